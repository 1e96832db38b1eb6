// The quantisers of docs/FORMAT.md: error bounds, total decoders, and the measurement behind
// the default rotation_bits.
#include "format/quantise.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "container_test_models.hpp"
#include "geometry/rigid_transform.hpp"

namespace sspc::codec {
namespace {

TEST(QuantiseTest, PositionWithinHalfStep) {
  test::TestRng rng(1);
  const float radius = 3.5f;
  for (int bits : {4, 12, 16}) {
    const float step = position_step(radius, bits);
    for (int i = 0; i < 20000; ++i) {
      const float x = rng.range(-radius, radius);
      const std::uint32_t v = quantise_coordinate(x, step, bits);
      ASSERT_LT(v, 1u << bits);
      EXPECT_LE(std::abs(dequantise_coordinate(v, step, bits) - x), step * 0.5f * 1.0001f)
          << "bits " << bits << " x " << x;
    }
    // Outside the range clamps to the end cells instead of wrapping.
    EXPECT_EQ(quantise_coordinate(10 * radius, step, bits), (1u << bits) - 1);
    EXPECT_EQ(quantise_coordinate(-10 * radius, step, bits), 0u);
  }
}

// The cell is floor(x / step) clamped, exactly (the writer's files depend on it): on grid
// points, just off them either side, far outside the range, and where x / step is not finite.
TEST(QuantiseTest, PositionCellIsTheFloorOfTheQuotient) {
  const auto reference = [](float x, float step, int bits) {
    const double half = static_cast<double>(1u << (bits - 1));
    double cell = std::floor(static_cast<double>(x) / static_cast<double>(step));
    if (!std::isfinite(cell)) cell = 0;
    return static_cast<std::uint32_t>(std::clamp(cell, -half, half - 1) + half);
  };
  test::TestRng rng(7);
  for (int bits : {4, 7, 16}) {
    for (const float step : {0.1f, 0.37f, 1.0f, 3e-6f}) {
      const float span = step * static_cast<float>(1u << bits);
      std::vector<float> xs = {0.0f, -0.0f, step, -step, 3 * step, -3 * step, 1e30f, -1e30f, span, -span,
                               std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity(),
                               std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::denorm_min(),
                               -std::numeric_limits<float>::denorm_min()};
      for (int k = -40; k <= 40; ++k) {
        const float on = static_cast<float>(k) * step;
        xs.insert(xs.end(), {on, std::nextafter(on, -1e30f), std::nextafter(on, 1e30f)});
      }
      for (int i = 0; i < 2000; ++i) xs.push_back(rng.range(-span, span));
      for (const float x : xs) {
        ASSERT_EQ(quantise_coordinate(x, step, bits), reference(x, step, bits)) << "x " << x << " step " << step;
      }
    }
  }
  EXPECT_EQ(quantise_coordinate(1.0f, 1e-40f, 8), reference(1.0f, 1e-40f, 8));  // an infinite quotient
}

TEST(QuantiseTest, NormalsOctahedral10BitsUnderAQuarterDegree) {
  test::TestRng rng(2);
  double worst = 0;
  for (int i = 0; i < 20000; ++i) {
    Vec3f n(rng.range(-1, 1), rng.range(-1, 1), rng.range(-1, 1));
    if (n.norm() < 1e-3f) continue;
    n.normalize();
    const auto uv = encode_normal(n, 10);
    const Vec3f d = decode_normal(uv[0], uv[1], 10);
    EXPECT_NEAR(d.norm(), 1.0f, 1e-5f);
    worst = std::max(worst, std::acos(std::min(1.0, static_cast<double>(n.dot(d)))));
  }
  EXPECT_LT(worst * 180.0 / M_PI, 0.25);
}

TEST(QuantiseTest, EveryStoredRotationDecodesToARotation) {
  test::TestRng rng(3);
  for (int bits : {4, 13, 20}) {
    for (int i = 0; i < 5000; ++i) {
      PackedRotation p;
      p.index = rng.below(4);
      for (auto& c : p.c) c = rng.below(1u << bits);
      const Eigen::Matrix3f r = decode_rotation(p, bits);
      EXPECT_TRUE(is_rotation(r, 1e-5f)) << r;
      EXPECT_GT(r.determinant(), 0.0f);
    }
  }
}

// Worst displacement of a point at patch_radius by the rotation's quantisation, over random
// rotations, against the 12-bit position step (FORMAT.md, "Why 13 bits").
double worst_rotation_error(int bits, float radius) {
  test::TestRng rng(4);
  double worst = 0;
  for (int i = 0; i < 20000; ++i) {
    const Eigen::Matrix3f r = rng.rotation();
    const Eigen::Matrix3f d = decode_rotation(encode_rotation(r, bits), bits);
    for (int a = 0; a < 3; ++a) {
      const Vec3f p = Vec3f::Unit(a) * radius;
      worst = std::max(worst, static_cast<double>((r * p - d * p).norm()));
    }
    const Vec3f diag = Vec3f::Ones().normalized() * radius;
    worst = std::max(worst, static_cast<double>((r * diag - d * diag).norm()));
  }
  return worst;
}

TEST(QuantiseTest, RotationErrorBelowPositionStep) {
  const float radius = 1.0f;
  const double step = position_step(radius, 12);
  const double e13 = worst_rotation_error(13, radius);
  const double e12 = worst_rotation_error(12, radius);
  std::printf(
      "rotation error at patch_radius: 12 bits %.3g, 13 bits %.3g; 12-bit position "
      "step %.3g\n",
      e12, e13, step);
  EXPECT_LT(e13, step);
}

TEST(QuantiseTest, TranslationGrid) {
  const Vec3f origin(-5, 2, 100);
  const float step = 1.0f / 64;
  test::TestRng rng(5);
  for (int i = 0; i < 1000; ++i) {
    const Vec3f t(rng.range(-5, 50), rng.range(2, 40), rng.range(100, 101));
    std::array<std::int32_t, 3> v{};
    ASSERT_TRUE(quantise_translation(t, origin, step, v));
    const Vec3f d = dequantise_translation(v, origin, step);
    EXPECT_LE((d - t).cwiseAbs().maxCoeff(), step * 0.5f + 1e-4f);
  }
  std::array<std::int32_t, 3> v{};
  EXPECT_FALSE(quantise_translation(Vec3f(1e9f, 0, 0), origin, step, v));
}

}  // namespace
}  // namespace sspc::codec
