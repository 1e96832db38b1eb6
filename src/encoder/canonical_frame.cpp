#include "encoder/canonical_frame.hpp"

#include <cmath>

#include <Eigen/Eigenvalues>

namespace sspc {

namespace {

// Below this resultant length the circular mean is noise (azimuths spread all round).
constexpr double kCircularMeanFloor = 0.15;
// Normals closer to +Z than this have no usable azimuth.
constexpr double kTiltFloor = 1e-4;

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
  const Eigen::Matrix3d up_from_world =
      Eigen::Quaterniond::FromTwoVectors(mean_normal, Vec3d::UnitZ()).toRotationMatrix();

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
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> solver(scatter);
      const Eigen::Vector2d axis = solver.eigenvectors().col(1);
      const double l0 = solver.eigenvalues()(0), l1 = solver.eigenvalues()(1);
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
  const Eigen::Matrix3d canonical_from_up =
      Eigen::AngleAxisd(-azimuth, Vec3d::UnitZ()).toRotationMatrix();
  const Eigen::Matrix3d canonical_from_world = canonical_from_up * up_from_world;

  frame.world_from_canonical.rotation = canonical_from_world.transpose().cast<float>();
  frame.world_from_canonical.translation = centroid.cast<float>();
  return frame;
}

}  // namespace sspc
