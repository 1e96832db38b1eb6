// Neighbour search: one thin wrapper over nanoflann's k-d tree, used everywhere in sspc.
//
// Answers do not depend on the tree's shape: among equidistant points the lower index comes
// first (and is kept when only some of them fit in k), and radius queries include the boundary.
// Safe to query from many threads at once once built. A tree keeps a pointer to its points,
// which must outlive it and must not move.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <utility>
#include <vector>

#include "sspc/point_cloud.hpp"
#include "sspc/progress.hpp"

namespace sspc {

// One neighbour: the point's index and its squared Euclidean distance to the query.
struct Neighbor {
  std::uint32_t index;
  float distance_squared;
};

// k nearest neighbours of many queries, stored flat: row i holds query i's `k` neighbours
// sorted by distance (fewer than k only when the cloud has fewer points; `count[i]` says).
struct KnnTable {
  std::size_t k = 0;
  std::vector<std::uint32_t> indices;    // queries × k
  std::vector<float> distances_squared;  // queries × k
  std::vector<std::uint32_t> count;      // per query

  std::span<const std::uint32_t> row(std::size_t i) const {
    return {indices.data() + i * k, count[i]};
  }
  std::span<const float> row_distances(std::size_t i) const {
    return {distances_squared.data() + i * k, count[i]};
  }
};

class KdTree3 {
 public:
  explicit KdTree3(std::span<const Vec3f> points, std::size_t leaf_size = 10);
  ~KdTree3();
  KdTree3(KdTree3&&) noexcept;
  KdTree3& operator=(KdTree3&&) noexcept;

  std::size_t size() const { return points_.size(); }
  std::span<const Vec3f> points() const { return points_; }

  // The k nearest points to `query`, closest first (ties: lower index first). Returns how many
  // were found: min(k, size()).
  std::size_t knn(const Vec3f& query, std::size_t k, std::uint32_t* indices,
                  float* distances_squared) const;
  // Convenience overload filling vectors.
  std::size_t knn(const Vec3f& query, std::size_t k, std::vector<Neighbor>& out) const;

  // The nearest point; its squared distance in `distance_squared`. Requires a non-empty tree.
  std::uint32_t nearest(const Vec3f& query, float* distance_squared) const;

  // Every point within `radius` (not squared, boundary included: d² ≤ radius²) of `query`,
  // sorted by distance and then index when `sorted`.
  std::size_t radius(const Vec3f& query, float radius, std::vector<Neighbor>& out,
                     bool sorted = true) const;

  // k nearest neighbours of every query, in parallel. `exclude_self`: queries are the tree's own
  // points and each one's own index is dropped from its row (k neighbours besides itself).
  // Advances `progress` (when given) by the number of queries answered; the caller owns the stage.
  KnnTable knn_batch(std::span<const Vec3f> queries, std::size_t k, bool exclude_self = false,
                     Progress* progress = nullptr) const;

 private:
  struct Impl;
  std::span<const Vec3f> points_;
  std::unique_ptr<Impl> impl_;
};

// Nominal point spacing: the median distance from a point to its nearest neighbour, over a
// deterministic sample of up to `samples` points. 0 for fewer than two points.
double nominal_spacing(const PointCloud& cloud, std::size_t samples = 10000);
double nominal_spacing(const KdTree3& tree, std::size_t samples = 10000);

}  // namespace sspc
