// One direction of the distortion: paper §6 (RMS and Hausdorff over nearest-point distances)
// and MPEG D1/D2 as mpeg-pcc-dmetric v0.14 computes them (source/pcc_distortion.cpp,
// findMetric): D1 = |a − b|², D2 = ((a − b) · n_b)² with b's normal, averaged over b's
// equidistant group as its default --averageNormals=1 does. docs/METRICS.md has the details.
#include "eval/directed_error.hpp"

#include <algorithm>
#include <cmath>

#include "core/parallel.hpp"

namespace sspc::eval {

namespace {

struct Sums {
  double d1 = 0;      // Σ min |a − b|²
  double d1_max = 0;  // max min |a − b|²
  double d2 = 0;      // Σ mean over the group of ((a − b) · n_b)²
  Sums& operator+=(const Sums& o) {
    d1 += o.d1;
    d1_max = std::max(d1_max, o.d1_max);
    d2 += o.d2;
    return *this;
  }
};

template <typename Normal>
DirectedError directed_error_impl(std::span<const Vec3f> from, std::span<const Vec3f> to,
                                  const NearestGroups& groups, std::span<const Normal> to_normals) {
  const bool with_d2 = !to_normals.empty();
  const Sums sums = deterministic_sum<Sums>(0, from.size(), [&](std::size_t a) {
    Sums s;
    s.d1 = groups.distance_squared[a];
    s.d1_max = s.d1;
    if (with_d2) {
      const Vec3d p = from[a].template cast<double>();
      double sum = 0;
      std::size_t members = 0;
      groups.for_each_member(a, [&](std::uint32_t b) {
        const double projected = (p - to[b].template cast<double>()).dot(to_normals[b].template cast<double>());
        sum += projected * projected;
        ++members;
      });
      s.d2 = sum / static_cast<double>(members);
    }
    return s;
  });
  const double n = static_cast<double>(from.size());
  DirectedError e;
  e.mse_d1 = sums.d1 / n;
  e.rms = std::sqrt(e.mse_d1);
  e.hausdorff = std::sqrt(sums.d1_max);
  e.has_d2 = with_d2;
  e.mse_d2 = with_d2 ? sums.d2 / n : 0.0;
  return e;
}

}  // namespace

DirectedError directed_error(std::span<const Vec3f> from, std::span<const Vec3f> to,
                             const NearestGroups& groups, std::span<const Vec3f> to_normals) {
  return directed_error_impl(from, to, groups, to_normals);
}

DirectedError directed_error(std::span<const Vec3f> from, std::span<const Vec3f> to,
                             const NearestGroups& groups, std::span<const Vec3d> to_normals) {
  return directed_error_impl(from, to, groups, to_normals);
}

}  // namespace sspc::eval
