// The steps of normal estimation, apart so that ensure_normals can run the k-NN search once and
// hand the same table to the PCA and to the orientation, and so that benchmarks can time each.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "sspc/neighbours.hpp"
#include "sspc/normals.hpp"
#include "sspc/point_cloud.hpp"
#include "sspc/progress.hpp"

namespace sspc::detail {

// ensure_normals (sspc/normals.hpp), handing the k-NN table it searched to `searched` (left
// empty when the cloud's own normals were kept): the encoder takes its feature strength from it.
// `tree`, when given, indexes cloud.positions and is searched instead of a tree built here (the
// encoder's, which it needs afterwards too). `alongside`, when given, runs once on every path
// that succeeds: beside the orientation (which runs on one core) where there is one, else at
// the end; it must not touch cloud.normals.
Status ensure_normals(PointCloud& cloud, const NormalOptions& options, KnnTable* searched,
                      const KdTree3* tree = nullptr, const std::function<void()>& alongside = {});

// Unit normals by PCA over each point's row of `neighbours` (the point itself included): the
// eigenvector of the smallest eigenvalue of the neighbourhood's covariance. Parallel; each
// normal depends only on its own row, so the result is independent of the thread count.
void estimate_normals_pca(std::span<const Vec3f> positions, const KnnTable& neighbours,
                          std::span<Vec3f> normals, Progress* progress);

// Hoppe et al. 1992, section 3.3: flips normals to agree along a minimum spanning tree of the
// symmetrised k-NN graph with edge cost 1 − |n_i·n_j|; in each connected component the highest
// point's normal faces +z. Sequential and deterministic (heap ties broken by index).
void orient_normals_mst(std::span<const Vec3f> positions, const KnnTable& neighbours,
                        std::span<Vec3f> normals, Progress* progress);

// The k-NN graph made symmetric, for the orientation: a point's neighbours are its own k-NN row
// plus every point whose row names it. The reverse half is built as compressed rows (CSR); the
// forward half is the table itself. An edge whose target's row names its source too is relaxed
// from the forward half already, so the reverse half leaves it out: relaxing an edge twice
// changes nothing, and on a surface most k-NN edges are mutual (autzen: the reverse half was
// 0.68 GB of the orientation's 0.96).
struct ReverseEdges {
  std::vector<std::uint64_t> offsets;  // points + 1
  std::vector<std::uint32_t> sources;  // per point, in an order that depends on thread timing

  std::span<const std::uint32_t> of(std::size_t i) const {
    return {sources.data() + offsets[i], static_cast<std::size_t>(offsets[i + 1] - offsets[i])};
  }
};

// For every edge (i, j) of `table` (row i names j, over `positions`) that row j does not
// return, i in j's list of the result. Parallel.
ReverseEdges reverse_edges(std::span<const Vec3f> positions, const KnnTable& table, std::size_t points);

// Flips every normal to face `viewpoint` (n·(viewpoint − p) ≥ 0).
void orient_normals_towards(std::span<const Vec3f> positions, const Vec3f& viewpoint,
                            std::span<Vec3f> normals);

}  // namespace sspc::detail
