// sspc::evaluate against values worked out by hand on clouds of two or three points
// (docs/METRICS.md gives the formulas), and its invariants on larger random clouds.
#include "sspc/metrics.hpp"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "sspc/synthetic.hpp"

namespace sspc {
namespace {

PointCloud cloud(std::initializer_list<Vec3f> positions, std::initializer_list<Vec3f> normals = {}) {
  PointCloud c;
  c.positions = positions;
  c.normals = normals;
  return c;
}

// REF = {(0,0,0), (2,0,0)}, TEST = {(0,0,1), (2,0,0), (4,0,0)}.
//   REF→TEST: d² = 1, 0         → MSE 1/2, Hausdorff 1
//   TEST→REF: d² = 1, 0, 4      → MSE 5/3, Hausdorff 2
// d_B = 2, so PSNR(paper) = 20·log10(2 / sqrt(5/3)) and D1 PSNR = 10·log10(3·2² / (5/3)).
TEST(Evaluate, HandComputedPointToPoint) {
  const PointCloud ref = cloud({{0, 0, 0}, {2, 0, 0}});
  const PointCloud test = cloud({{0, 0, 1}, {2, 0, 0}, {4, 0, 0}});
  const auto report = evaluate(ref, test);
  ASSERT_TRUE(report.ok()) << report.status().message();
  EXPECT_EQ(report->ref_points, 2u);
  EXPECT_EQ(report->test_points, 3u);
  EXPECT_DOUBLE_EQ(report->ref_diagonal, 2.0);
  EXPECT_DOUBLE_EQ(report->peak, 2.0);
  EXPECT_DOUBLE_EQ(report->ref_to_test.mse_d1, 0.5);
  EXPECT_DOUBLE_EQ(report->ref_to_test.rms, std::sqrt(0.5));
  EXPECT_DOUBLE_EQ(report->ref_to_test.hausdorff, 1.0);
  EXPECT_DOUBLE_EQ(report->test_to_ref.mse_d1, 5.0 / 3.0);
  EXPECT_DOUBLE_EQ(report->test_to_ref.rms, std::sqrt(5.0 / 3.0));
  EXPECT_DOUBLE_EQ(report->test_to_ref.hausdorff, 2.0);
  EXPECT_DOUBLE_EQ(report->rms_max, std::sqrt(5.0 / 3.0));
  EXPECT_DOUBLE_EQ(report->hausdorff, 2.0);
  EXPECT_DOUBLE_EQ(report->psnr_paper, 20.0 * std::log10(2.0 / std::sqrt(5.0 / 3.0)));
  EXPECT_DOUBLE_EQ(report->d1_mse, 5.0 / 3.0);
  EXPECT_NEAR(report->d1_psnr, 10.0 * std::log10(7.2), 1e-12);
  EXPECT_FALSE(report->has_d2);
  EXPECT_FALSE(report->has_normal_error);
}

// The same clouds with REF normals n0 = (0,0,1), n1 = (0.6,0,0.8).
//   TEST→REF (REF's normals): B0−A0 = (0,0,1)·n0 → 1; B1 → 0; B2−A1 = (2,0,0)·n1 = 1.2 → 1.44
//     MSE = 2.44 / 3.
//   REF→TEST (normals moved to TEST as pc_error does): B0 takes n0, B1 takes n1;
//     A0−B0 = (0,0,−1)·n0 → 1; A1 → 0; MSE = 1/2.
// D2 MSE = max = 2.44/3; PSNR = 10·log10(3·4 / (2.44/3)).
TEST(Evaluate, HandComputedPointToPlane) {
  const PointCloud ref = cloud({{0, 0, 0}, {2, 0, 0}}, {{0, 0, 1}, {0.6f, 0, 0.8f}});
  const PointCloud test = cloud({{0, 0, 1}, {2, 0, 0}, {4, 0, 0}});
  const auto report = evaluate(ref, test);
  ASSERT_TRUE(report.ok()) << report.status().message();
  ASSERT_TRUE(report->has_d2);
  const double n1x = static_cast<double>(0.6f);  // the stored float, not 0.6
  EXPECT_DOUBLE_EQ(report->test_to_ref.mse_d2, (1.0 + 4.0 * n1x * n1x) / 3.0);
  EXPECT_DOUBLE_EQ(report->ref_to_test.mse_d2, 0.5);
  EXPECT_DOUBLE_EQ(report->d2_mse, (1.0 + 4.0 * n1x * n1x) / 3.0);
  EXPECT_NEAR(report->d2_psnr, 10.0 * std::log10(12.0 / ((1.0 + 4.0 * n1x * n1x) / 3.0)), 1e-12);
  // D1 does not depend on normals.
  EXPECT_DOUBLE_EQ(report->d1_mse, 5.0 / 3.0);
}

// A TEST point equidistant from two REF points with different normals: the point-to-plane
// error is the mean over the pair, as pc_error's default --averageNormals does.
//   REF A0 = (−1,0,0) n = (0,0,1), A1 = (1,0,0) n = (1,0,0); TEST B = (0,0,0.5).
//   TEST→REF: ((1,0,0.5)·(0,0,1))² = 0.25, ((−1,0,0.5)·(1,0,0))² = 1 → mean 0.625.
//   REF→TEST: B's normal is the mean of A0's and A1's, (0.5,0,0.5), not renormalised;
//     A0: ((−1,0,−0.5)·(0.5,0,0.5))² = 0.5625, A1: ((1,0,−0.5)·(0.5,0,0.5))² = 0.0625 → 0.3125.
TEST(Evaluate, EquidistantNeighboursAreAveraged) {
  const PointCloud ref = cloud({{-1, 0, 0}, {1, 0, 0}}, {{0, 0, 1}, {1, 0, 0}});
  const PointCloud test = cloud({{0, 0, 0.5f}});
  const auto report = evaluate(ref, test);
  ASSERT_TRUE(report.ok()) << report.status().message();
  EXPECT_DOUBLE_EQ(report->test_to_ref.mse_d1, 1.25);
  EXPECT_DOUBLE_EQ(report->ref_to_test.mse_d1, 1.25);
  EXPECT_DOUBLE_EQ(report->test_to_ref.mse_d2, 0.625);
  EXPECT_DOUBLE_EQ(report->ref_to_test.mse_d2, 0.3125);
  EXPECT_DOUBLE_EQ(report->d2_mse, 0.625);
}

// pc_error calls squared distances equal when they differ by less than 1e-8 absolute, which at
// this scale (spacing 1e-5) would average in a neighbour twice as far away. sspc does not.
//   REF A0 = (0,0,0) n = (0,0,1), A1 = (1e-5,0,0) n = (1,0,0); TEST B = (4e-6,0,0).
//   Nearest is A0 alone: D2 = ((4e-6,0,0)·(0,0,1))² = 0.
TEST(Evaluate, TiesAreRelativeNotAbsolute) {
  const PointCloud ref = cloud({{0, 0, 0}, {1e-5f, 0, 0}}, {{0, 0, 1}, {1, 0, 0}});
  const PointCloud test = cloud({{4e-6f, 0, 0}});
  const auto report = evaluate(ref, test);
  ASSERT_TRUE(report.ok()) << report.status().message();
  EXPECT_EQ(report->test_to_ref.mse_d2, 0.0);
  const double x = static_cast<double>(4e-6f);
  EXPECT_DOUBLE_EQ(report->test_to_ref.mse_d1, x * x);
}

TEST(Evaluate, GivenPeak) {
  const PointCloud ref = cloud({{0, 0, 0}, {2, 0, 0}});
  const PointCloud test = cloud({{0, 0, 1}, {2, 0, 0}, {4, 0, 0}});
  EvalOptions options;
  options.peak = 1023;
  const auto report = evaluate(ref, test, options);
  ASSERT_TRUE(report.ok());
  EXPECT_DOUBLE_EQ(report->peak, 1023.0);
  EXPECT_NEAR(report->d1_psnr, 10.0 * std::log10(3.0 * 1023.0 * 1023.0 / (5.0 / 3.0)), 1e-9);
  // The paper's PSNR always uses REF's diagonal.
  EXPECT_DOUBLE_EQ(report->psnr_paper, 20.0 * std::log10(2.0 / std::sqrt(5.0 / 3.0)));
}

TEST(Evaluate, IdenticalCloudsHaveInfinitePsnr) {
  const PointCloud ref = synthetic::sphere(2000, 1.0);
  const auto report = evaluate(ref, ref);
  ASSERT_TRUE(report.ok());
  EXPECT_EQ(report->rms_max, 0.0);
  EXPECT_EQ(report->hausdorff, 0.0);
  EXPECT_TRUE(std::isinf(report->psnr_paper));
  EXPECT_TRUE(std::isinf(report->d1_psnr));
  EXPECT_TRUE(std::isinf(report->d2_psnr));
  ASSERT_TRUE(report->has_normal_error);
  EXPECT_EQ(report->normal_angle_mean_deg, 0.0);
  EXPECT_EQ(report->normal_angle_p95_deg, 0.0);
  EXPECT_EQ(report->normal_angle_points, 2000u);
}

// TEST normals at 0°, 90° and 180° (flipped) from REF's, one point each, plus 17 at 0°:
// mean = 270/20 = 13.5°, and the nearest-rank 95th percentile (the 19th of 20) is 90°.
TEST(Evaluate, NormalAngles) {
  PointCloud ref;
  PointCloud test;
  for (int i = 0; i < 20; ++i) {
    ref.positions.push_back({static_cast<float>(i), 0, 0});
    ref.normals.push_back({0, 0, 1});
    test.positions.push_back({static_cast<float>(i), 0, 0});
    test.normals.push_back({0, 0, 1});
  }
  test.normals[3] = {1, 0, 0};
  test.normals[7] = {0, 0, -1};
  const auto report = evaluate(ref, test);
  ASSERT_TRUE(report.ok());
  ASSERT_TRUE(report->has_normal_error);
  EXPECT_NEAR(report->normal_angle_mean_deg, 13.5, 1e-12);
  EXPECT_NEAR(report->normal_angle_p95_deg, 90.0, 1e-12);
}

TEST(Evaluate, RejectsBadInput) {
  const PointCloud good = cloud({{0, 0, 0}, {1, 0, 0}});
  EXPECT_EQ(evaluate(PointCloud{}, good).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(evaluate(good, PointCloud{}).status().code(), StatusCode::kInvalidArgument);
  const PointCloud nan = cloud({{0, std::numeric_limits<float>::quiet_NaN(), 0}});
  EXPECT_EQ(evaluate(good, nan).status().code(), StatusCode::kInvalidArgument);
  PointCloud mismatched = good;
  mismatched.normals = {{0, 0, 1}};  // one normal for two points
  EXPECT_FALSE(evaluate(mismatched, good).ok());
  for (double peak : {0.0, -1.0, std::numeric_limits<double>::infinity(),
                      std::numeric_limits<double>::quiet_NaN()}) {
    EvalOptions options;
    options.peak = peak;
    EXPECT_EQ(evaluate(good, good, options).status().code(), StatusCode::kInvalidArgument) << peak;
  }
  // All of REF at one point: no diagonal, so no default peak; a given one is fine.
  const PointCloud single = cloud({{1, 1, 1}, {1, 1, 1}});
  EXPECT_EQ(evaluate(single, good).status().code(), StatusCode::kInvalidArgument);
  EvalOptions options;
  options.peak = 1;
  EXPECT_TRUE(evaluate(single, good, options).ok());
}

TEST(Evaluate, SwappingCloudsSwapsDirections) {
  synthetic::Options noisy;
  noisy.seed = 7;
  noisy.noise = 0.01;
  const PointCloud a = synthetic::torus(3000, 1.0, 0.3);
  const PointCloud b = synthetic::torus(2000, 1.0, 0.3, noisy);
  const auto ab = evaluate(a, b);
  const auto ba = evaluate(b, a);
  ASSERT_TRUE(ab.ok() && ba.ok());
  EXPECT_EQ(ab->ref_to_test.mse_d1, ba->test_to_ref.mse_d1);
  EXPECT_EQ(ab->test_to_ref.mse_d1, ba->ref_to_test.mse_d1);
  EXPECT_EQ(ab->hausdorff, ba->hausdorff);
  EXPECT_EQ(ab->d1_mse, ba->d1_mse);
}

// Gaussian noise of sigma along the normal on a smooth dense surface: TEST→REF's MSE is close
// to sigma² (a little less: the nearest REF point is not the noise-free one).
TEST(Evaluate, NoiseOfKnownSigma) {
  const double sigma = 1e-3;
  synthetic::Options noisy;
  noisy.seed = 3;
  noisy.noise = sigma;
  const PointCloud ref = synthetic::plane(100000, 1.0);
  const PointCloud test = synthetic::plane(20000, 1.0, noisy);
  const auto report = evaluate(ref, test);
  ASSERT_TRUE(report.ok());
  // D2 TEST→REF projects on the plane's normal: the plane's normal error alone, ≈ sigma².
  EXPECT_NEAR(report->test_to_ref.mse_d2 / (sigma * sigma), 1.0, 0.05);
  EXPECT_GT(report->test_to_ref.mse_d1, report->test_to_ref.mse_d2);
}

TEST(Evaluate, SameResultOnOneAndTwoThreads) {
  synthetic::Options noisy;
  noisy.seed = 11;
  noisy.noise = 0.002;
  const PointCloud ref = synthetic::bumps(40000, 1.0, 4, 0.1);
  const PointCloud test = synthetic::bumps(30000, 1.0, 4, 0.1, noisy);
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
  EXPECT_EQ(one.d1_mse, two.d1_mse);
  EXPECT_EQ(one.d2_mse, two.d2_mse);
  EXPECT_EQ(one.ref_to_test.mse_d2, two.ref_to_test.mse_d2);
  EXPECT_EQ(one.hausdorff, two.hausdorff);
  EXPECT_EQ(one.normal_angle_mean_deg, two.normal_angle_mean_deg);
  EXPECT_EQ(one.normal_angle_p95_deg, two.normal_angle_p95_deg);
}

TEST(Metrics, PsnrFormulas) {
  EXPECT_DOUBLE_EQ(paper_psnr(10.0, 0.01), 60.0);
  EXPECT_TRUE(std::isinf(paper_psnr(10.0, 0.0)));
  EXPECT_DOUBLE_EQ(mpeg_geometry_psnr(3.0, 10.0), 20.0);  // 10·log10(300/3)
  EXPECT_TRUE(std::isinf(mpeg_geometry_psnr(0.0, 1.0)));
  EXPECT_DOUBLE_EQ(bits_per_point(1000, 8000), 1.0);
  EXPECT_EQ(bits_per_point(1000, 0), 0.0);
}

}  // namespace
}  // namespace sspc
