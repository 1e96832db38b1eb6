// Neighbour search: thin wrappers over nanoflann's k-d tree, used everywhere in sspc. KdTree3
// searches 3-D points in the Euclidean metric; KdTreeL1 searches descriptor vectors of any
// dimension in the L1 metric (the code book's match distance, paper §4.3).
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
struct Neighbour {
  std::uint32_t index;
  float distance_squared;
};

// k nearest neighbours of many queries, stored flat: row i holds query i's `k` neighbours
// sorted by distance (fewer than k only when the cloud has fewer points; `count[i]` says).
struct KnnTable {
  std::size_t k = 0;
  std::vector<std::uint32_t> indices;    // queries × k
  std::vector<float> distances_squared;  // queries × k, or empty when not asked for
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
  std::size_t knn(const Vec3f& query, std::size_t k, std::vector<Neighbour>& out) const;

  // The nearest point; its squared distance in `distance_squared`. Requires a non-empty tree.
  std::uint32_t nearest(const Vec3f& query, float* distance_squared) const;

  // Every point within `radius` (not squared, boundary included: d² ≤ radius²) of `query`,
  // sorted by distance and then index when `sorted`.
  std::size_t radius(const Vec3f& query, float radius, std::vector<Neighbour>& out,
                     bool sorted = true) const;

  // How many points radius() would give, without collecting them.
  std::size_t radius_count(const Vec3f& query, float radius) const;

  // k nearest neighbours of every query, in parallel. `exclude_self`: queries are the tree's own
  // points and each one's own index is dropped from its row (k neighbours besides itself).
  // Advances `progress` (when given) by the number of queries answered; the caller owns the stage.
  // Without `distances` the table holds no distances_squared (half its memory: normals need
  // only the indices).
  KnnTable knn_batch(std::span<const Vec3f> queries, std::size_t k, bool exclude_self = false,
                     Progress* progress = nullptr, bool distances = true) const;

 private:
  struct Impl;
  std::span<const Vec3f> points_;
  std::unique_ptr<Impl> impl_;
};

// One neighbour in the L1 metric: the item's index and its L1 distance to the query.
struct L1Neighbour {
  std::uint32_t index;
  float distance;
};

// The L1 distance Σ|a_i − b_i| as KdTreeL1 measures it: summed in float in index order, so
// that a caller's own test against a radius agrees with the tree's to the last bit.
float l1_distance(const float* a, const float* b, std::size_t dimension);

// A k-d tree over `rows` vectors of `dimension` floats each, stored row-major in `data`
// (data.size() == rows × dimension). Built for the code book's "every descriptor within L1
// radius ε of this one".
class KdTreeL1 {
 public:
  // `data.size()` must be a multiple of `dimension` (≥ 1); a trailing partial row is ignored.
  KdTreeL1(std::span<const float> data, std::size_t dimension, std::size_t leaf_size = 16);
  ~KdTreeL1();
  KdTreeL1(KdTreeL1&&) noexcept;
  KdTreeL1& operator=(KdTreeL1&&) noexcept;

  std::size_t size() const { return rows_; }
  std::size_t dimension() const { return dimension_; }
  std::span<const float> row(std::size_t i) const {
    return data_.subspan(i * dimension_, dimension_);
  }

  // Every item whose l1_distance to `query` (dimension() floats) is ≤ `radius`: the radius is a
  // plain L1 distance, not squared. Sorted by distance, then index. Returns out.size().
  std::size_t radius(std::span<const float> query, float radius,
                     std::vector<L1Neighbour>& out) const;

  // The k nearest items in L1, closest first (ties: lower index first). Returns out.size().
  std::size_t knn(std::span<const float> query, std::size_t k, std::vector<L1Neighbour>& out) const;

 private:
  struct Impl;
  std::span<const float> data_;
  std::size_t dimension_ = 0;
  std::size_t rows_ = 0;
  std::unique_ptr<Impl> impl_;
};

// Nominal point spacing: the median distance from a point to its nearest neighbour at another
// position, over a deterministic sample of up to `samples` points (of the distinct positions when
// any sampled point has a twin). 0 for fewer than two distinct positions.
double nominal_spacing(const PointCloud& cloud, std::size_t samples = 10000);
double nominal_spacing(const KdTree3& tree, std::size_t samples = 10000);

// The limits within which sspc's float32 geometry holds (squared distances neither overflow
// nor underflow, grids of spacing-sized cells fit in 32-bit indices): every |coordinate| at most
// kMaxCoordinate, a nominal spacing of at least kMinSpacing, and an extent of at most
// kMaxExtentInSpacings spacings. Returns kInvalidArgument saying which limit the cloud
// (`positions`, of nominal spacing `spacing`) breaks and what to do about it, else OK.
inline constexpr double kMaxCoordinate = 1e18;
inline constexpr double kMinSpacing = 1e-18;
inline constexpr double kMaxExtentInSpacings = 16777216.0;  // 2^24: float32's own resolution
Status check_geometry_range(std::span<const Vec3f> positions, double spacing);
// The part of those checks that needs no spacing (a pass over the positions): every
// |coordinate| at most kMaxCoordinate, and an extent of 0 or at least kMinSpacing.
Status check_coordinate_range(std::span<const Vec3f> positions);

}  // namespace sspc
