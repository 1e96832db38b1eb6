// Distinct positions and the k-NN over them: the table must equal KdTree3's over the points
// themselves, entry for entry, on clouds where points coincide by the hundred.
#include "geometry/distinct_positions.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <vector>

#include "sspc/neighbours.hpp"
#include "sspc/synthetic.hpp"

namespace sspc {
namespace {

// `positions` distinct random positions (some on a coarse grid, so that distinct positions
// also tie in distance), each repeated a random 1-300 times, shuffled.
std::vector<Vec3f> coincident_cloud(std::size_t positions, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> cell(0, 7);
  std::uniform_int_distribution<std::size_t> copies(1, 300);
  std::vector<Vec3f> points;
  for (std::size_t i = 0; i < positions; ++i) {
    const Vec3f p(0.25f * static_cast<float>(cell(rng)), 0.25f * static_cast<float>(cell(rng)),
                  0.25f * static_cast<float>(cell(rng)));
    const std::size_t n = copies(rng);
    for (std::size_t c = 0; c < n; ++c) points.push_back(p);
  }
  std::shuffle(points.begin(), points.end(), rng);
  return points;
}

void expect_same_table(const KnnTable& got, const KnnTable& want) {
  ASSERT_EQ(got.k, want.k);
  ASSERT_EQ(got.count, want.count);
  ASSERT_EQ(got.indices, want.indices);
  ASSERT_EQ(got.distances_squared, want.distances_squared);
}

TEST(DistinctPositions, GroupsCoincidentPointsByLowestIndex) {
  const std::vector<Vec3f> points = {{1, 0, 0}, {0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {0, 0, 0}, {1, 0, 0}};
  const DistinctPositions distinct(points);
  ASSERT_TRUE(distinct.gathered());
  ASSERT_EQ(distinct.positions().size(), 3u);
  EXPECT_EQ(distinct.positions()[0], Vec3f(1, 0, 0));
  EXPECT_EQ(distinct.positions()[1], Vec3f(0, 0, 0));
  EXPECT_EQ(distinct.positions()[2], Vec3f(2, 0, 0));
  EXPECT_EQ(std::vector<std::uint32_t>(distinct.members(0).begin(), distinct.members(0).end()),
            (std::vector<std::uint32_t>{0, 2, 5}));
  EXPECT_EQ(std::vector<std::uint32_t>(distinct.members(1).begin(), distinct.members(1).end()),
            (std::vector<std::uint32_t>{1, 4}));
  EXPECT_FALSE(DistinctPositions(synthetic::sphere(500, 1.0).positions).gathered());
}

TEST(DistinctPositions, KnnEqualsTheTreeOverThePoints) {
  for (const unsigned seed : {1u, 2u, 3u}) {
    const std::vector<Vec3f> points = coincident_cloud(60, seed);
    // k = 500 (beyond most groups' reach) once: it is the slowest case by far under ASan.
    for (const std::size_t k : {std::size_t{1}, std::size_t{16}, std::size_t{40}, seed == 1 ? std::size_t{500} : 0}) {
      if (k == 0) continue;
      SCOPED_TRACE(testing::Message() << "seed " << seed << ", k " << k);
      expect_same_table(knn_of_own_points(points, k, nullptr), KdTree3(points).knn_batch(points, k));
    }
  }
}

TEST(DistinctPositions, KnnWithoutDistancesHasTheSameRows) {
  for (const std::vector<Vec3f>& points : {coincident_cloud(60, 4), synthetic::sphere(2000, 1.0).positions}) {
    const KnnTable with = knn_of_own_points(points, 16, nullptr);
    const KnnTable without = knn_of_own_points(points, 16, nullptr, false);
    EXPECT_TRUE(without.distances_squared.empty());
    EXPECT_EQ(without.k, with.k);
    EXPECT_EQ(without.count, with.count);
    EXPECT_EQ(without.indices, with.indices);
  }
}

TEST(DistinctPositions, KnnWithoutCoincidentPointsIsTheTree) {
  const std::vector<Vec3f> points = synthetic::sphere(2000, 1.0).positions;
  expect_same_table(knn_of_own_points(points, 12, nullptr), KdTree3(points).knn_batch(points, 12));
}

}  // namespace
}  // namespace sspc
