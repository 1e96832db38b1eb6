#include "encoder/canonical_frame.hpp"

#include <cmath>


namespace sspc {

namespace {

// Below this resultant length the circular mean is noise (azimuths spread all round).
constexpr double kCircularMeanFloor = 0.15;
// Normals closer to +Z than this have no usable azimuth.
constexpr double kTiltFloor = 1e-4;

// The shortest-arc rotation taking unit m to +Z (Rodrigues' formula), or a half turn about X
// when m is (nearly) −Z. Written out rather than Eigen's Quaterniond::FromTwoVectors, whose
// antiparallel case instantiates a JacobiSVD: this file took 24 s to compile, the slowest of
// the library by twice.
Eigen::Matrix3d rotation_to_z(const Vec3d& m) {
  const double c = m.z();
  if (c < -1 + 1e-12) return Eigen::Vector3d(1, -1, -1).asDiagonal();
  const Vec3d v(m.y(), -m.x(), 0);  // m × z
  Eigen::Matrix3d k;
  k << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return Eigen::Matrix3d::Identity() + k + k * k / (1 + c);
}

}  // namespace

CanonicalFrame canonical_frame(std::span<const Vec3f> positions, std::span<const Vec3f> normals,
                               std::span<const std::uint32_t> indices) {
  CanonicalFrame frame;
  if (indices.empty()) return frame;

  Vec3d centroid = Vec3d::Zero();
  Vec3d normal_sum = Vec3d::Zero();
  for (std::uint32_t i : indices) {
    centroid += positions[i].cast<double>();
    normal_sum += normals[i].cast<double>();
  }
  centroid /= static_cast<double>(indices.size());
  const Vec3d mean_normal =
      normal_sum.norm() > 1e-12 ? Vec3d(normal_sum.normalized()) : Vec3d(Vec3d::UnitZ());

  // Rotation taking the mean normal to +Z (the shortest arc).
  const Eigen::Matrix3d up_from_world = rotation_to_z(mean_normal);

  double sum_cos = 0, sum_sin = 0, count = 0;
  Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
  for (std::uint32_t i : indices) {
    const Vec3d n = up_from_world * normals[i].cast<double>();
    const double tilt = std::hypot(n.x(), n.y());
    if (tilt < kTiltFloor) continue;
    sum_cos += n.x() / tilt;
    sum_sin += n.y() / tilt;
    count += 1;
    scatter += Eigen::Vector2d(n.x(), n.y()) * Eigen::Vector2d(n.x(), n.y()).transpose();
  }
  double azimuth = 0;
  if (count > 0) {
    const double resultant = std::hypot(sum_cos, sum_sin) / count;
    if (resultant >= kCircularMeanFloor) {
      azimuth = std::atan2(sum_sin, sum_cos);
      frame.azimuth_confidence = static_cast<float>(resultant);
    } else {
      // The scatter's principal axis and eigenvalues, in closed form for a symmetric 2 × 2.
      const double a = scatter(0, 0), b = scatter(0, 1), cc = scatter(1, 1);
      const double mid = 0.5 * (a + cc), radius = std::hypot(0.5 * (a - cc), b);
      const double angle = 0.5 * std::atan2(2 * b, a - cc);
      const Eigen::Vector2d axis(std::cos(angle), std::sin(angle));
      const double l0 = mid - radius, l1 = mid + radius;
      // Sign of the axis: the side where the normals' projections have the heavier tail.
      double third = 0;
      for (std::uint32_t i : indices) {
        const Vec3d n = up_from_world * normals[i].cast<double>();
        const double s = axis.x() * n.x() + axis.y() * n.y();
        third += s * s * s;
      }
      const Eigen::Vector2d signed_axis = third < 0 ? Eigen::Vector2d(-axis) : axis;
      azimuth = std::atan2(signed_axis.y(), signed_axis.x());
      frame.azimuth_confidence = l1 > 0 ? static_cast<float>((l1 - l0) / l1) * 0.15f : 0.0f;
    }
  }
  Eigen::Matrix3d canonical_from_up;  // a turn by −azimuth about Z
  canonical_from_up << std::cos(azimuth), std::sin(azimuth), 0, -std::sin(azimuth), std::cos(azimuth), 0, 0, 0, 1;
  const Eigen::Matrix3d canonical_from_world = canonical_from_up * up_from_world;

  frame.world_from_canonical.rotation = canonical_from_world.transpose().cast<float>();
  frame.world_from_canonical.translation = centroid.cast<float>();
  return frame;
}

}  // namespace sspc
