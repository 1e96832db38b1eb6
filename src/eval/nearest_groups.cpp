// Equidistant nearest-neighbour groups (docs/METRICS.md, "Equidistant neighbours"; the grouping
// follows mpeg-pcc-dmetric's findMetric/scaleNormals, the equality test does not).
#include "eval/nearest_groups.hpp"

#include <algorithm>
#include <limits>
#include <numeric>

#include "core/parallel.hpp"

namespace sspc::eval {

namespace {

// The tree's float distances decide only how many candidates to fetch; membership is decided in
// double afterwards. Two squared distances that are equal in double differ in float by a few
// ulps (≈1e-7 relative) at most, so any candidate within this factor of the float minimum may
// still tie and the search widens until the last candidate is clearly farther.
constexpr float kFloatSlack = 1e-5f;

// Queries per work chunk: fixed, so that the order of `extra` does not depend on scheduling.
constexpr std::size_t kChunk = 4096;

double squared_distance(const Vec3f& a, const Vec3f& b) {
  // The difference of two floats is exact in double (barring exponents 29 binades apart), so
  // this is the distance between the stored points rounded once per operation in double.
  return (a.cast<double>() - b.cast<double>()).squaredNorm();
}

}  // namespace

NearestGroupIndex::NearestGroupIndex(std::span<const Vec3f> points) {
  // Points sorted by position, coincident ones by index: each run of equal positions is one
  // distinct position, its first member the lowest index.
  std::vector<std::uint32_t> order(points.size());
  std::iota(order.begin(), order.end(), 0u);
  const auto less = [&](std::uint32_t a, std::uint32_t b) {
    const Vec3f& p = points[a];
    const Vec3f& q = points[b];
    if (p.x() != q.x()) return p.x() < q.x();
    if (p.y() != q.y()) return p.y() < q.y();
    if (p.z() != q.z()) return p.z() < q.z();
    return a < b;
  };
  std::sort(order.begin(), order.end(), less);
  bool coincident = false;
  for (std::size_t i = 1; i < order.size() && !coincident; ++i) coincident = points[order[i]] == points[order[i - 1]];
  if (!coincident) {
    tree_.emplace(points);
    return;
  }
  // Distinct positions numbered in the order of their lowest index, so that the tree's own
  // tie-break (lower index first) agrees with the points' indices.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> runs;  // (lowest index, start in order)
  for (std::size_t i = 0; i < order.size(); ++i) {
    if (i == 0 || points[order[i]] != points[order[i - 1]]) runs.emplace_back(order[i], static_cast<std::uint32_t>(i));
  }
  std::vector<std::uint32_t> run_end(runs.size());
  for (std::size_t r = 0; r < runs.size(); ++r) {
    run_end[r] = r + 1 < runs.size() ? runs[r + 1].second : static_cast<std::uint32_t>(order.size());
  }
  std::vector<std::uint32_t> by_index(runs.size());
  std::iota(by_index.begin(), by_index.end(), 0u);
  std::sort(by_index.begin(), by_index.end(),
            [&](std::uint32_t a, std::uint32_t b) { return runs[a].first < runs[b].first; });
  distinct_.reserve(runs.size());
  offsets_.reserve(runs.size() + 1);
  members_.reserve(points.size());
  offsets_.push_back(0);
  for (const std::uint32_t r : by_index) {
    distinct_.push_back(points[runs[r].first]);
    members_.insert(members_.end(), order.begin() + runs[r].second, order.begin() + run_end[r]);
    offsets_.push_back(static_cast<std::uint32_t>(members_.size()));
  }
  tree_.emplace(distinct_);
}

void NearestGroupIndex::append_points(std::uint32_t u, std::size_t limit,
                                      std::vector<std::uint32_t>& out) const {
  if (distinct_.empty()) {
    out.push_back(u);
    return;
  }
  const std::size_t begin = offsets_[u];
  const std::size_t end = std::min<std::size_t>(offsets_[u + 1], begin + limit);
  out.insert(out.end(), members_.begin() + static_cast<std::ptrdiff_t>(begin),
             members_.begin() + static_cast<std::ptrdiff_t>(end));
}

NearestGroups NearestGroupIndex::find(std::span<const Vec3f> queries, Progress* progress) const {
  const KdTree3& tree = *tree_;
  NearestGroups groups;
  groups.nearest.assign(queries.size(), 0);
  groups.distance_squared.assign(queries.size(), 0.0);
  const std::size_t chunks = (queries.size() + kChunk - 1) / kChunk;
  std::vector<std::vector<std::pair<std::uint32_t, std::uint32_t>>> chunk_extra(chunks);
  const std::size_t n = tree.size();
  const std::span<const Vec3f> points = tree.points();

  parallel_for(0, chunks, 1, [&](std::size_t c) {
    const std::size_t begin = c * kChunk;
    const std::size_t end = std::min(queries.size(), begin + kChunk);
    std::vector<std::uint32_t> idx;
    std::vector<float> d2f;
    std::vector<std::uint32_t> positions;
    std::vector<std::uint32_t> members;
    for (std::size_t q = begin; q < end; ++q) {
      const Vec3f& p = queries[q];
      // Two candidates settle almost every query: the second is clearly farther than the first.
      std::size_t k = std::min<std::size_t>(2, n);
      std::size_t found = 0;
      for (;;) {
        idx.resize(k);
        d2f.resize(k);
        found = tree.knn(p, k, idx.data(), d2f.data());
        if (found == n || d2f[found - 1] > d2f[0] + d2f[0] * kFloatSlack || found > kMaxGroup) break;
        k = std::min(k * 4, n);
      }
      double best = std::numeric_limits<double>::infinity();
      for (std::size_t j = 0; j < found; ++j) best = std::min(best, squared_distance(p, points[idx[j]]));
      const double limit = best + best * kTieRelativeTolerance;
      positions.clear();
      for (std::size_t j = 0; j < found; ++j) {
        if (squared_distance(p, points[idx[j]]) <= limit) positions.push_back(idx[j]);
      }
      // The points at those positions, lowest index first: the group's order then depends on
      // the data alone, not on the tree. The tree breaks ties by index (positions are numbered
      // by their lowest point), so a group cut at kMaxGroup keeps its lowest indices.
      members.clear();
      for (const std::uint32_t u : positions) append_points(u, kMaxGroup, members);
      std::sort(members.begin(), members.end());
      if (members.size() > kMaxGroup) members.resize(kMaxGroup);
      groups.nearest[q] = members.front();
      groups.distance_squared[q] = best;
      for (std::size_t j = 1; j < members.size(); ++j) {
        chunk_extra[c].emplace_back(static_cast<std::uint32_t>(q), members[j]);
      }
    }
    progress_advance(progress, end - begin);
  });

  std::size_t total = 0;
  for (const auto& e : chunk_extra) total += e.size();
  groups.extra.reserve(total);
  for (const auto& e : chunk_extra) groups.extra.insert(groups.extra.end(), e.begin(), e.end());
  return groups;
}

}  // namespace sspc::eval
