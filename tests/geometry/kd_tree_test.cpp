// KdTree3 against brute force: the tree's answers must equal a scan's, ties and boundary
// included, whatever the tree's shape (leaf sizes 1 and 10).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <vector>

#include "sspc/neighbours.hpp"
#include "sspc/synthetic.hpp"

namespace sspc {
namespace {

float distance_squared(const Vec3f& a, const Vec3f& b) {
  // The same expression nanoflann's L2_Simple_Adaptor evaluates, term by term in order.
  const float dx = a.x() - b.x();
  const float dy = a.y() - b.y();
  const float dz = a.z() - b.z();
  return dx * dx + dy * dy + dz * dz;
}

bool before(const Neighbour& a, const Neighbour& b) {
  return a.distance_squared < b.distance_squared ||
         (a.distance_squared == b.distance_squared && a.index < b.index);
}

std::vector<Neighbour> brute_sorted(const std::vector<Vec3f>& points, const Vec3f& q) {
  std::vector<Neighbour> all;
  all.reserve(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    all.push_back({static_cast<std::uint32_t>(i), distance_squared(points[i], q)});
  }
  std::sort(all.begin(), all.end(), before);
  return all;
}

// Points on a coarse integer lattice with many exact duplicates and many equal distances, so
// that the k-th neighbour is usually one of several ties.
std::vector<Vec3f> tie_heavy_cloud(std::size_t n, std::uint64_t seed) {
  synthetic::Rng rng(seed);
  std::vector<Vec3f> points;
  points.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    points.emplace_back(static_cast<float>(rng.next_u64() % 6),
                        static_cast<float>(rng.next_u64() % 6),
                        static_cast<float>(rng.next_u64() % 3));
  }
  return points;
}

std::vector<Vec3f> random_cloud(std::size_t n, std::uint64_t seed) {
  synthetic::Rng rng(seed);
  std::vector<Vec3f> points;
  points.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    points.emplace_back(static_cast<float>(rng.uniform(-1, 1)),
                        static_cast<float>(rng.uniform(-1, 1)),
                        static_cast<float>(rng.uniform(-1, 1)));
  }
  // Exact duplicates of a few points, at higher indices than their originals.
  for (std::size_t i = 0; i < n / 10; ++i) points.push_back(points[i * 7 % n]);
  return points;
}

void expect_knn_matches_brute_force(const std::vector<Vec3f>& points, std::size_t leaf_size) {
  const KdTree3 tree(points, leaf_size);
  synthetic::Rng rng(99);
  for (std::size_t trial = 0; trial < 200; ++trial) {
    // Half the queries are the cloud's own points, half lie anywhere in its box.
    const Vec3f q = trial % 2 == 0 ? points[rng.next_u64() % points.size()]
                                   : Vec3f(static_cast<float>(rng.uniform(-1, 6)),
                                           static_cast<float>(rng.uniform(-1, 6)),
                                           static_cast<float>(rng.uniform(-1, 3)));
    const auto expected = brute_sorted(points, q);
    for (std::size_t k : {std::size_t{1}, std::size_t{5}, std::size_t{16}}) {
      std::vector<Neighbour> got;
      ASSERT_EQ(tree.knn(q, k, got), k);
      for (std::size_t j = 0; j < k; ++j) {
        ASSERT_EQ(got[j].index, expected[j].index) << "trial " << trial << " k " << k << " j " << j;
        ASSERT_EQ(got[j].distance_squared, expected[j].distance_squared);
      }
    }
    float d2 = -1;
    EXPECT_EQ(tree.nearest(q, &d2), expected[0].index);
    EXPECT_EQ(d2, expected[0].distance_squared);
  }
}

TEST(KdTree3, KnnMatchesBruteForceWithTies) {
  const auto points = tie_heavy_cloud(600, 5);
  expect_knn_matches_brute_force(points, 10);
  expect_knn_matches_brute_force(points, 1);
}

TEST(KdTree3, KnnMatchesBruteForceOnRandomCloudWithDuplicates) {
  const auto points = random_cloud(2000, 6);
  expect_knn_matches_brute_force(points, 10);
}

TEST(KdTree3, KnnReturnsAllPointsWhenKExceedsSize) {
  const std::vector<Vec3f> points = {Vec3f(0, 0, 0), Vec3f(1, 0, 0), Vec3f(0, 0, 0)};
  const KdTree3 tree(points);
  std::vector<Neighbour> got;
  ASSERT_EQ(tree.knn(Vec3f(0, 0, 0), 10, got), 3u);
  EXPECT_EQ(got[0].index, 0u);
  EXPECT_EQ(got[1].index, 2u);
  EXPECT_EQ(got[2].index, 1u);
}

TEST(KdTree3, EmptyTreeAnswersNothing) {
  const std::vector<Vec3f> points;
  const KdTree3 tree(points);
  std::vector<Neighbour> got;
  EXPECT_EQ(tree.knn(Vec3f(0, 0, 0), 3, got), 0u);
  EXPECT_EQ(tree.radius(Vec3f(0, 0, 0), 1.0f, got), 0u);
  EXPECT_EQ(tree.radius_count(Vec3f(0, 0, 0), 1.0f), 0u);
  const KnnTable table = tree.knn_batch(points, 4);
  EXPECT_TRUE(table.count.empty());
}

TEST(KdTree3, RadiusMatchesBruteForceAndIncludesBoundary) {
  for (const auto& points : {tie_heavy_cloud(600, 7), random_cloud(2000, 8)}) {
    const KdTree3 tree(points, 4);
    synthetic::Rng rng(3);
    for (std::size_t trial = 0; trial < 100; ++trial) {
      const Vec3f q = points[rng.next_u64() % points.size()];
      // Radii equal to actual distances put points exactly on the sphere: they must be kept.
      const auto all = brute_sorted(points, q);
      const float r = trial % 2 == 0 ? std::sqrt(all[rng.next_u64() % all.size()].distance_squared)
                                     : static_cast<float>(rng.uniform(0, 2));
      const float r2 = r * r;
      std::vector<Neighbour> expected;
      for (const auto& n : all) {
        if (n.distance_squared <= r2) expected.push_back(n);
      }
      std::vector<Neighbour> got;
      ASSERT_EQ(tree.radius(q, r, got), expected.size()) << "trial " << trial << " r " << r;
      ASSERT_EQ(tree.radius_count(q, r), expected.size()) << "trial " << trial << " r " << r;
      for (std::size_t j = 0; j < got.size(); ++j) {
        ASSERT_EQ(got[j].index, expected[j].index);
        ASSERT_EQ(got[j].distance_squared, expected[j].distance_squared);
      }
      // Unsorted answers hold the same set.
      std::vector<Neighbour> unsorted;
      tree.radius(q, r, unsorted, false);
      std::sort(unsorted.begin(), unsorted.end(), before);
      ASSERT_EQ(unsorted.size(), expected.size());
      for (std::size_t j = 0; j < unsorted.size(); ++j)
        ASSERT_EQ(unsorted[j].index, expected[j].index);
    }
  }
}

TEST(KdTree3, RadiusKeepsPointExactlyOnTheBoundary) {
  const std::vector<Vec3f> points = {Vec3f(0, 0, 0), Vec3f(3, 0, 0), Vec3f(0, 4, 0),
                                     Vec3f(5, 0.1f, 0)};
  const KdTree3 tree(points, 1);
  std::vector<Neighbour> got;
  ASSERT_EQ(tree.radius(Vec3f(0, 0, 0), 4.0f, got), 3u);
  EXPECT_EQ(got[2].index, 2u);
  EXPECT_EQ(got[2].distance_squared, 16.0f);
}

TEST(KdTree3, KnnBatchMatchesSingleQueriesAndExcludesSelf) {
  auto points = random_cloud(3000, 9);
  // Duplicates at lower and higher indices than the query: self-exclusion must drop exactly the
  // query's own index and keep its twins.
  points.push_back(points[0]);
  points.push_back(points[0]);
  const KdTree3 tree(points);
  const std::size_t k = 8;
  const KnnTable with_self = tree.knn_batch(points, k, false);
  const KnnTable without_self = tree.knn_batch(points, k, true);
  ASSERT_EQ(with_self.count.size(), points.size());
  // Without distances: the same rows, and no distances held.
  const KnnTable indices_only = tree.knn_batch(points, k, true, nullptr, false);
  EXPECT_TRUE(indices_only.distances_squared.empty());
  EXPECT_EQ(indices_only.indices, without_self.indices);
  EXPECT_EQ(indices_only.count, without_self.count);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto expected = brute_sorted(points, points[i]);
    ASSERT_EQ(with_self.count[i], k);
    ASSERT_EQ(without_self.count[i], k);
    const auto row = with_self.row(i);
    for (std::size_t j = 0; j < k; ++j) ASSERT_EQ(row[j], expected[j].index) << i;
    std::vector<std::uint32_t> others;
    for (const auto& n : expected) {
      if (n.index != i && others.size() < k) others.push_back(n.index);
    }
    const auto row_ex = without_self.row(i);
    const auto dist_ex = without_self.row_distances(i);
    for (std::size_t j = 0; j < k; ++j) {
      ASSERT_EQ(row_ex[j], others[j]) << i;
      ASSERT_NE(row_ex[j], i);
      ASSERT_EQ(dist_ex[j], distance_squared(points[i], points[row_ex[j]]));
    }
  }
  // Point 0 has three twins (random_cloud copied it to index 3000, then 3300 and 3301 here):
  // the last one's row starts with the other three, in index order.
  const auto last = without_self.row(points.size() - 1);
  EXPECT_EQ(last[0], 0u);
  EXPECT_EQ(last[1], 3000u);
  EXPECT_EQ(last[2], points.size() - 2);
  EXPECT_EQ(without_self.row_distances(points.size() - 1)[2], 0.0f);
}

TEST(KdTree3, KnnBatchOnTinyCloudFillsWhatExists) {
  const std::vector<Vec3f> points = {Vec3f(0, 0, 0), Vec3f(1, 0, 0), Vec3f(2, 0, 0)};
  const KdTree3 tree(points);
  const KnnTable table = tree.knn_batch(points, 5, true);
  ASSERT_EQ(table.count.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) EXPECT_EQ(table.count[i], 2u);
  EXPECT_EQ(table.row(1)[0], 0u);  // 0 and 2 tie at distance 1; the lower index first
  EXPECT_EQ(table.row(1)[1], 2u);
}

TEST(KdTree3, NominalSpacingOfRegularGridIsItsStep) {
  PointCloud cloud;
  const float step = 0.25f;
  for (int y = 0; y < 60; ++y) {
    for (int x = 0; x < 70; ++x)
      cloud.positions.emplace_back(step * static_cast<float>(x), step * static_cast<float>(y),
                                   2.0f);
  }
  EXPECT_FLOAT_EQ(static_cast<float>(nominal_spacing(cloud)), step);
  EXPECT_FLOAT_EQ(static_cast<float>(nominal_spacing(cloud, 100)), step);
  PointCloud one;
  one.positions.emplace_back(0, 0, 0);
  EXPECT_EQ(nominal_spacing(one), 0.0);
}

// Duplicates do not shrink the spacing: it is that of the distinct positions, so that a cloud
// written twice (or with most points doubled) keeps the step that renderers and the codec derive
// from it (it was 0, and a march in steps of it never moved).
TEST(KdTree3, NominalSpacingIgnoresCoincidentPoints) {
  PointCloud cloud;
  const float step = 0.25f;
  for (int y = 0; y < 60; ++y) {
    for (int x = 0; x < 70; ++x) cloud.positions.emplace_back(step * static_cast<float>(x), step * static_cast<float>(y), 2.0f);
  }
  PointCloud doubled = cloud;
  doubled.positions.insert(doubled.positions.end(), cloud.positions.begin(), cloud.positions.end());
  EXPECT_FLOAT_EQ(static_cast<float>(nominal_spacing(doubled)), step);
  PointCloud some = cloud;  // a tenth of the points doubled
  for (std::size_t i = 0; i < cloud.size(); i += 10) some.positions.push_back(cloud.positions[i]);
  EXPECT_FLOAT_EQ(static_cast<float>(nominal_spacing(some)), step);
  PointCloud coincident;
  coincident.positions.assign(50, Vec3f(1, 2, 3));
  EXPECT_EQ(nominal_spacing(coincident), 0.0);
}

TEST(GeometryRange, LimitsOfFloat32AreNamed) {
  PointCloud cloud;
  for (int i = 0; i < 100; ++i) cloud.positions.emplace_back(0.01f * static_cast<float>(i), 0.0f, 1.0f);
  EXPECT_TRUE(check_geometry_range(cloud.positions, 0.01).ok());
  EXPECT_TRUE(check_coordinate_range(cloud.positions).ok());

  PointCloud outlier = cloud;
  outlier.positions[3].x() = 1e20f;
  const Status far = check_coordinate_range(outlier.positions);
  EXPECT_EQ(far.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(far.message().find("coordinates reach 1e+20"), std::string::npos) << far.message();

  PointCloud tiny = cloud;
  for (Vec3f& p : tiny.positions) p *= 1e-30f;
  EXPECT_FALSE(check_coordinate_range(tiny.positions).ok());
  EXPECT_FALSE(check_geometry_range(cloud.positions, 1e-20).ok());
  EXPECT_FALSE(check_geometry_range(cloud.positions, 0.0).ok());

  PointCloud spread = cloud;  // 10^17 spacings across: beyond float32's 2^24
  spread.positions[0].x() = 1e15f;
  EXPECT_TRUE(check_coordinate_range(spread.positions).ok());
  const Status wide = check_geometry_range(spread.positions, 0.01);
  EXPECT_NE(wide.message().find("spacings"), std::string::npos) << wide.message();

  PointCloud same;
  same.positions.assign(10, Vec3f(1, 1, 1));
  EXPECT_NE(check_geometry_range(same.positions, 0.0).message().find("coincide"), std::string::npos);
}

}  // namespace
}  // namespace sspc
