// Synthetic surfaces: a seed names one cloud byte for byte, points lie on the analytic surface,
// and the normals are the surface's unit normals.
#include "sspc/synthetic.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <functional>
#include <numbers>
#include <vector>

namespace sspc::synthetic {
namespace {

bool same_bytes(const std::vector<Vec3f>& a, const std::vector<Vec3f>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(Vec3f)) == 0;
}

using Generator = std::function<PointCloud(const Options&)>;

struct Case {
  const char* name;
  Generator make;
};

std::vector<Case> cases() {
  return {
      {"plane", [](const Options& o) { return plane(2000, 4.0, o); }},
      {"sphere", [](const Options& o) { return sphere(2000, 1.5, o); }},
      {"torus", [](const Options& o) { return torus(2000, 2.0, 0.5, o); }},
      {"bumps", [](const Options& o) { return bumps(2000, 4.0, 4, 0.3, o); }},
  };
}

TEST(Synthetic, SameSeedGivesIdenticalCloudsAndOtherSeedsDiffer) {
  for (const auto& c : cases()) {
    Options o;
    o.seed = 42;
    o.noise = 0.01;
    const PointCloud a = c.make(o);
    const PointCloud b = c.make(o);
    ASSERT_EQ(a.size(), 2000u) << c.name;
    EXPECT_TRUE(same_bytes(a.positions, b.positions)) << c.name;
    EXPECT_TRUE(same_bytes(a.normals, b.normals)) << c.name;
    o.seed = 43;
    const PointCloud other = c.make(o);
    EXPECT_FALSE(same_bytes(a.positions, other.positions)) << c.name;
  }
}

TEST(Synthetic, NormalsAreOptional) {
  for (const auto& c : cases()) {
    Options o;
    o.normals = false;
    const PointCloud cloud = c.make(o);
    EXPECT_EQ(cloud.size(), 2000u) << c.name;
    EXPECT_FALSE(cloud.has_normals()) << c.name;
    EXPECT_TRUE(cloud.validate().ok()) << c.name;
  }
}

TEST(Synthetic, PlanePointsLieOnThePlane) {
  const PointCloud cloud = plane(3000, 4.0);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Vec3f& p = cloud.positions[i];
    ASSERT_EQ(p.z(), 0.0f);
    ASSERT_LE(std::abs(p.x()), 2.0f);
    ASSERT_LE(std::abs(p.y()), 2.0f);
    ASSERT_EQ(cloud.normals[i], Vec3f::UnitZ());
  }
}

TEST(Synthetic, SpherePointsLieOnTheSphereWithOutwardNormals) {
  const PointCloud cloud = sphere(3000, 1.5);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Vec3d p = cloud.positions[i].cast<double>();
    const Vec3d n = cloud.normals[i].cast<double>();
    ASSERT_NEAR(p.norm(), 1.5, 1e-6);
    ASSERT_NEAR(n.norm(), 1.0, 1e-6);
    ASSERT_GT(n.dot(p.normalized()), 1.0 - 1e-6);
  }
}

TEST(Synthetic, TorusPointsSatisfyTheImplicitEquation) {
  const double big = 2.0, small = 0.5;
  const PointCloud cloud = torus(3000, big, small);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Vec3d p = cloud.positions[i].cast<double>();
    const double ring = std::hypot(p.x(), p.y());
    // (√(x²+y²) − R)² + z² = r²
    ASSERT_NEAR((ring - big) * (ring - big) + p.z() * p.z(), small * small, 1e-5);
    // The outward normal points from the tube's centre circle to the point.
    const Vec3d centre(big * p.x() / ring, big * p.y() / ring, 0.0);
    ASSERT_GT(cloud.normals[i].cast<double>().dot((p - centre).normalized()), 1.0 - 1e-5);
  }
}

TEST(Synthetic, TorusIsAreaUniformOuterRimDenserThanInner) {
  // The outer half (cos v > 0) has area share (π R + 2 r) / (2 π R) ≈ 0.58 for R = 2, r = 0.5.
  const PointCloud cloud = torus(20000, 2.0, 0.5);
  std::size_t outer = 0;
  for (const Vec3f& p : cloud.positions) outer += std::hypot(p.x(), p.y()) > 2.0f ? 1u : 0u;
  const double share = static_cast<double>(outer) / static_cast<double>(cloud.size());
  constexpr double pi = std::numbers::pi;
  EXPECT_NEAR(share, (pi * 2.0 + 1.0) / (2 * pi * 2.0), 0.015);
}

TEST(Synthetic, BumpsFollowTheHeightFieldAndRepeat) {
  const double size = 4.0, height = 0.3;
  const int per_side = 4;
  const PointCloud cloud = bumps(5000, size, per_side, height);
  const double pitch = size / per_side, sigma = pitch / 6;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Vec3d p = cloud.positions[i].cast<double>();
    ASSERT_LE(std::abs(p.x()), size / 2);
    ASSERT_LE(std::abs(p.y()), size / 2);
    // Height and normal from all bumps (the generator keeps only the 3×3 nearest: e^-40 less).
    double z = 0, gx = 0, gy = 0;
    for (int j = 0; j < per_side; ++j) {
      for (int k = 0; k < per_side; ++k) {
        const double dx = p.x() - (-size / 2 + (k + 0.5) * pitch);
        const double dy = p.y() - (-size / 2 + (j + 0.5) * pitch);
        const double g = height * std::exp(-(dx * dx + dy * dy) / (2 * sigma * sigma));
        z += g;
        gx -= g * dx / (sigma * sigma);
        gy -= g * dy / (sigma * sigma);
      }
    }
    ASSERT_NEAR(p.z(), z, 1e-6);
    const Vec3d n = Vec3d(-gx, -gy, 1).normalized();
    ASSERT_GT(cloud.normals[i].cast<double>().dot(n), 1.0 - 1e-6);
  }
}

TEST(Synthetic, NoiseMovesPointsAlongTheNormalWithTheRequestedSigma) {
  Options o;
  o.noise = 0.01;
  const PointCloud cloud = sphere(20000, 1.0, o);
  double sum2 = 0;
  for (const Vec3f& p : cloud.positions) {
    const double e = p.cast<double>().norm() - 1.0;
    sum2 += e * e;
  }
  EXPECT_NEAR(std::sqrt(sum2 / static_cast<double>(cloud.size())), 0.01, 0.0005);
}

TEST(Synthetic, RngIsSplitMix64WithUnitGaussians) {
  // SplitMix64's published first output for seed 0.
  Rng zero(0);
  EXPECT_EQ(zero.next_u64(), 0xE220A8397B1DCDAFULL);
  Rng rng(7);
  double sum = 0, sum2 = 0;
  const int n = 100000;
  for (int i = 0; i < n; ++i) {
    const double g = rng.gaussian();
    sum += g;
    sum2 += g * g;
  }
  EXPECT_NEAR(sum / n, 0.0, 0.02);
  EXPECT_NEAR(sum2 / n, 1.0, 0.02);
  for (int i = 0; i < 1000; ++i) {
    const double u = rng.uniform();
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
  }
}

}  // namespace
}  // namespace sspc::synthetic
