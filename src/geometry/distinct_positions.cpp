// Distinct positions and k-NN over them (geometry/distinct_positions.hpp).
#include "geometry/distinct_positions.hpp"

#include <algorithm>
#include <bit>
#include <numeric>
#include <utility>

#include "core/parallel.hpp"

namespace sspc {

namespace {

// Whether some position may hold more than `gather_above` points: the longest run of equal
// hashes of the coordinates' bits. A collision can only lengthen a run, so "no" is certain.
// Sorting one 64-bit word a point takes half the time of sorting the points by position
// (autzen: 0.5 s against 1.1 s on 2 cores), and most clouds stop here.
bool may_gather(std::span<const Vec3f> points, std::size_t gather_above) {
  std::vector<std::uint64_t> hashes(points.size());
  parallel_for(0, points.size(), 4096, [&](std::size_t i) {
    std::uint64_t h = 0x9E3779B97F4A7C15ull;
    for (int a = 0; a < 3; ++a) {
      h ^= std::bit_cast<std::uint32_t>(points[i][a] == 0.0f ? 0.0f : points[i][a]);  // -0 is 0
      h *= 0xBF58476D1CE4E5B9ull;
      h ^= h >> 31;
    }
    hashes[i] = h;
  });
  parallel_sort(hashes.begin(), hashes.end(), std::less<>());
  std::size_t run = 1;
  for (std::size_t i = 1; i < hashes.size(); ++i) {
    run = hashes[i] == hashes[i - 1] ? run + 1 : 1;
    if (run > gather_above) return true;
  }
  return false;
}

}  // namespace

DistinctPositions::DistinctPositions(std::span<const Vec3f> points, std::size_t gather_above) {
  if (!may_gather(points, gather_above)) return;
  // Points sorted by position, coincident ones by index: each run of equal positions is one
  // distinct position, its first member the lowest index. The entries carry their coordinates,
  // so the sort compares without reaching back into the cloud (3 times as fast as sorting
  // indices on autzen). The order is total, so the result does not depend on the thread count.
  struct Entry {
    float x, y, z;
    std::uint32_t index;
  };
  std::vector<Entry> order(points.size());
  parallel_for(0, points.size(), 4096, [&](std::size_t i) {
    order[i] = {points[i].x(), points[i].y(), points[i].z(), static_cast<std::uint32_t>(i)};
  });
  const auto same = [](const Entry& a, const Entry& b) { return a.x == b.x && a.y == b.y && a.z == b.z; };
  parallel_sort(order.begin(), order.end(), [](const Entry& a, const Entry& b) {
    if (a.x != b.x) return a.x < b.x;
    if (a.y != b.y) return a.y < b.y;
    if (a.z != b.z) return a.z < b.z;
    return a.index < b.index;
  });
  std::vector<std::uint32_t> run_start;  // where each run starts in `order`
  for (std::size_t i = 0; i < order.size(); ++i) {
    if (i == 0 || !same(order[i], order[i - 1])) run_start.push_back(static_cast<std::uint32_t>(i));
  }
  run_start.push_back(static_cast<std::uint32_t>(order.size()));
  const std::size_t runs = run_start.size() - 1;
  std::size_t most = 0;
  for (std::size_t r = 0; r < runs; ++r) most = std::max<std::size_t>(most, run_start[r + 1] - run_start[r]);
  if (most <= gather_above) return;
  // Positions numbered by their lowest index, so that a tree over them, which breaks ties by
  // index, breaks them as a tree over the points would.
  std::vector<std::uint32_t> by_lowest(runs);
  std::iota(by_lowest.begin(), by_lowest.end(), 0u);
  std::sort(by_lowest.begin(), by_lowest.end(), [&](std::uint32_t a, std::uint32_t b) {
    return order[run_start[a]].index < order[run_start[b]].index;
  });
  positions_.reserve(runs);
  offsets_.reserve(runs + 1);
  members_.reserve(points.size());
  offsets_.push_back(0);
  for (const std::uint32_t r : by_lowest) {
    positions_.push_back(points[order[run_start[r]].index]);
    for (std::size_t m = run_start[r]; m < run_start[r + 1]; ++m) members_.push_back(order[m].index);
    offsets_.push_back(static_cast<std::uint32_t>(members_.size()));
  }
}

namespace {

// Fills `row` with the k nearest points, by (distance, index), among the points at the positions
// `idx` (their squared distances `d2`, as the tree returns them: ascending, ties by position
// number). Returns whether no position left out can hold a point of the row: all positions were
// searched, or the k-th point is strictly nearer than the farthest position searched, or it ties
// with it and has an index no higher than the lowest point of a searched position at that
// distance (positions left out at that distance are numbered higher, so their points all have
// higher lowest indices).
bool fill_row(const DistinctPositions& distinct, std::size_t k, std::span<const std::uint32_t> idx,
              std::span<const float> d2, bool all_searched,
              std::vector<std::pair<float, std::uint32_t>>& row) {
  row.clear();
  for (std::size_t j = 0; j < idx.size(); ++j) {
    const auto members = distinct.members(idx[j]);
    for (std::size_t m = 0; m < std::min(k, members.size()); ++m) row.emplace_back(d2[j], members[m]);
  }
  const std::size_t keep = std::min(k, row.size());
  std::partial_sort(row.begin(), row.begin() + static_cast<std::ptrdiff_t>(keep), row.end());
  row.resize(keep);
  if (all_searched) return true;
  if (keep < k) return false;
  const float farthest = d2.back();
  if (row.back().first < farthest) return true;
  std::uint32_t lowest_at_farthest = 0;
  for (std::size_t j = 0; j < idx.size(); ++j) {
    if (d2[j] == farthest) lowest_at_farthest = std::max(lowest_at_farthest, distinct.members(idx[j]).front());
  }
  return row.back().second <= lowest_at_farthest;
}

}  // namespace

KnnTable knn_of_own_points(std::span<const Vec3f> points, std::size_t k, Progress* progress, bool distances,
                           const KdTree3* tree) {
  // A tree over the points visits all c points at a position for each of them: c² for the
  // position, harmless while c is about k or less (the search itself costs k per point).
  const DistinctPositions distinct(points, std::max<std::size_t>(2 * k, 32));
  if (!distinct.gathered()) {
    if (tree != nullptr) return tree->knn_batch(points, k, false, progress, distances);
    return KdTree3(points).knn_batch(points, k, false, progress, distances);
  }

  KnnTable table;
  table.k = k;
  table.indices.assign(points.size() * k, 0);
  if (distances) table.distances_squared.assign(points.size() * k, 0.0f);
  table.count.assign(points.size(), 0);
  if (k == 0) return table;
  const std::span<const Vec3f> positions = distinct.positions();
  const KdTree3 position_tree(positions);
  const std::size_t n = positions.size();
  // The k nearest positions of every position settle almost every row (the batch walks the
  // tree in leaf order); a row that coincident points or ties leave open asks for more.
  const std::size_t first_ask = std::min(k, n);
  const KnnTable nearest = position_tree.knn_batch(positions, first_ask);
  parallel_for_ranges(0, n, 256, [&](std::size_t begin, std::size_t end) {
    std::vector<std::uint32_t> idx;
    std::vector<float> d2;
    std::vector<std::pair<float, std::uint32_t>> row;
    for (std::size_t u = begin; u < end; ++u) {
      bool done = fill_row(distinct, k, nearest.row(u), nearest.row_distances(u), first_ask == n, row);
      for (std::size_t ask = std::min(2 * first_ask, n); !done; ask = std::min(2 * ask, n)) {
        idx.resize(ask);
        d2.resize(ask);
        const std::size_t found = position_tree.knn(positions[u], ask, idx.data(), d2.data());
        done = fill_row(distinct, k, std::span(idx.data(), found), std::span(d2.data(), found), found == n, row);
      }
      const std::span<const std::uint32_t> at_u = distinct.members(u);
      for (const std::uint32_t q : at_u) {
        for (std::size_t j = 0; j < row.size(); ++j) {
          table.indices[q * k + j] = row[j].second;
          if (distances) table.distances_squared[q * k + j] = row[j].first;
        }
        table.count[q] = static_cast<std::uint32_t>(row.size());
      }
      progress_advance(progress, at_u.size());
    }
  });
  return table;
}

}  // namespace sspc
