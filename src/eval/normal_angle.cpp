// Normals' angular error (definition in docs/METRICS.md, "Normals' angular error").
#include "eval/normal_angle.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "core/parallel.hpp"

namespace sspc::eval {

double angle_degrees(const Vec3d& a, const Vec3d& b) {
  if (a.squaredNorm() == 0 || b.squaredNorm() == 0) return std::numeric_limits<double>::quiet_NaN();
  // atan2(|a × b|, a · b) keeps full precision near 0° and 180°, where acos of a rounded cosine
  // loses half the digits, and needs no normalisation.
  return std::atan2(a.cross(b).norm(), a.dot(b)) * (180.0 / std::numbers::pi);
}

NormalAngleStats normal_angle_error(std::span<const Vec3f> test_normals,
                                    std::span<const Vec3f> ref_normals,
                                    const NearestGroups& test_to_ref) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> angles(test_normals.size(), nan);
  parallel_for(0, test_normals.size(), 4096, [&](std::size_t t) {
    const Vec3d n = test_normals[t].cast<double>();
    double sum = 0;
    std::size_t members = 0;
    test_to_ref.for_each_member(t, [&](std::uint32_t r) {
      const double angle = angle_degrees(n, ref_normals[r].cast<double>());
      if (std::isnan(angle)) return;
      sum += angle;
      ++members;
    });
    if (members > 0) angles[t] = sum / static_cast<double>(members);
  });

  struct Acc {
    double sum = 0;
    std::uint64_t count = 0;
    Acc& operator+=(const Acc& o) {
      sum += o.sum;
      count += o.count;
      return *this;
    }
  };
  const Acc acc = deterministic_sum<Acc>(0, angles.size(), [&](std::size_t t) {
    return std::isnan(angles[t]) ? Acc{} : Acc{angles[t], 1};
  });

  NormalAngleStats stats;
  stats.points = acc.count;
  if (acc.count == 0) return stats;
  stats.mean_deg = acc.sum / static_cast<double>(acc.count);
  std::erase_if(angles, [](double a) { return std::isnan(a); });
  // Nearest rank: the smallest angle that at least 95% of the points do not exceed, i.e. the
  // ceil(0.95·n)-th smallest (1-based). An order statistic is one value whatever the order.
  const std::size_t rank = (95 * angles.size() + 99) / 100;
  auto nth = angles.begin() + static_cast<std::ptrdiff_t>(rank - 1);
  std::nth_element(angles.begin(), nth, angles.end());
  stats.p95_deg = *nth;
  return stats;
}

}  // namespace sspc::eval
