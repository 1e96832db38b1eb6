#include "encoder/icp.hpp"

#include <cmath>
#include <limits>

#include <Eigen/Cholesky>

namespace sspc::codec {

IcpResult align_point_to_plane(std::span<const Vec3f> source, const CodewordSurface& target,
                               const IcpOptions& options) {
  IcpResult result;
  RigidTransform& t = result.target_from_source;
  const float max_d2 = options.max_pair_distance > 0
                           ? options.max_pair_distance * options.max_pair_distance
                           : std::numeric_limits<float>::infinity();
  const double w = static_cast<double>(options.point_to_point_weight);
  for (int iteration = 0; iteration < options.max_iterations; ++iteration) {
    // Normal equations of Σ ((x + ω×x + τ − y)·n)² in (ω, τ), accumulated in double.
    Eigen::Matrix<double, 6, 6> ata = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> atb = Eigen::Matrix<double, 6, 1>::Zero();
    double sse = 0;
    std::size_t pairs = 0;
    double sum_x2 = 0;
    Eigen::Matrix3d sum_xxt = Eigen::Matrix3d::Zero();
    Vec3d sum_x = Vec3d::Zero(), sum_x_cross_d = Vec3d::Zero(), sum_d = Vec3d::Zero();
    for (const Vec3f& s : source) {
      const Vec3f x = t.apply(s);
      float d2 = 0;
      const std::uint32_t j = target.tree().nearest(x, &d2);
      if (d2 > max_d2) continue;
      const Vec3d xd = x.cast<double>();
      const Vec3d n = target.normals()[j].cast<double>();
      const double r = (xd - target.points()[j].cast<double>()).dot(n);
      Eigen::Matrix<double, 6, 1> row;
      row << xd.cross(n), n;
      ata.selfadjointView<Eigen::Lower>().rankUpdate(row);
      atb -= row * r;
      sse += r * r;
      if (w > 0) {
        // The point-to-point rows (x × e_a, e_a) for the three axes, summed in closed form:
        // Σ_a r_a r_aᵀ = [[|x|² I − x xᵀ, [x]×], [[x]×ᵀ, I]] and Σ_a r_a (x − y)_a = (x × d, d).
        const Vec3d d = xd - target.points()[j].cast<double>();
        sum_x2 += xd.squaredNorm();
        sum_xxt += xd * xd.transpose();
        sum_x += xd;
        sum_x_cross_d += xd.cross(d);
        sum_d += d;
      }
      ++pairs;
    }
    if (w > 0 && pairs > 0) {
      Eigen::Matrix<double, 6, 6> p2p;
      Eigen::Matrix3d cross;  // [Σx]×: [x]× v = x × v
      cross << 0, -sum_x.z(), sum_x.y(), sum_x.z(), 0, -sum_x.x(), -sum_x.y(), sum_x.x(), 0;
      p2p.topLeftCorner<3, 3>() = sum_x2 * Eigen::Matrix3d::Identity() - sum_xxt;
      p2p.topRightCorner<3, 3>() = cross;
      p2p.bottomLeftCorner<3, 3>() = cross.transpose();
      p2p.bottomRightCorner<3, 3>() = static_cast<double>(pairs) * Eigen::Matrix3d::Identity();
      ata.triangularView<Eigen::Lower>() += w * p2p;
      atb.head<3>() -= w * sum_x_cross_d;
      atb.tail<3>() -= w * sum_d;
    }
    result.iterations = iteration + 1;
    result.rms = pairs > 0 ? static_cast<float>(std::sqrt(sse / static_cast<double>(pairs))) : 0.0f;
    if (pairs < 6) break;
    if (options.abandon_rms > 0 && iteration >= 4 && result.rms > options.abandon_rms) break;
    // A little damping keeps directions the patch does not constrain (sliding along a plane,
    // spinning a sphere cap) where the canonical frames put them.
    const Eigen::Matrix<double, 6, 6> full = ata.selfadjointView<Eigen::Lower>();
    const double damping = 1e-6 * full.trace() + 1e-12;
    const Eigen::Matrix<double, 6, 1> step =
        (full + damping * Eigen::Matrix<double, 6, 6>::Identity()).ldlt().solve(atb);
    const Vec3d omega = step.head<3>();
    const Vec3d tau = step.tail<3>();
    RigidTransform delta;
    const double angle = omega.norm();
    if (angle > 0) {
      delta.rotation = Eigen::AngleAxisd(angle, omega / angle).toRotationMatrix().cast<float>();
    }
    delta.translation = tau.cast<float>();
    t = delta * t;
    if (options.converged_step > 0 &&
        static_cast<float>(tau.norm()) < options.converged_step &&
        static_cast<float>(angle) * options.lever_arm < options.converged_step) {
      break;
    }
  }
  return result;
}

}  // namespace sspc::codec
