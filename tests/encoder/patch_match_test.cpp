// The code book's acceptance rules (encoder/patch_match.hpp), each shown to accept the case just
// inside it and reject the case just outside, with the other rules held satisfied. The drift
// rule is not isolated here: on a smooth asymmetric patch ICP slides at most about 0.2 spacings
// (a code word whose origin sat one spacing along the same surface landed 0.17 spacings from
// the patch's centre), so the rules below decide before the drift can.
#include "encoder/patch_match.hpp"

#include <cmath>
#include <cstdint>
#include <numeric>
#include <vector>

#include <gtest/gtest.h>

namespace sspc::codec {
namespace {

constexpr float kSpacing = 0.05f;

// An asymmetric height field (no rotation or slide maps it onto itself), sampled on the grid of
// kSpacing over the unit disc; `bump(i, j)` adds a height to sample (i, j).
struct Surface {
  std::vector<Vec3f> points;
  std::vector<Vec3f> normals;
};

template <typename Bump>
Surface height_field(Bump bump) {
  Surface s;
  for (int i = -20; i <= 20; ++i) {
    for (int j = -20; j <= 20; ++j) {
      const float x = static_cast<float>(i) * kSpacing, y = static_cast<float>(j) * kSpacing;
      if (x * x + y * y > 1) continue;
      const float z = 0.3f * x * x - 0.2f * y * y + 0.25f * x * x * x + bump(i, j);
      const Vec3f g(0.6f * x + 0.75f * x * x, -0.4f * y, -1);
      s.points.emplace_back(x, y, z);
      s.normals.push_back(-g.normalized());
    }
  }
  return s;
}
Surface height_field() {
  return height_field([](int, int) { return 0.0f; });
}

// The world pose of the patch: the code word's frame is the patch's own frame moved here.
RigidTransform world_from_local() {
  RigidTransform t;
  t.rotation = Eigen::AngleAxisf(0.9f, Vec3f(0.2f, 0.7f, -0.4f).normalized()).toRotationMatrix();
  t.translation = Vec3f(3.0f, -1.0f, 2.0f);
  return t;
}

CodebookOptions options(float tau, float coverage_radius) {
  CodebookOptions o;
  o.patch_radius = 1.0f;
  o.coverage_radius = coverage_radius;
  o.spacing = kSpacing;
  o.tau = tau;
  return o;
}

// The patch (the undisturbed height field placed in the world) tested against `codeword`.
Match match(const Surface& codeword, float tau, float coverage_radius = 0.7f) {
  const Surface local = height_field();
  const RigidTransform world = world_from_local();
  PointCloud cloud;
  for (const Vec3f& p : local.points) cloud.positions.push_back(world.apply(p));
  const KdTree3 tree(cloud.positions);
  std::vector<std::uint32_t> idx(cloud.positions.size());
  std::iota(idx.begin(), idx.end(), 0u);
  const CodewordSurface surface(codeword.points, codeword.normals);
  return try_match(cloud, tree, idx, world.translation, world, RigidTransform(), surface,
                   options(tau, coverage_radius));
}

// Appends `count` copies of points spread over the disc of radius 0.5: more code-word points in
// the region without moving any nearest-point distance.
void add_copies(Surface& s, std::size_t count) {
  const std::size_t n = s.points.size();
  std::size_t added = 0;
  for (std::size_t i = 0; added < count && i < n; ++i) {
    if (s.points[i].head<2>().norm() > 0.5f) continue;
    s.points.push_back(s.points[i]);
    s.normals.push_back(s.normals[i]);
    ++added;
  }
  ASSERT_EQ(added, count);
}

TEST(PatchMatch, AnExactCopyIsAcceptedWithItsPose) {
  const Match m = match(height_field(), 0.25f);
  ASSERT_TRUE(m.accepted);
  const RigidTransform world = world_from_local();
  EXPECT_LT((m.world_from_codeword.translation - world.translation).norm(), 1e-3f);
  EXPECT_LT((m.world_from_codeword.rotation - world.rotation).norm(), 1e-3f);
}

// A checkerboard of ±δ along the normal cannot be aligned away: the RMS is δ.
TEST(PatchMatch, TheRmsErrorMustNotExceedTau) {
  const float delta = 0.6f * kSpacing;
  const Surface rough = height_field([&](int i, int j) { return ((i + j) & 1) ? delta : -delta; });
  EXPECT_TRUE(match(rough, 0.7f).accepted);
  EXPECT_FALSE(match(rough, 0.5f).accepted);
}

// A code word with a hole in the region: points of the patch then lie farther than 2.5 spacings
// from any code-word point. Copies elsewhere keep the point count, and τ is loose, so that only
// the hole rule can reject.
Surface with_hole(float hole_radius) {
  Surface s = height_field();
  Surface kept;
  for (std::size_t i = 0; i < s.points.size(); ++i) {
    if ((s.points[i].head<2>() - Eigen::Vector2f(-0.3f, 0.2f)).norm() < hole_radius) continue;
    kept.points.push_back(s.points[i]);
    kept.normals.push_back(s.normals[i]);
  }
  add_copies(kept, s.points.size() - kept.points.size());
  return kept;
}

TEST(PatchMatch, AHoleInTheCodewordRejectsIt) {
  // A hole of 3 spacings leaves about 1 patch point (0.2%) beyond 2.5 spacings; 5.5 leave ~28 (5%).
  EXPECT_TRUE(match(with_hole(3.0f * kSpacing), 3.0f).accepted);
  EXPECT_FALSE(match(with_hole(5.5f * kSpacing), 3.0f).accepted);
}

// Code-word points past the patch's edge (where the scan has none) are holes the other way.
TEST(PatchMatch, CodewordPointsOffTheScannedSurfaceRejectIt) {
  auto with_flap = [](float height) {
    Surface s = height_field();
    const std::size_t n = s.points.size();
    // Lift a band of the region by `height`: the points move, so the count is unchanged.
    for (std::size_t i = 0; i < n; ++i) {
      if (s.points[i].x() > 0.3f && s.points[i].x() < 0.45f && std::abs(s.points[i].y()) < 0.3f) {
        s.points[i].z() += height;
      }
    }
    return s;
  };
  // Lifted by 2 spacings the band is still near the patch's surface; by 4 it is off it (6% of
  // the region beyond 2.5 spacings, while its RMS, about 1 spacing, passes τ = 3).
  EXPECT_TRUE(match(with_flap(2.0f * kSpacing), 3.0f).accepted);
  EXPECT_FALSE(match(with_flap(4.0f * kSpacing), 3.0f).accepted);
}

// The code word must decode about as many points as the patch has: within 10% either way.
TEST(PatchMatch, TheCodewordsDensityMustBeWithinTenPercent) {
  // The region (coverage radius 0.7) holds about 615 patch points.
  Surface denser = height_field();
  add_copies(denser, 40);  // +6.5%
  EXPECT_TRUE(match(denser, 0.25f).accepted);
  Surface densest = height_field();
  add_copies(densest, 80);  // +13%
  EXPECT_FALSE(match(densest, 0.25f).accepted);
}

}  // namespace
}  // namespace sspc::codec
