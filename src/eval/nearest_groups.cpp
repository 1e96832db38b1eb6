// Equidistant nearest-neighbour groups (docs/METRICS.md, "Equidistant neighbours"; the grouping
// follows mpeg-pcc-dmetric's findMetric/scaleNormals, the equality test does not).
#include "eval/nearest_groups.hpp"

#include <algorithm>
#include <limits>

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

NearestGroupIndex::NearestGroupIndex(std::span<const Vec3f> points) : distinct_(points) {
  tree_.emplace(distinct_.gathered() ? distinct_.positions() : points);
}

void NearestGroupIndex::append_points(std::uint32_t u, std::size_t limit,
                                      std::vector<std::uint32_t>& out) const {
  if (!distinct_.gathered()) {
    out.push_back(u);
    return;
  }
  const auto members = distinct_.members(u);
  out.insert(out.end(), members.begin(), members.begin() + static_cast<std::ptrdiff_t>(std::min(limit, members.size())));
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
