// Normal estimation by principal component analysis of the k nearest neighbours (Hoppe, DeRose,
// Duchamp, McDonald, Stuetzle: "Surface reconstruction from unorganized points", SIGGRAPH 1992,
// section 3.2: the tangent plane's normal is the eigenvector of the smallest eigenvalue of the
// neighbourhood's covariance matrix).
//
// The covariance is accumulated in double about the centroid (two passes): real scans sit far
// from the origin (autzen's coordinates are in the thousands of feet), where the one-pass
// Σpp^T − n·cc^T would cancel away the small variance across the surface that is the normal.
// The 3×3 eigenproblem is solved in closed form (Eigen's computeDirect), about three times as
// fast as the iterative solver here and as accurate for the smallest eigenvector, whose
// eigenvalue is well separated on a surface (bench/normals_bench.cpp measures both).
#include <Eigen/Eigenvalues>

#include "core/parallel.hpp"
#include "geometry/normals_steps.hpp"

namespace sspc::detail {

namespace {

Vec3f pca_normal(std::span<const Vec3f> positions, std::span<const std::uint32_t> row) {
  Vec3d centroid = Vec3d::Zero();
  for (const std::uint32_t j : row) centroid += positions[j].cast<double>();
  centroid /= static_cast<double>(row.size());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (const std::uint32_t j : row) {
    const Vec3d d = positions[j].cast<double>() - centroid;
    covariance.selfadjointView<Eigen::Lower>().rankUpdate(d);
  }
  // Only the lower triangle is read by the solver; no need to mirror it or divide by n.
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
  solver.computeDirect(covariance, Eigen::ComputeEigenvectors);
  // Eigenvalues come in increasing order. A degenerate neighbourhood (all points equal) gets an
  // identity basis, so the result is still a unit vector.
  Vec3f normal = solver.eigenvectors().col(0).cast<float>();
  normal.normalize();
  return normal;
}

}  // namespace

void estimate_normals_pca(std::span<const Vec3f> positions, const KnnTable& neighbours,
                          std::span<Vec3f> normals, Progress* progress) {
  parallel_for_ranges(0, normals.size(), 4096, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) normals[i] = pca_normal(positions, neighbours.row(i));
    progress_advance(progress, end - begin);
  });
}

}  // namespace sspc::detail
