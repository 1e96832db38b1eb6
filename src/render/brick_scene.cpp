#include "render/brick_scene.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

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
  edge_ = edge;
  bandwidth_ = bandwidth;
  budget_ = budget_bytes;
  origin_ = bounds.min();
  const Vec3f extent = bounds.max() - bounds.min();
  double total = 1;
  for (int a = 0; a < 3; ++a) {
    const double cells = std::ceil(static_cast<double>(extent[a]) / static_cast<double>(edge) + 1e-6);
    if (!(cells <= 1e7)) return invalid_argument("the scene spans too many bricks");
    dims_[a] = std::max(1, static_cast<int>(cells));
    total *= dims_[a];
  }
  if (total > 1e7) return invalid_argument("the scene spans too many bricks");
  occupied_.assign(static_cast<std::size_t>(total), false);
  return Status();
}

Box3f BrickScene::surface_bounds() const {
  const Box3f grid(origin_, origin_ + edge_ * Vec3f(static_cast<float>(dims_[0]), static_cast<float>(dims_[1]),
                                                    static_cast<float>(dims_[2])));
  return grid.merged(bounds_);
}

int BrickScene::brick_coordinate(float v, int axis) const {
  const float c = std::floor((v - origin_[axis]) / edge_);
  if (!(c > 0)) return 0;
  if (c >= static_cast<float>(dims_[axis] - 1)) return dims_[axis] - 1;
  return static_cast<int>(c);
}

Box3f BrickScene::brick_box(std::size_t b) const {
  const auto x = static_cast<int>(b % static_cast<std::size_t>(dims_[0]));
  const auto y = static_cast<int>((b / static_cast<std::size_t>(dims_[0])) % static_cast<std::size_t>(dims_[1]));
  const auto z = static_cast<int>(b / (static_cast<std::size_t>(dims_[0]) * static_cast<std::size_t>(dims_[1])));
  const Vec3f lo = origin_ + edge_ * Vec3f(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z));
  return Box3f(lo, lo + Vec3f::Constant(edge_));
}

StatusOr<BrickScene::SurfacePtr> BrickScene::surface(std::size_t b) const {
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
  isolated([&] { built = load(b); });
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
  peak_cached_bytes_ = std::max(peak_cached_bytes_, cached_bytes_);
  return built;
}

// The scene's surface as march_ray (render/mls_march.hpp) asks for it, for one ray: a point is
// evaluated in the surface of the brick that holds it, which holds every point within the
// support radius of the brick, so the march samples what the whole cloud's surface would give
// there, bracket by bracket across the bricks' faces. The bricks it last used are kept, as a
// bracket that straddles a face goes back and forth between two.
class BrickScene::Field {
 public:
  explicit Field(const BrickScene& scene) : scene_(scene) {}

  float bandwidth() const { return scene_.bandwidth_; }
  const Status& status() const { return status_; }

  bool evaluate(const Vec3f& x, const Vec3f& facing, Vec3f& a, Vec3f& n, float& support) const {
    const MlsSurface* s = at(x);
    return s != nullptr && s->evaluate(x, facing, a, n, support);
  }

  float empty_until(const Vec3f& o, const Vec3f& d, float t, float t_max) const {
    const Vec3f x = o + t * d;
    int c[3];
    if (!locate(x, c)) return std::numeric_limits<float>::infinity();  // beyond every brick
    const float exit = std::max(exit_of(c, o, d), t) + 1e-3f * scene_.edge_;
    const std::size_t b = scene_.brick_index(c[0], c[1], c[2]);
    if (!scene_.occupied_[b]) return exit;
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
  // scene_.brick_of(x, c), answered without its three divisions while x stays well inside the
  // brick last found (7.5% of a compressed render of dragon_scans at level 5 went to brick_of;
  // a march samples a brick many times in a row). "Well inside" by a margin far above the
  // rounding of brick_of's arithmetic, so the answer is always brick_of's.
  bool locate(const Vec3f& x, int c[3]) const {
    if (x.x() > inner_lo_.x() && x.x() < inner_hi_.x() && x.y() > inner_lo_.y() && x.y() < inner_hi_.y() &&
        x.z() > inner_lo_.z() && x.z() < inner_hi_.z()) {
      std::copy(last_, last_ + 3, c);
      return true;
    }
    if (!scene_.brick_of(x, c)) return false;
    std::copy(c, c + 3, last_);
    const float edge = scene_.edge_;
    for (int a = 0; a < 3; ++a) {
      const float lo = scene_.origin_[a] + static_cast<float>(c[a]) * edge;
      const float margin =
          1e-3f * edge + 4e-7f * (std::abs(scene_.origin_[a]) + std::abs(lo) + (static_cast<float>(c[a]) + 1) * edge);
      inner_lo_[a] = lo + margin;
      inner_hi_[a] = lo + edge - margin;  // empty (lo > hi) when the margin is the brick's size
    }
    return true;
  }
  // Where the ray leaves brick c.
  float exit_of(const int c[3], const Vec3f& o, const Vec3f& d) const {
    Vec3f lo, hi;
    for (int a = 0; a < 3; ++a) {
      lo[a] = scene_.origin_[a] + static_cast<float>(c[a]) * scene_.edge_;
      hi[a] = scene_.origin_[a] + static_cast<float>(c[a] + 1) * scene_.edge_;
    }
    return exit_from_box(lo, hi, o, d, std::numeric_limits<float>::infinity());
  }
  // The surface of the occupied brick holding x, else null.
  const MlsSurface* at(const Vec3f& x) const {
    int c[3];
    if (!locate(x, c)) return nullptr;
    const std::size_t b = scene_.brick_index(c[0], c[1], c[2]);
    return scene_.occupied_[b] ? surface(b) : nullptr;
  }
  const MlsSurface* surface(std::size_t b) const {
    for (const auto& [brick, held] : recent_) {
      if (brick == b && held != nullptr) return held.get();
    }
    if (!status_.ok()) return nullptr;
    StatusOr<SurfacePtr> s = scene_.surface(b);
    if (!s.ok()) {
      status_ = s.status();
      return nullptr;
    }
    recent_[1] = std::move(recent_[0]);
    recent_[0] = {b, std::move(s).value()};
    return recent_[0].second.get();
  }

  const BrickScene& scene_;
  // The brick locate() last found, and the part of its box where its answer needs no division
  // (empty before the first).
  mutable int last_[3] = {0, 0, 0};
  mutable Vec3f inner_lo_ = Vec3f::Constant(std::numeric_limits<float>::infinity());
  mutable Vec3f inner_hi_ = Vec3f::Constant(-std::numeric_limits<float>::infinity());
  mutable std::pair<std::size_t, SurfacePtr> recent_[2];
  mutable Status status_;
};

bool BrickScene::brick_of(const Vec3f& x, int c[3]) const {
  for (int a = 0; a < 3; ++a) {
    const float v = std::floor((x[a] - origin_[a]) / edge_);
    if (!(v >= 0) || !(v < static_cast<float>(dims_[a]))) return false;
    c[a] = static_cast<int>(v);
  }
  return true;
}

StatusOr<std::optional<RayHit>> BrickScene::trace(const Field& field, const Vec3f& eye, const Vec3f& d, float t_min,
                                                  float t_max, bool want_id, std::uint64_t& evaluations) const {
  const std::optional<RayHit> miss;
  // The ray's interval in the grid of bricks.
  float t0 = std::max(t_min, 0.0f), t1 = t_max;
  const Vec3f far_corner = origin_ + edge_ * Vec3f(static_cast<float>(dims_[0]), static_cast<float>(dims_[1]),
                                                   static_cast<float>(dims_[2]));
  if (!clip_to_box(origin_, far_corner, eye, d, t0, t1)) return miss;
  const auto hit = march_ray(field, eye, d, t0, t1);
  SSPC_RETURN_IF_ERROR(field.status());
  if (!hit) return miss;
  evaluations += static_cast<std::uint64_t>(hit->evaluations);
  return std::optional<RayHit>(RayHit{hit->t, hit->normal, want_id ? field.nearest_id(eye + hit->t * d) : 0});
}

StatusOr<std::optional<RayHit>> BrickScene::intersect(const Vec3f& origin, const Vec3f& direction, float t_min,
                                                      float t_max) const {
  SSPC_ASSIGN_OR_RETURN(const UnitRay ray, UnitRay::make(origin, direction, t_min, t_max));
  std::uint64_t evaluations = 0;
  const Field field(*this);
  SSPC_ASSIGN_OR_RETURN(std::optional<RayHit> hit,
                        trace(field, ray.origin, ray.direction, ray.t_min, ray.t_max, true, evaluations));
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
  // One Field for each stretch of tiles a thread traces, not one a ray: the bricks it holds stay
  // at hand from ray to ray without the cache's lock. Made a ray, every ray took the lock and
  // copied a brick's shared pointer, and on 2 threads the compressed dragon_scans (level 5,
  // 1024², bricks built) rendered in 1.4x the CPU time of 1 thread.
  Image image = trace_image(
      o, camera,
      [&] {
        return [&, field = std::make_unique<Field>(*this)](int px, int py, Frame& frame, std::uint64_t& evaluations) {
          auto hit = trace(*field, camera.eye(), camera.direction(px, py), 0, std::numeric_limits<float>::infinity(),
                           want_id, evaluations);
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
    stats->scene_bytes = memory_bytes_ + peak_cached_bytes_ + source_peak_bytes();
    stats->bytes_read = bytes_loaded() - read_before;
    stats->pages_read = loads_ - loads_before;
  }
  return image;
}

}  // namespace sspc::render
