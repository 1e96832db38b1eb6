// Equidistant nearest-neighbour groups against a brute-force scan, on a lattice (where ties are
// everywhere) and on random points (where there are none).
#include "eval/nearest_groups.hpp"

#include <algorithm>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "sspc/synthetic.hpp"

namespace sspc::eval {
namespace {

double d2(const Vec3f& a, const Vec3f& b) { return (a.cast<double>() - b.cast<double>()).squaredNorm(); }

std::vector<std::uint32_t> brute_force_group(const std::vector<Vec3f>& points, const Vec3f& q) {
  double best = std::numeric_limits<double>::infinity();
  for (const Vec3f& p : points) best = std::min(best, d2(p, q));
  std::vector<std::uint32_t> group;
  for (std::uint32_t i = 0; i < points.size(); ++i) {
    if (d2(points[i], q) <= best + best * kTieRelativeTolerance) group.push_back(i);
  }
  return group;
}

void expect_matches_brute_force(const std::vector<Vec3f>& points, const std::vector<Vec3f>& queries,
                                std::size_t* ties) {
  const KdTree3 tree(points);
  const NearestGroups groups = find_nearest_groups(tree, queries, nullptr);
  ASSERT_EQ(groups.size(), queries.size());
  for (std::size_t q = 0; q < queries.size(); ++q) {
    std::vector<std::uint32_t> got;
    groups.for_each_member(q, [&](std::uint32_t i) { got.push_back(i); });
    const std::vector<std::uint32_t> want = brute_force_group(points, queries[q]);
    ASSERT_EQ(got, want) << "query " << q;
    EXPECT_EQ(groups.distance_squared[q], d2(points[want.front()], queries[q]));
    if (want.size() > 1) ++*ties;
  }
}

TEST(NearestGroups, LatticeWithTies) {
  // Steps of 1/8 are exact in float, so the ties are exact. Queries at cell centres, face centres and lattice points: groups of 8, 2 and 1.
  std::vector<Vec3f> points;
  for (float x = 0; x < 6; ++x)
    for (float y = 0; y < 6; ++y)
      for (float z = 0; z < 6; ++z) points.push_back({0.125f * x, 0.125f * y, 0.125f * z});
  std::vector<Vec3f> queries;
  for (float i = 0; i < 5; ++i) {
    queries.push_back({0.0625f + 0.125f * i, 0.0625f + 0.125f * i, 0.0625f + 0.125f * (4 - i)});
    queries.push_back({0.125f * i, 0.25f, 0.0625f + 0.125f * i});
    queries.push_back({0.125f * i, 0.375f, 0.125f * i});
  }
  std::size_t ties = 0;
  expect_matches_brute_force(points, queries, &ties);
  EXPECT_GE(ties, 5u);  // the test exercises groups at all
}

TEST(NearestGroups, RandomPoints) {
  const PointCloud a = synthetic::sphere(3000, 1.0);
  synthetic::Options other;
  other.seed = 99;
  const PointCloud b = synthetic::sphere(500, 1.0, other);
  std::size_t ties = 0;
  expect_matches_brute_force(a.positions, b.positions, &ties);
  EXPECT_EQ(ties, 0u);
}

TEST(NearestGroups, DuplicatePointsFormOneGroup) {
  const std::vector<Vec3f> points = {{0, 0, 0}, {1, 1, 1}, {0, 0, 0}, {0, 0, 0}, {2, 2, 2}};
  const std::vector<Vec3f> queries = {{0, 0, 0}, {0.1f, 0, 0}, {2, 2, 2}};
  std::size_t ties = 0;
  expect_matches_brute_force(points, queries, &ties);
  EXPECT_EQ(ties, 2u);
}

}  // namespace
}  // namespace sspc::eval
