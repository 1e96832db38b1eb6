// Points gathered by position, for searches over clouds with many coincident points.
//
// Coders that quantise coarsely decode many points onto one position: Draco's 6-bit autzen puts
// about a thousand on each. sspc's k-d tree keeps the lowest indices among equal distances (so
// that answers do not depend on the tree's shape), which means visiting every coincident point
// whenever a query's neighbours are among them: quadratic in the coincidence. Searching the
// distinct positions and expanding each to its points gives the same answers at the cost of a
// sort.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "sspc/neighbours.hpp"
#include "sspc/point_cloud.hpp"
#include "sspc/progress.hpp"

namespace sspc {

class DistinctPositions {
 public:
  // `points` must outlive this. Sorts the points by position (in parallel), and gathers them
  // only when some position holds more than `gather_above` points.
  explicit DistinctPositions(std::span<const Vec3f> points, std::size_t gather_above = 1);

  // False when no position holds more than `gather_above` points; positions() and members() are
  // then empty: search the points themselves.
  bool gathered() const { return !positions_.empty(); }
  // One entry per distinct position, numbered in the order of each position's lowest index.
  std::span<const Vec3f> positions() const { return positions_; }
  // The indices of the points at position u, ascending.
  std::span<const std::uint32_t> members(std::size_t u) const {
    return {members_.data() + offsets_[u], offsets_[u + 1] - offsets_[u]};
  }

 private:
  std::vector<Vec3f> positions_;
  std::vector<std::uint32_t> offsets_;
  std::vector<std::uint32_t> members_;
};

// The k nearest of every point among the cloud's own points (itself included), exactly as
// KdTree3(points).knn_batch(points, k) answers: ties by lower index. Over the distinct positions
// when points coincide. Advances `progress` by one per point. Without `distances`, the table
// holds none (KdTree3::knn_batch). `tree`, when given, indexes `points` and is searched where
// no position needs gathering, instead of a tree built here.
KnnTable knn_of_own_points(std::span<const Vec3f> points, std::size_t k, Progress* progress,
                           bool distances = true, const KdTree3* tree = nullptr);

}  // namespace sspc
