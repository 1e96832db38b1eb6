#include "core/parallel.hpp"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <vector>

namespace sspc {
namespace {

double sum_with_threads(int threads, const std::vector<double>& v) {
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                            static_cast<std::size_t>(threads));
  return deterministic_sum<double>(0, v.size(), [&](std::size_t i) { return v[i]; }, 1000);
}

TEST(Parallel, ForVisitsEveryIndexOnce) {
  std::vector<int> hits(100'003, 0);
  parallel_for(0, hits.size(), 64, [&](std::size_t i) { hits[i] += 1; });
  for (int h : hits) ASSERT_EQ(h, 1);
}

TEST(Parallel, DeterministicSumIsIdenticalAcrossThreadCounts) {
  // Terms of wildly different magnitude make the sum depend on the order of additions.
  std::vector<double> v(200'000);
  for (std::size_t i = 0; i < v.size(); ++i) {
    v[i] = std::sin(static_cast<double>(i)) * std::pow(10.0, static_cast<double>(i % 17) - 8.0);
  }
  const double one = sum_with_threads(1, v);
  const double two = sum_with_threads(2, v);
  const double four = sum_with_threads(4, v);
  EXPECT_EQ(one, two);
  EXPECT_EQ(one, four);
  double serial = 0;
  for (double x : v) serial += x;
  EXPECT_NEAR(one, serial, 1e-9 * std::abs(serial) + 1e-12);
}

TEST(Parallel, EmptyRangesDoNothing) {
  int calls = 0;
  parallel_for(5, 5, 1, [&](std::size_t) { ++calls; });
  EXPECT_EQ(calls, 0);
  EXPECT_EQ(deterministic_sum<double>(3, 3, [](std::size_t) { return 1.0; }), 0.0);
}

}  // namespace
}  // namespace sspc
