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

Status BrickScene::layout(const Box3f& bounds, float edge, std::uint64_t budget_bytes) {
  if (bounds_.isEmpty()) bounds_ = bounds;
  edge_ = edge;
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

StatusOr<std::optional<RayHit>> BrickScene::trace(const Vec3f& eye, const Vec3f& d, float t_min, float t_max,
                                                  bool want_id, std::uint64_t& evaluations) const {
  const std::optional<RayHit> miss;
  // The ray's interval in the grid of bricks.
  float t0 = std::max(t_min, 0.0f), t1 = t_max;
  for (int a = 0; a < 3; ++a) {
    const float lo = origin_[a], hi = origin_[a] + static_cast<float>(dims_[a]) * edge_;
    if (d[a] == 0) {
      if (eye[a] < lo || eye[a] > hi) return miss;
      continue;
    }
    float near = (lo - eye[a]) / d[a], far = (hi - eye[a]) / d[a];
    if (near > far) std::swap(near, far);
    t0 = std::max(t0, near);
    t1 = std::min(t1, far);
  }
  if (!(t0 <= t1)) return miss;
  // 3D DDA over the bricks, front to back: the first brick with a hit has the first hit.
  const Vec3f start = eye + t0 * d;
  int c[3], step[3];
  float next[3], delta[3];
  for (int a = 0; a < 3; ++a) {
    c[a] = brick_coordinate(start[a], a);
    step[a] = d[a] > 0 ? 1 : -1;
    const float boundary = origin_[a] + static_cast<float>(c[a] + (d[a] > 0 ? 1 : 0)) * edge_;
    next[a] = d[a] != 0 ? (boundary - eye[a]) / d[a] : std::numeric_limits<float>::infinity();
    delta[a] = d[a] != 0 ? edge_ / std::abs(d[a]) : std::numeric_limits<float>::infinity();
  }
  float t = t0;
  while (t <= t1) {
    const int axis = next[0] < next[1] ? (next[0] < next[2] ? 0 : 2) : (next[1] < next[2] ? 1 : 2);
    const float exit = std::min(next[axis], t1);
    const std::size_t b = brick_index(c[0], c[1], c[2]);
    if (occupied_[b]) {
      SSPC_ASSIGN_OR_RETURN(const SurfacePtr s, surface(b));
      const auto hit = s->intersect(eye, d, t, exit);
      if (hit) {
        evaluations += static_cast<std::uint64_t>(hit->evaluations);
        return std::optional<RayHit>(RayHit{hit->t, hit->normal, want_id ? s->nearest_id(eye + hit->t * d) : 0});
      }
    }
    t = next[axis];
    next[axis] += delta[axis];
    c[axis] += step[axis];
    if (c[axis] < 0 || c[axis] >= dims_[axis]) break;
  }
  return miss;
}

StatusOr<std::optional<RayHit>> BrickScene::intersect(const Vec3f& origin, const Vec3f& direction, float t_min,
                                                      float t_max) const {
  SSPC_ASSIGN_OR_RETURN(const UnitRay ray, UnitRay::make(origin, direction, t_min, t_max));
  std::uint64_t evaluations = 0;
  SSPC_ASSIGN_OR_RETURN(std::optional<RayHit> hit, trace(ray.origin, ray.direction, ray.t_min, ray.t_max, true, evaluations));
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
  Image image = trace_image(
      o, camera,
      [&](int px, int py, Frame& frame, std::uint64_t& evaluations) {
        auto hit = trace(camera.eye(), camera.direction(px, py), 0, std::numeric_limits<float>::infinity(), want_id,
                         evaluations);
        if (!hit.ok()) {
          std::lock_guard lock(failure_mutex);
          if (failure.ok()) failure = hit.status();
          return false;
        }
        if (!*hit) return false;
        frame.set(px, py, (*hit)->t, (*hit)->normal, (*hit)->id);
        return true;
      },
      stats);
  SSPC_RETURN_IF_ERROR(failure);
  if (stats != nullptr) {
    stats->build_seconds = build_seconds_;
    std::lock_guard lock(mutex_);
    stats->scene_bytes = memory_bytes_ + peak_cached_bytes_;
    stats->bytes_read = bytes_loaded() - read_before;
    stats->pages_read = loads_ - loads_before;
  }
  return image;
}

}  // namespace sspc::render
