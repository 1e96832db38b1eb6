#include "render/mls_surface.hpp"

#include <cmath>
#include <limits>

namespace sspc::render {

namespace {

// Neighbours a single evaluation averages over: enough for a smooth surface at h ≈ the
// spacing (weights fall to e^−4 at 2h), few enough to stay fast.
constexpr std::size_t kNeighbours = 16;
// Refinement steps once a crossing is bracketed.
constexpr int kMaxIterations = 12;

}  // namespace

MlsSurface::MlsSurface(std::span<const Vec3f> points, std::span<const Vec3f> normals, float bandwidth)
    : points_(points), normals_(normals), h_(bandwidth), reach_(3.0f * bandwidth), tree_(points) {}

bool MlsSurface::evaluate(const Vec3f& x, Vec3f& a, Vec3f& n) const {
  float nearest = 0;
  return evaluate(x, a, n, nearest);
}

bool MlsSurface::evaluate(const Vec3f& x, Vec3f& a, Vec3f& n, float& nearest) const {
  std::uint32_t idx[kNeighbours];
  float d2[kNeighbours];
  const std::size_t found = tree_.knn(x, kNeighbours, idx, d2);
  nearest = found == 0 ? std::numeric_limits<float>::infinity() : std::sqrt(d2[0]);
  if (found == 0 || d2[0] > reach_ * reach_) return false;
  const float inv_h2 = 1.0f / (h_ * h_);
  Vec3f sum_p = Vec3f::Zero(), sum_n = Vec3f::Zero();
  float sum_w = 0;
  for (std::size_t j = 0; j < found; ++j) {
    // Relative to the nearest point's weight, so that far queries do not underflow to 0/0.
    const float w = std::exp(-(d2[j] - d2[0]) * inv_h2);
    sum_p += w * points_[idx[j]];
    sum_n += w * normals_[idx[j]];
    sum_w += w;
  }
  a = sum_p / sum_w;
  n = sum_n;
  return n.squaredNorm() > 0;
}

std::optional<SurfaceHit> MlsSurface::intersect(const Vec3f& o, const Vec3f& d, float t_min,
                                                float t_max) const {
  if (tree_.size() == 0) return std::nullopt;
  SurfaceHit hit;
  // The signed distance to the local plane, f(x) = n(x)·(x − a(x)), positive on the side the
  // normals face; false where the surface is undefined.
  Vec3f a, n;
  float nearest = 0;
  const auto f_at = [&](float t, float& f) {
    ++hit.evaluations;
    const Vec3f x = o + t * d;
    if (!evaluate(x, a, n, nearest)) return false;
    n.normalize();
    f = n.dot(x - a);
    return true;
  };
  float t = t_min;
  bool have_previous = false;
  float t_previous = 0, f_previous = 0;
  bool near_points = false;  // the last sample had a point within reach
  while (t <= t_max) {
    if (!near_points) {
      // In empty space a nearest-point query is enough to take the next step.
      float d2 = 0;
      tree_.nearest(o + t * d, &d2);
      nearest = std::sqrt(d2);
      if (nearest > reach_) {
        t += std::max(nearest - reach_, 0.25f * h_);
        continue;
      }
    }
    float f = 0;
    near_points = f_at(t, f);
    if (!near_points) {
      // No point within reach: the surface cannot be nearer than nearest − reach.
      t += std::max(nearest - reach_, 0.25f * h_);
      have_previous = false;
      continue;
    }
    if (have_previous && (f > 0) != (f_previous > 0)) {
      // f changed sign between the last two samples: the surface is in between. Regula falsi
      // with the Illinois rule (the end that stays is halved), a handful of evaluations.
      float lo = t_previous, f_lo = f_previous, hi = t, f_hi = f;
      float s = hi;
      int kept = 0;  // which end stayed last: −1 lo, +1 hi
      for (int it = 0; it < kMaxIterations; ++it) {
        s = lo - f_lo * (hi - lo) / (f_hi - f_lo);
        float f_s = 0;
        if (!f_at(s, f_s)) break;
        if (std::abs(f_s) < 1e-5f * h_ || hi - lo < 1e-5f * h_) break;
        if ((f_s > 0) == (f_lo > 0)) {
          lo = s;
          f_lo = f_s;
          if (kept == 1) f_hi *= 0.5f;
          kept = 1;
        } else {
          hi = s;
          f_hi = f_s;
          if (kept == -1) f_lo *= 0.5f;
          kept = -1;
        }
      }
      float f_s = 0;
      if (s >= t_min && s <= t_max && f_at(s, f_s)) {
        hit.t = s;
        hit.normal = n.dot(d) > 0 ? Vec3f(-n) : n;
        return hit;
      }
    }
    have_previous = true;
    t_previous = t;
    f_previous = f;
    // At least half the bandwidth, and up to 90% of the distance to the local plane (along the
    // ray the plane is at least that far): a surface is found unless two crossings lie closer
    // than the step.
    t += std::max(0.5f * h_, 0.9f * std::abs(f));
  }
  return std::nullopt;
}

}  // namespace sspc::render
