// KdTreeL1 against brute force on random 8- and 32-dimensional vectors: radius answers must be
// exactly the items with l1_distance ≤ radius (boundary included) and k-NN answers the k
// smallest (distance, index) pairs.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <vector>

#include "sspc/neighbours.hpp"
#include "sspc/synthetic.hpp"

namespace sspc {
namespace {

// Cumulative-histogram-like rows in [0, 1]; every fifth row copies an earlier one so that
// distances tie, and values are on a grid of 1/8 so that sums are often exactly equal.
std::vector<float> random_rows(std::size_t rows, std::size_t dimension, std::uint64_t seed) {
  synthetic::Rng rng(seed);
  std::vector<float> data(rows * dimension);
  for (std::size_t r = 0; r < rows; ++r) {
    for (std::size_t d = 0; d < dimension; ++d) {
      data[r * dimension + d] = r % 5 == 4 ? data[(r / 2) * dimension + d]
                                           : static_cast<float>(rng.next_u64() % 9) / 8.0f;
    }
  }
  return data;
}

std::vector<L1Neighbour> brute_sorted(const std::vector<float>& data, std::size_t dimension,
                                     const float* query) {
  std::vector<L1Neighbour> all;
  for (std::size_t r = 0; r < data.size() / dimension; ++r) {
    all.push_back(
        {static_cast<std::uint32_t>(r), l1_distance(query, &data[r * dimension], dimension)});
  }
  std::sort(all.begin(), all.end(), [](const L1Neighbour& a, const L1Neighbour& b) {
    return a.distance < b.distance || (a.distance == b.distance && a.index < b.index);
  });
  return all;
}

class KdTreeL1Test : public ::testing::TestWithParam<std::size_t> {};

TEST_P(KdTreeL1Test, RadiusAndKnnMatchBruteForce) {
  const std::size_t dimension = GetParam();
  const std::size_t rows = 1500;
  const auto data = random_rows(rows, dimension, 11 + dimension);
  const KdTreeL1 tree(data, dimension, 8);
  ASSERT_EQ(tree.size(), rows);
  ASSERT_EQ(tree.dimension(), dimension);
  synthetic::Rng rng(4);
  std::vector<float> query(dimension);
  for (std::size_t trial = 0; trial < 60; ++trial) {
    // Queries: a stored row, or a row nudged off the value grid.
    const std::size_t source = rng.next_u64() % rows;
    for (std::size_t d = 0; d < dimension; ++d) {
      query[d] = data[source * dimension + d] +
                 (trial % 2 == 0 ? 0.0f : static_cast<float>(rng.uniform(-0.1, 0.1)));
    }
    const auto all = brute_sorted(data, dimension, query.data());

    // Radius: half the radii equal an actual distance, so items lie exactly on the boundary.
    const float radius =
        trial % 3 == 0 ? all[rng.next_u64() % 200].distance
                       : static_cast<float>(rng.uniform(0, 0.15 * static_cast<double>(dimension)));
    std::vector<L1Neighbour> expected;
    for (const auto& n : all) {
      if (n.distance <= radius) expected.push_back(n);
    }
    std::vector<L1Neighbour> got;
    ASSERT_EQ(tree.radius(query, radius, got), expected.size()) << "trial " << trial;
    for (std::size_t j = 0; j < got.size(); ++j) {
      ASSERT_EQ(got[j].index, expected[j].index);
      ASSERT_EQ(got[j].distance, expected[j].distance);
    }

    for (std::size_t k : {std::size_t{1}, std::size_t{7}, std::size_t{25}}) {
      ASSERT_EQ(tree.knn(query, k, got), k);
      for (std::size_t j = 0; j < k; ++j) {
        ASSERT_EQ(got[j].index, all[j].index) << "trial " << trial << " k " << k << " j " << j;
        ASSERT_EQ(got[j].distance, all[j].distance);
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Dimensions, KdTreeL1Test,
                         ::testing::Values(std::size_t{8}, std::size_t{32}));

TEST(KdTreeL1, EmptyAndShortQueriesAnswerNothing) {
  const std::vector<float> none;
  const KdTreeL1 empty(none, 4);
  std::vector<L1Neighbour> got;
  const std::vector<float> query(4, 0.0f);
  EXPECT_EQ(empty.radius(query, 1.0f, got), 0u);
  EXPECT_EQ(empty.knn(query, 3, got), 0u);

  const std::vector<float> data = {0, 0, 0, 0, 1, 1, 1, 1};
  const KdTreeL1 tree(data, 4);
  EXPECT_EQ(tree.radius(std::span<const float>(query).first(3), 10.0f, got), 0u);
  EXPECT_EQ(tree.knn(query, 5, got), 2u);
  EXPECT_EQ(got[1].distance, 4.0f);
}

}  // namespace
}  // namespace sspc
