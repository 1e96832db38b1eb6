// sspc::evaluate's colour PSNR against values worked out by hand (docs/METRICS.md, "Colour"):
// identical colours, a constant offset, two directions that differ, and a point equidistant
// from two differently coloured neighbours.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "sspc/metrics.hpp"
#include "sspc/synthetic.hpp"

namespace sspc {
namespace {

PointCloud coloured(std::vector<std::pair<Vec3f, Rgb8>> points) {
  PointCloud c;
  for (const auto& [position, colour] : points) {
    c.positions.push_back(position);
    c.colours.push_back(colour);
  }
  return c;
}

// A deterministic colour for every point, each channel below 250 so that +5 cannot saturate.
PointCloud with_colours(PointCloud c) {
  c.colours.resize(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) {
    c.colours[i] = Rgb8{static_cast<std::uint8_t>((i * 37) % 250),
                        static_cast<std::uint8_t>((i * 11 + 90) % 250),
                        static_cast<std::uint8_t>((i * 5 + 200) % 250)};
  }
  return c;
}

// Saturating, as an image editor brightens; with_colours keeps every channel below 250, so the
// known answer below holds exactly.
std::uint8_t plus_five(std::uint8_t v) {
  return static_cast<std::uint8_t>(std::min(255, v + 5));
}

TEST(ColourPsnr, Formula) {
  EXPECT_TRUE(std::isinf(colour_psnr(0.0)));
  EXPECT_DOUBLE_EQ(colour_psnr(255.0 * 255.0), 0.0);
  EXPECT_NEAR(colour_psnr(25.0), 34.151, 5e-4);  // 10·log10(65025 / 25)
}

TEST(ColourPsnr, IdenticalCloudsHaveInfinitePsnr) {
  const PointCloud ref = with_colours(synthetic::sphere(2000, 1.0));
  const auto report = evaluate(ref, ref);
  ASSERT_TRUE(report.ok()) << report.status().message();
  ASSERT_TRUE(report->has_colour);
  EXPECT_EQ(report->colour_mse, 0.0);
  EXPECT_TRUE(std::isinf(report->colour_psnr));
}

// Every channel of every point 5 levels up, positions unchanged: each point's nearest neighbour
// is its own copy, so both directions' MSE is exactly 5² = 25 and the PSNR 10·log10(65025/25).
TEST(ColourPsnr, ConstantOffsetOfFiveLevels) {
  const PointCloud ref = with_colours(synthetic::sphere(2000, 1.0));
  PointCloud test = ref;
  for (Rgb8& c : test.colours) c = Rgb8{plus_five(c.r), plus_five(c.g), plus_five(c.b)};
  const auto report = evaluate(ref, test);
  ASSERT_TRUE(report.ok()) << report.status().message();
  ASSERT_TRUE(report->has_colour);
  EXPECT_EQ(report->ref_to_test.mse_colour, 25.0);
  EXPECT_EQ(report->test_to_ref.mse_colour, 25.0);
  EXPECT_EQ(report->colour_mse, 25.0);
  EXPECT_DOUBLE_EQ(report->colour_psnr, 10.0 * std::log10(65025.0 / 25.0));
  EXPECT_NEAR(report->colour_psnr, 34.151, 5e-4);
}

// REF  A0 = (0,0,0) (100,100,100), A1 = (2,0,0) (100,106,100)
// TEST B0 = (0,0,0) (100,100,100), B1 = (2,0,0) (100,100,100), B2 = (4,0,0) (130,100,100)
//   REF→TEST: A0 → B0: 0; A1 → B1: 6² / 3 = 12               → MSE (0 + 12) / 2 = 6
//   TEST→REF: B0 → A0: 0; B1 → A1: 12; B2 → A1: (30² + 6²) / 3 = 312 → MSE 324 / 3 = 108
// The larger, 108, is the colour MSE whichever cloud is the reference.
TEST(ColourPsnr, TheLargerDirectionIsTaken) {
  const PointCloud ref = coloured({{{0, 0, 0}, {100, 100, 100}}, {{2, 0, 0}, {100, 106, 100}}});
  const PointCloud test = coloured(
      {{{0, 0, 0}, {100, 100, 100}}, {{2, 0, 0}, {100, 100, 100}}, {{4, 0, 0}, {130, 100, 100}}});
  const auto report = evaluate(ref, test);
  ASSERT_TRUE(report.ok()) << report.status().message();
  EXPECT_DOUBLE_EQ(report->ref_to_test.mse_colour, 6.0);
  EXPECT_DOUBLE_EQ(report->test_to_ref.mse_colour, 108.0);
  EXPECT_DOUBLE_EQ(report->colour_mse, 108.0);
  EXPECT_DOUBLE_EQ(report->colour_psnr, 10.0 * std::log10(65025.0 / 108.0));
  const auto swapped = evaluate(test, ref);
  ASSERT_TRUE(swapped.ok());
  EXPECT_DOUBLE_EQ(swapped->ref_to_test.mse_colour, 108.0);
  EXPECT_DOUBLE_EQ(swapped->test_to_ref.mse_colour, 6.0);
  EXPECT_EQ(swapped->colour_mse, report->colour_mse);
}

// TEST B = (0,0,0.5) is equidistant from REF A0 = (−1,0,0) and A1 = (1,0,0): it is compared with
// their mean colour, as pc_error's default --neighborsProc=1 does.
//   A0 (100,41,20), A1 (201,80,20): mean (150.5, 60.5, 20); B (150,60,20)
//   TEST→REF: (0.5² + 0.5² + 0) / 3 = 0.5 / 3   (A0 alone would give (50² + 19²) / 3 = 2,861 / 3)
//   REF→TEST: both have B as their only neighbour:
//     A0: (50² + 19² + 0) / 3 = 2,861 / 3, A1: (51² + 20² + 0) / 3 = 3,001 / 3 → mean 5,862 / 6
TEST(ColourPsnr, EquidistantNeighboursAreAveraged) {
  const PointCloud ref = coloured({{{-1, 0, 0}, {100, 41, 20}}, {{1, 0, 0}, {201, 80, 20}}});
  const PointCloud test = coloured({{{0, 0, 0.5f}, {150, 60, 20}}});
  const auto report = evaluate(ref, test);
  ASSERT_TRUE(report.ok()) << report.status().message();
  EXPECT_DOUBLE_EQ(report->test_to_ref.mse_colour, 0.5 / 3.0);
  EXPECT_DOUBLE_EQ(report->ref_to_test.mse_colour, 5862.0 / 6.0);
  EXPECT_DOUBLE_EQ(report->colour_mse, 5862.0 / 6.0);
}

// Coincident points are the commonest equidistant group (a coder that merges points, or keeps
// duplicates): REF's point meets the mean of TEST's two copies.
TEST(ColourPsnr, CoincidentPointsAreAveraged) {
  const PointCloud ref = coloured({{{0, 0, 0}, {100, 100, 100}}, {{1, 0, 0}, {0, 0, 0}}});
  const PointCloud test =
      coloured({{{0, 0, 0}, {90, 100, 120}}, {{0, 0, 0}, {110, 100, 80}}, {{1, 0, 0}, {0, 0, 0}}});
  const auto report = evaluate(ref, test);
  ASSERT_TRUE(report.ok()) << report.status().message();
  EXPECT_EQ(report->ref_to_test.mse_colour, 0.0);
  // Each copy against REF's point: (10² + 0 + 20²) / 3 each; the third point matches exactly.
  EXPECT_DOUBLE_EQ(report->test_to_ref.mse_colour, 1000.0 / 9.0);
}

TEST(ColourPsnr, OnlyWhenBothCloudsHaveColours) {
  const PointCloud plain = synthetic::sphere(500, 1.0);
  const PointCloud with = with_colours(plain);
  for (const auto& [ref, test] : {std::pair{&plain, &with}, std::pair{&with, &plain}}) {
    const auto report = evaluate(*ref, *test);
    ASSERT_TRUE(report.ok());
    EXPECT_FALSE(report->has_colour);
    EXPECT_FALSE(report->ref_to_test.has_colour);
    EXPECT_FALSE(report->test_to_ref.has_colour);
  }
}

TEST(ColourPsnr, SameResultOnOneAndTwoThreads) {
  synthetic::Options noisy;
  noisy.seed = 13;
  noisy.noise = 0.002;
  const PointCloud ref = with_colours(synthetic::bumps(40000, 1.0, 4, 0.1));
  PointCloud test = synthetic::bumps(30000, 1.0, 4, 0.1, noisy);
  test.colours.resize(test.size());
  for (std::size_t i = 0; i < test.size(); ++i) {
    test.colours[i] = Rgb8{static_cast<std::uint8_t>(i % 251), static_cast<std::uint8_t>(i % 241),
                           static_cast<std::uint8_t>(i % 239)};
  }
  EvalReport one;
  EvalReport two;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    one = evaluate(ref, test).value();
  }
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
    two = evaluate(ref, test).value();
  }
  ASSERT_TRUE(one.has_colour);
  EXPECT_GT(one.colour_mse, 0.0);
  EXPECT_EQ(one.ref_to_test.mse_colour, two.ref_to_test.mse_colour);
  EXPECT_EQ(one.test_to_ref.mse_colour, two.test_to_ref.mse_colour);
  EXPECT_EQ(one.colour_psnr, two.colour_psnr);
}

}  // namespace
}  // namespace sspc
