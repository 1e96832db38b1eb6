// Nearest neighbours for distortion metrics, with equidistant neighbours kept together.
//
// MPEG's metric software (mpeg-pcc-dmetric, source/pcc_distortion.cpp, findMetric and
// scaleNormals, with its default --averageNormals=1) treats the points of B that are all at the
// minimum distance from a point of A as one group and averages the point-to-plane error and the
// normals over it. It calls two squared distances equal when they differ by less than an
// absolute 1e-8, which groups genuinely different neighbours once coordinates are small (metres
// with sub-millimetre spacing). sspc keeps the grouping but decides equality relative to the
// distance itself: see docs/METRICS.md, "Equidistant neighbours".
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <utility>
#include <vector>

#include "geometry/distinct_positions.hpp"
#include "sspc/neighbours.hpp"
#include "sspc/point_cloud.hpp"
#include "sspc/progress.hpp"

namespace sspc::eval {

// Two squared distances d², e² (computed in double from the stored float coordinates) are equal
// when |d² − e²| ≤ kTieRelativeTolerance · min(d², e²). Exact ties in the stored data differ
// only by the rounding of a three-term sum (≈1e-16), while distinct float distances differ by
// far more than 1e-12; the test is scale-free, so it behaves the same in millimetres and in
// kilometres. A zero distance ties only with zero (exact duplicates).
inline constexpr double kTieRelativeTolerance = 1e-12;

// A group holds at most this many points, the lowest indices of the tie, as pc_error's does
// (it fetches 30 neighbours). Coders that quantise coarsely decode hundreds of coincident points
// per cell; uncapped, every query near such a cell grew its search and its group to all of
// them (Draco's 8-bit autzen: 7 GB and many minutes).
inline constexpr std::size_t kMaxGroup = 30;

// For every query point, the group of tree points at the minimum distance.
struct NearestGroups {
  // Per query: the lowest index in its group, and the group's squared distance (the minimum,
  // in double).
  std::vector<std::uint32_t> nearest;
  std::vector<double> distance_squared;
  // The other members of groups with more than one member, as (query, index) sorted by query
  // then index. Empty for clouds without ties, which is the common case for scans.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> extra;

  std::size_t size() const { return nearest.size(); }

  // Calls f(index) for each member of query q's group, lowest index first.
  template <typename F>
  void for_each_member(std::size_t q, F&& f) const {
    f(nearest[q]);
    if (extra.empty()) return;
    const auto query = static_cast<std::uint32_t>(q);
    auto it = std::lower_bound(extra.begin(), extra.end(), query,
                               [](const auto& e, std::uint32_t v) { return e.first < v; });
    for (; it != extra.end() && it->first == query; ++it) f(it->second);
  }

  std::size_t group_size(std::size_t q) const {
    std::size_t n = 0;
    for_each_member(q, [&](std::uint32_t) { ++n; });
    return n;
  }
};

// A k-d tree over the distinct positions of a cloud (geometry/distinct_positions.hpp), answering
// nearest-point groups in the cloud's own indices: a group found among positions is expanded
// back to the lowest indices of the points at them. Draco's 6-bit autzen (about a thousand
// coincident points a position) took minutes in `sspc eval` with a tree over the points.
class NearestGroupIndex {
 public:
  // `points` must outlive the index. Not empty.
  explicit NearestGroupIndex(std::span<const Vec3f> points);
  NearestGroupIndex(const NearestGroupIndex&) = delete;
  NearestGroupIndex& operator=(const NearestGroupIndex&) = delete;

  std::size_t distinct_positions() const { return tree_->size(); }

  // The nearest-point group of every point of `queries` among the indexed points, in their
  // indices. Parallel; the result is identical whatever the thread count. Advances `progress`
  // by one per query.
  NearestGroups find(std::span<const Vec3f> queries, Progress* progress) const;

 private:
  // Appends to `out` the lowest (at most `limit`) indices of the points at tree position u.
  void append_points(std::uint32_t u, std::size_t limit, std::vector<std::uint32_t>& out) const;

  DistinctPositions distinct_;
  std::optional<KdTree3> tree_;
};

}  // namespace sspc::eval
