#include "render/brick_scene.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "core/parallel.hpp"
#include "render/camera.hpp"
#include "render/shading.hpp"

namespace sspc::render {

namespace {

// Bricks a cache holds whatever its budget (see BrickScene::surface).
constexpr std::size_t kMinBricks = 8;

}  // namespace

Status BrickScene::layout(const Box3f& bounds, float edge, float bandwidth, std::uint64_t budget_bytes) {
  if (bounds_.isEmpty()) bounds_ = bounds;
  budget_ = budget_bytes;
  Grid& grid = grids_[0];
  grid.origin = bounds.min();
  grid.edge = edge;
  grid.bandwidth = bandwidth;
  const Vec3f extent = bounds.max() - bounds.min();
  double total = 1;
  for (int a = 0; a < 3; ++a) {
    const double cells = std::ceil(static_cast<double>(extent[a]) / static_cast<double>(edge) + 1e-6);
    if (!(cells <= 1e7)) return invalid_argument("the scene spans too many bricks");
    grid.dims[a] = std::max(1, static_cast<int>(cells));
    total *= grid.dims[a];
  }
  if (total > 1e7) return invalid_argument("the scene spans too many bricks");
  grid.occupied.assign(static_cast<std::size_t>(total), false);
  return Status();
}

void BrickScene::add_levels(int count, float cell, float bandwidth) {
  grids_.resize(1);
  grids_.reserve(static_cast<std::size_t>(std::max(count, 1)));  // `fine` stays where it is
  const Grid& fine = grids_[0];
  for (int level = 1; level < count; ++level) {
    const int scale = 1 << level;
    Grid grid;
    grid.origin = fine.origin;
    grid.edge = fine.edge * static_cast<float>(scale);
    grid.cell = cell * static_cast<float>(scale / 2);
    grid.bandwidth = bandwidth * static_cast<float>(scale / 2);
    for (int a = 0; a < 3; ++a) grid.dims[a] = (fine.dims[a] + scale - 1) / scale;
    const Grid& above = grids_.back();
    grid.first_key = above.first_key + above.occupied.size();
    grid.occupied.assign(static_cast<std::size_t>(grid.dims[0]) * static_cast<std::size_t>(grid.dims[1]) *
                             static_cast<std::size_t>(grid.dims[2]),
                         false);
    // Each occupied level-0 brick marks the coarse bricks whose boxes lie within the coarse
    // support radius of it, in level-0 bricks.
    const float support = MlsSurface(std::span<const Vec3f>(), std::span<const Vec3f>(), grid.bandwidth).support_radius();
    const int reach = static_cast<int>(std::min(std::ceil(support / fine.edge), 1e6f));
    for (int z = 0; z < fine.dims[2]; ++z) {
      for (int y = 0; y < fine.dims[1]; ++y) {
        for (int x = 0; x < fine.dims[0]; ++x) {
          if (!fine.occupied[fine.index(x, y, z)]) continue;
          const int lo[3] = {std::max(0, x - reach) / scale, std::max(0, y - reach) / scale, std::max(0, z - reach) / scale};
          const int hi[3] = {std::min(grid.dims[0] - 1, (x + reach) / scale), std::min(grid.dims[1] - 1, (y + reach) / scale),
                             std::min(grid.dims[2] - 1, (z + reach) / scale)};
          for (int cz = lo[2]; cz <= hi[2]; ++cz) {
            for (int cy = lo[1]; cy <= hi[1]; ++cy) {
              for (int cx = lo[0]; cx <= hi[0]; ++cx) grid.occupied[grid.index(cx, cy, cz)] = true;
            }
          }
        }
      }
    }
    grids_.push_back(std::move(grid));
  }
}

Box3f BrickScene::surface_bounds() const {
  return Box3f(grids_[0].origin, grids_[0].far_corner()).merged(bounds_);
}

int BrickScene::Grid::coordinate(float v, int axis) const {
  const float c = std::floor((v - origin[axis]) / edge);
  if (!(c > 0)) return 0;
  if (c >= static_cast<float>(dims[axis] - 1)) return dims[axis] - 1;
  return static_cast<int>(c);
}

Box3f BrickScene::Grid::box(std::size_t b) const {
  const auto x = static_cast<int>(b % static_cast<std::size_t>(dims[0]));
  const auto y = static_cast<int>((b / static_cast<std::size_t>(dims[0])) % static_cast<std::size_t>(dims[1]));
  const auto z = static_cast<int>(b / (static_cast<std::size_t>(dims[0]) * static_cast<std::size_t>(dims[1])));
  const Vec3f lo = origin + edge * Vec3f(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z));
  return Box3f(lo, lo + Vec3f::Constant(edge));
}

bool BrickScene::Grid::of(const Vec3f& x, int c[3]) const {
  for (int a = 0; a < 3; ++a) {
    const float v = std::floor((x[a] - origin[a]) / edge);
    if (!(v >= 0) || !(v < static_cast<float>(dims[a]))) return false;
    c[a] = static_cast<int>(v);
  }
  return true;
}

StatusOr<BrickScene::SurfacePtr> BrickScene::surface(int level, std::size_t brick) const {
  const std::size_t b = grids_[static_cast<std::size_t>(level)].first_key + brick;
  std::promise<StatusOr<SurfacePtr>> promise;
  std::shared_future<StatusOr<SurfacePtr>> pending;
  {
    std::lock_guard lock(mutex_);
    if (auto it = cache_.find(b); it != cache_.end()) {
      if (it->second.built) lru_.splice(lru_.begin(), lru_, it->second.lru);
      pending = it->second.surface;
    } else {
      Entry entry;
      entry.surface = promise.get_future().share();
      cache_.emplace(b, entry);
    }
  }
  // Another thread builds it, or has: wait for it. Waiting cannot deadlock: a builder never
  // waits for another brick.
  if (pending.valid()) return pending.get();

  StatusOr<SurfacePtr> built = internal_error("not built");
  isolated([&] { built = load(level, brick); });
  promise.set_value(built);
  ++loads_;
  std::lock_guard lock(mutex_);
  auto it = cache_.find(b);
  if (!built.ok()) {
    cache_.erase(it);  // the next ray tries again, and fails the same way
    return built;
  }
  lru_.push_front(b);
  it->second.lru = lru_.begin();
  it->second.built = true;
  cached_bytes_ += (*built)->memory_bytes();
  // Evict the least recently used until within the budget, but keep the last kMinBricks: a
  // budget below what the rays of a few rows cross would otherwise evict a brick between two
  // neighbouring rays and rebuild it for every pixel (a 96² sphere under a 64 KiB budget took
  // minutes instead of a second). Threads still tracing an evicted brick keep it alive through
  // their pointer.
  while (cached_bytes_ > budget_ && lru_.size() > kMinBricks) {
    const std::size_t victim = lru_.back();
    lru_.pop_back();
    auto v = cache_.find(victim);
    cached_bytes_ -= v->second.surface.get().value()->memory_bytes();
    cache_.erase(v);
  }
  peak_held_bytes_ = std::max(peak_held_bytes_, cached_bytes_ + source_bytes());
  bricks_resized(cached_bytes_);
  return built;
}

// One level's surface as march_ray (render/mls_march.hpp) asks for it, for one thread's rays: a
// point is evaluated in the surface of the brick that holds it, which holds every point within
// the support radius of the brick, so the march samples what the whole cloud's surface would
// give there, bracket by bracket across the bricks' faces. The bricks it last used are kept, as
// a bracket that straddles a face goes back and forth between two.
class BrickScene::Field {
 public:
  Field(const BrickScene& scene, int level)
      : scene_(scene), grid_(scene.grids_[static_cast<std::size_t>(level)]), level_(level) {}

  float bandwidth() const { return grid_.bandwidth; }
  const Status& status() const { return status_; }

  bool evaluate(const Vec3f& x, const Vec3f& facing, Vec3f& a, Vec3f& n, float& support) const {
    const MlsSurface* s = at(x);
    return s != nullptr && s->evaluate(x, facing, a, n, support);
  }

  float empty_until(const Vec3f& o, const Vec3f& d, float t, float t_max) const {
    const Vec3f x = o + t * d;
    int c[3];
    if (!locate(x, c)) return std::numeric_limits<float>::infinity();  // beyond every brick
    const float exit = std::max(exit_of(c, o, d), t) + 1e-3f * grid_.edge;
    const std::size_t b = grid_.index(c[0], c[1], c[2]);
    if (!grid_.occupied[b]) return exit;
    const MlsSurface* s = surface(b);
    if (s == nullptr) return std::numeric_limits<float>::infinity();  // failed: the march ends
    // A cell of the brick's surface near none of its points is near no point of the cloud only
    // inside the brick: the skip stops at the brick's face.
    const float until = s->empty_until(o, d, t, t_max);
    return until > t ? std::min(until, exit) : t;
  }

  float skip_until(const Vec3f& o, const Vec3f& d, float t, float t_max) const {
    const Vec3f x = o + t * d;
    int c[3];
    if (!locate(x, c)) return t;
    const MlsSurface* s = at(x);
    if (s == nullptr) return t;
    return std::min(s->skip_until(o, d, t, t_max), std::max(exit_of(c, o, d), t));
  }

  std::uint32_t nearest_id(const Vec3f& x) const {
    const MlsSurface* s = at(x);
    return s != nullptr ? s->nearest_id(x) : 0;
  }

 private:
  // grid_.of(x, c), answered without its three divisions while x stays well inside the brick
  // last found (7.5% of a compressed render of dragon_scans at level 5 went to finding bricks;
  // a march samples a brick many times in a row). "Well inside" by a margin far above the
  // rounding of Grid::of's arithmetic, so the answer is always its.
  bool locate(const Vec3f& x, int c[3]) const {
    if (x.x() > inner_lo_.x() && x.x() < inner_hi_.x() && x.y() > inner_lo_.y() && x.y() < inner_hi_.y() &&
        x.z() > inner_lo_.z() && x.z() < inner_hi_.z()) {
      std::copy(last_, last_ + 3, c);
      return true;
    }
    if (!grid_.of(x, c)) return false;
    std::copy(c, c + 3, last_);
    const float edge = grid_.edge;
    for (int a = 0; a < 3; ++a) {
      const float lo = grid_.origin[a] + static_cast<float>(c[a]) * edge;
      const float margin =
          1e-3f * edge + 4e-7f * (std::abs(grid_.origin[a]) + std::abs(lo) + (static_cast<float>(c[a]) + 1) * edge);
      inner_lo_[a] = lo + margin;
      inner_hi_[a] = lo + edge - margin;  // empty (lo > hi) when the margin is the brick's size
    }
    return true;
  }
  // Where the ray leaves brick c.
  float exit_of(const int c[3], const Vec3f& o, const Vec3f& d) const {
    Vec3f lo, hi;
    for (int a = 0; a < 3; ++a) {
      lo[a] = grid_.origin[a] + static_cast<float>(c[a]) * grid_.edge;
      hi[a] = grid_.origin[a] + static_cast<float>(c[a] + 1) * grid_.edge;
    }
    return exit_from_box(lo, hi, o, d, std::numeric_limits<float>::infinity());
  }
  // The surface of the occupied brick holding x, else null.
  const MlsSurface* at(const Vec3f& x) const {
    int c[3];
    if (!locate(x, c)) return nullptr;
    const std::size_t b = grid_.index(c[0], c[1], c[2]);
    return grid_.occupied[b] ? surface(b) : nullptr;
  }
  const MlsSurface* surface(std::size_t b) const {
    for (const auto& [brick, held] : recent_) {
      if (brick == b && held != nullptr) return held.get();
    }
    if (!status_.ok()) return nullptr;
    StatusOr<SurfacePtr> s = scene_.surface(level_, b);
    if (!s.ok()) {
      status_ = s.status();
      return nullptr;
    }
    recent_[1] = std::move(recent_[0]);
    recent_[0] = {b, std::move(s).value()};
    return recent_[0].second.get();
  }

  const BrickScene& scene_;
  const Grid& grid_;
  int level_;
  // The brick locate() last found, and the part of its box where its answer needs no division
  // (empty before the first).
  mutable int last_[3] = {0, 0, 0};
  mutable Vec3f inner_lo_ = Vec3f::Constant(std::numeric_limits<float>::infinity());
  mutable Vec3f inner_hi_ = Vec3f::Constant(-std::numeric_limits<float>::infinity());
  mutable std::pair<std::size_t, SurfacePtr> recent_[2];
  mutable Status status_;
};

StatusOr<std::optional<RayHit>> BrickScene::trace(Fields& fields, std::span<const float> starts, const Vec3f& eye,
                                                  const Vec3f& d, float t_min, float t_max, bool want_id,
                                                  std::uint64_t& evaluations) const {
  const std::optional<RayHit> miss;
  // The ray's interval in the grid of bricks.
  float t0 = std::max(t_min, 0.0f), t1 = t_max;
  if (!clip_to_box(grids_[0].origin, grids_[0].far_corner(), eye, d, t0, t1)) return miss;
  // Level by level: level l from starts[l], less its bandwidth (a crossing that level l − 1's
  // last samples had not bracketed is found from just before), to the next level's start.
  for (std::size_t level = 0; level < starts.size(); ++level) {
    const float end = level + 1 < starts.size() ? std::min(t1, starts[level + 1]) : t1;
    const float begin = level == 0 ? t0 : std::max(t0, starts[level] - grids_[level].bandwidth);
    if (begin > end) continue;
    if (fields[level] == nullptr) fields[level] = std::make_unique<Field>(*this, static_cast<int>(level));
    const Field& field = *fields[level];
    const auto hit = march_ray(field, eye, d, begin, end, &evaluations);
    SSPC_RETURN_IF_ERROR(field.status());
    if (hit) {
      return std::optional<RayHit>(RayHit{hit->t, hit->normal, want_id ? field.nearest_id(eye + hit->t * d) : 0});
    }
    if (end >= t1) break;
  }
  return miss;
}

std::vector<float> BrickScene::level_starts(const FrameOptions& o) const {
  std::vector<float> starts{0.0f};
  if (!(o.level_of_detail > 0)) return starts;
  // A pixel at distance t spans about t·θ (θ the angle of the image's central pixel); level l's
  // points lie about a cell apart, so it is used from where a cell spans level_of_detail pixels.
  const double theta =
      2 * std::tan(0.5 * static_cast<double>(o.camera.fov_degrees) * std::numbers::pi / 180) / o.height;
  for (std::size_t level = 1; level < grids_.size(); ++level) {
    const double cell = static_cast<double>(grids_[level].cell);
    starts.push_back(static_cast<float>(cell / (static_cast<double>(o.level_of_detail) * theta)));
  }
  return starts;
}

StatusOr<std::optional<RayHit>> BrickScene::intersect(const Vec3f& origin, const Vec3f& direction, float t_min,
                                                      float t_max) const {
  SSPC_ASSIGN_OR_RETURN(const UnitRay ray, UnitRay::make(origin, direction, t_min, t_max));
  std::uint64_t evaluations = 0;
  Fields fields(1);
  const float level0 = 0;
  SSPC_ASSIGN_OR_RETURN(std::optional<RayHit> hit, trace(fields, std::span<const float>(&level0, 1), ray.origin,
                                                         ray.direction, ray.t_min, ray.t_max, true, evaluations));
  if (hit) hit->t /= ray.scale;
  return hit;
}

StatusOr<Image> BrickScene::render(const FrameOptions& o, RenderStats* stats) const {
  SSPC_RETURN_IF_ERROR(check_frame(o));
  const PinholeCamera camera(o.camera, o.width, o.height);
  const std::uint64_t read_before = bytes_loaded(), loads_before = loads_;
  std::mutex failure_mutex;
  Status failure;
  const bool want_id = o.shade == Shade::kCodeword;
  const std::vector<float> starts = level_starts(o);
  // One Field for each stretch of tiles a thread traces, not one a ray: the bricks it holds stay
  // at hand from ray to ray without the cache's lock. Made a ray, every ray took the lock and
  // copied a brick's shared pointer, and on 2 threads the compressed dragon_scans (level 5,
  // 1024², bricks built) rendered in 1.4x the CPU time of 1 thread.
  Image image = trace_image(
      o, camera,
      [&] {
        return [&, fields = Fields(starts.size())](int px, int py, Frame& frame, std::uint64_t& evaluations) mutable {
          auto hit = trace(fields, starts, camera.eye(), camera.direction(px, py), 0,
                           std::numeric_limits<float>::infinity(), want_id, evaluations);
          if (!hit.ok()) {
            std::lock_guard lock(failure_mutex);
            if (failure.ok()) failure = hit.status();
            return false;
          }
          if (!*hit) return false;
          frame.set(px, py, (*hit)->t, (*hit)->normal, (*hit)->id);
          return true;
        };
      },
      stats);
  SSPC_RETURN_IF_ERROR(failure);
  if (stats != nullptr) {
    stats->build_seconds = build_seconds_;
    std::lock_guard lock(mutex_);
    peak_held_bytes_ = std::max(peak_held_bytes_, cached_bytes_ + source_bytes());
    stats->scene_bytes = memory_bytes_ + peak_held_bytes_;
    stats->bytes_read = bytes_loaded() - read_before;
    stats->pages_read = loads_ - loads_before;
  }
  return image;
}

}  // namespace sspc::render
