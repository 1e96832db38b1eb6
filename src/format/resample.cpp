#include "format/resample.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include <Eigen/Dense>

namespace sspc::codec {

CodewordFit::CodewordFit(std::span<const Vec3f> points) : points_(points), tree_(points) {}

std::uint64_t CodewordFit::memory_bytes() const {
  // nanoflann: an index a point and about one node of 40 bytes a leaf of ten.
  return sizeof(*this) + points_.size() * (sizeof(std::uint32_t) + 4);
}

void CodewordFit::resample(std::uint32_t i, int m, float step, std::vector<Vec3f>& points,
                               std::vector<Vec3f>* normals) const {
  const Vec3f q = points_[i];
  std::array<std::uint32_t, kResampleNeighbours> index{};
  std::array<float, kResampleNeighbours> d2{};
  const std::size_t count = tree_.knn(q, kResampleNeighbours, index.data(), d2.data());

  // The normal: the least principal axis of the neighbours, turned towards +z of the code
  // word's frame (then +x, then +y, where it lies in a plane of them).
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (std::size_t j = 0; j < count; ++j) mean += points_[index[j]].cast<double>();
  mean /= static_cast<double>(std::max<std::size_t>(count, 1));
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (std::size_t j = 0; j < count; ++j) {
    const Eigen::Vector3d d = points_[index[j]].cast<double>() - mean;
    cov += d * d.transpose();
  }
  Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
  if (count >= 3) {
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
    eig.computeDirect(cov);
    if (eig.info() == Eigen::Success && eig.eigenvectors().allFinite()) n = eig.eigenvectors().col(0).normalized();
  }
  const double sign = n.z() != 0 ? n.z() : n.x() != 0 ? n.x() : n.y();
  if (sign < 0) n = -n;
  // The tangents: the frame's x axis in the tangent plane (its y axis where x nearly is the
  // normal), so that the m × m points of a cell line up with the code word's grid.
  Eigen::Vector3d t1 = Eigen::Vector3d::UnitX() - n.x() * n;
  if (t1.squaredNorm() < 0.25) t1 = Eigen::Vector3d::UnitY() - n.y() * n;
  t1.normalize();
  const Eigen::Vector3d t2 = n.cross(t1);

  // z(u, v) = c0 + c1 U + c2 V + c3 U² + c4 U V + c5 V² with U = u / step, V = v / step, by
  // weighted least squares (weights exp(-(u² + v²) / step²)); a plane with fewer than six
  // neighbours or an ill-conditioned system, the tangent plane itself with fewer than three.
  const double g = static_cast<double>(step);
  const Eigen::Vector3d origin = q.cast<double>();
  Eigen::Matrix<double, 6, 6> a = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> b = Eigen::Matrix<double, 6, 1>::Zero();
  for (std::size_t j = 0; j < count; ++j) {
    const Eigen::Vector3d d = points_[index[j]].cast<double>() - origin;
    const double u = d.dot(t1) / g, v = d.dot(t2) / g, z = d.dot(n);
    const double w = std::exp(-(u * u + v * v));
    Eigen::Matrix<double, 6, 1> phi;
    phi << 1, u, v, u * u, u * v, v * v;
    a.noalias() += w * phi * phi.transpose();
    b.noalias() += (w * z) * phi;
  }
  Eigen::Matrix<double, 6, 1> c = Eigen::Matrix<double, 6, 1>::Zero();
  bool fitted = false;
  if (count >= 6) {
    const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt(a);
    if (ldlt.info() == Eigen::Success && ldlt.rcond() > 1e-9) {
      c = ldlt.solve(b);
      fitted = c.allFinite();
    }
  }
  if (!fitted && count >= 3) {
    const Eigen::Matrix3d a3 = a.topLeftCorner<3, 3>();
    const Eigen::LDLT<Eigen::Matrix3d> ldlt(a3);
    c.setZero();
    if (ldlt.info() == Eigen::Success && ldlt.rcond() > 1e-9) {
      c.head<3>() = ldlt.solve(b.head<3>());
      if (!c.allFinite()) c.setZero();
    }
  }

  // The m × m points: the centres of an m × m split of the cell around q, lifted onto the
  // fit, at most one step off the tangent plane (a fit's edge may curl away).
  for (int s = 0; s < m; ++s) {
    const double u = (static_cast<double>(s) + 0.5) / m - 0.5;
    for (int r = 0; r < m; ++r) {
      const double v = (static_cast<double>(r) + 0.5) / m - 0.5;
      const double z =
          std::clamp(c[0] + c[1] * u + c[2] * v + c[3] * u * u + c[4] * u * v + c[5] * v * v, -g, g);
      points.push_back((origin + (u * g) * t1 + (v * g) * t2 + z * n).cast<float>());
      if (normals == nullptr) continue;
      const double du = (c[1] + 2 * c[3] * u + c[4] * v) / g, dv = (c[2] + c[4] * u + 2 * c[5] * v) / g;
      // The fit's normal, or the neighbours' where it has none: a step of 0 (a header's patch
      // radius among float's subnormals, the decoder's fuzzer found) makes the slopes 0/0.
      const Eigen::Vector3d bent = n - du * t1 - dv * t2;
      const double length = bent.norm();
      normals->push_back((std::isfinite(length) && length > 0 ? Eigen::Vector3d(bent / length) : n).cast<float>());
    }
  }
}

}  // namespace sspc::codec
