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
  if (group.size() > kMaxGroup) group.resize(kMaxGroup);  // the lowest indices
  return group;
}

void expect_matches_brute_force(const std::vector<Vec3f>& points, const std::vector<Vec3f>& queries,
                                std::size_t* ties) {
  const NearestGroupIndex index(points);
  const NearestGroups groups = index.find(queries, nullptr);
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

// The points (step·x, step·y, step·z) for x < nx, y < ny, z < nz.
std::vector<Vec3f> lattice(int nx, int ny, int nz, float step) {
  std::vector<Vec3f> points;
  for (int x = 0; x < nx; ++x)
    for (int y = 0; y < ny; ++y)
      for (int z = 0; z < nz; ++z)
        points.push_back(step * Vec3f(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z)));
  return points;
}

TEST(NearestGroups, LatticeWithTies) {
  // Steps of 1/8 are exact in float, so the ties are exact. Queries at cell centres, face centres and lattice points: groups of 8, 2 and 1.
  const std::vector<Vec3f> points = lattice(6, 6, 6, 0.125f);
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

TEST(NearestGroups, CoincidentPointsByTheHundred) {
  // A coarsely quantised decode: 40 positions on a lattice, each held by 150 points whose
  // indices interleave across positions. A query nearest one position gets the lowest 30 of its
  // points; one midway between positions, the lowest 30 of all theirs. The index keeps 40
  // positions.
  const std::vector<Vec3f> grid = lattice(5, 4, 2, 0.25f);
  std::vector<Vec3f> points;
  for (std::size_t copy = 0; copy < 150; ++copy)
    for (std::size_t i = 0; i < grid.size(); ++i) points.push_back(grid[(i * 7 + copy) % grid.size()]);
  const std::vector<Vec3f> queries = {{0.25f, 0.25f, 0}, {0.125f, 0.5f, 0.25f}, {0.3f, 0.01f, 0.2f},
                                      {1, 0.75f, 0.25f}, {0.5f, 0.5f, 0.125f}};
  std::size_t ties = 0;
  expect_matches_brute_force(points, queries, &ties);
  EXPECT_EQ(ties, queries.size());
  EXPECT_EQ(NearestGroupIndex(points).distinct_positions(), grid.size());
  EXPECT_EQ(NearestGroupIndex(grid).distinct_positions(), grid.size());
}

}  // namespace
}  // namespace sspc::eval
