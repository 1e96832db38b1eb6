// Point-to-plane ICP: it recovers a known rigid motion of a curved patch, and its anchor keeps
// a flat patch's origin where it was put, where nothing else constrains the slide.
#include "codec/icp.hpp"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

namespace sspc::codec {
namespace {

// A grid-sampled height field z = f(x, y) over the unit disc, with analytic normals.
struct Patch {
  std::vector<Vec3f> points;
  std::vector<Vec3f> normals;
};

Patch height_field(float curvature, float step) {
  Patch p;
  for (float x = -1; x <= 1; x += step) {
    for (float y = -1; y <= 1; y += step) {
      if (x * x + y * y > 1) continue;
      // Asymmetric (x³ term) so that no rotation or slide maps the patch onto itself.
      const float z = curvature * (0.3f * x * x - 0.2f * y * y + 0.25f * x * x * x);
      const Vec3f g(curvature * (0.6f * x + 0.75f * x * x), curvature * (-0.4f * y), -1);
      p.points.emplace_back(x, y, z);
      p.normals.push_back(-g.normalized());
    }
  }
  return p;
}

RigidTransform small_motion() {
  RigidTransform t;
  t.rotation = Eigen::AngleAxisf(0.08f, Vec3f(0.3f, -0.5f, 0.8f).normalized()).toRotationMatrix();
  t.translation = Vec3f(0.03f, -0.02f, 0.015f);
  return t;
}

TEST(Icp, RecoversAKnownMotionOfACurvedPatch) {
  const Patch target = height_field(1.0f, 0.05f);
  const CodewordSurface surface(target.points, target.normals, 0.075f);
  const RigidTransform source_from_target = small_motion();
  std::vector<Vec3f> source;
  for (const Vec3f& p : target.points) source.push_back(source_from_target.apply(p));

  IcpOptions options;
  options.max_iterations = 30;
  options.max_pair_distance = 0.3f;
  const IcpResult r = align_point_to_plane(source, surface, options);
  ASSERT_TRUE(is_rotation(r.target_from_source.rotation));
  const RigidTransform identity = r.target_from_source * source_from_target;
  float worst = 0;
  for (const Vec3f& p : target.points) worst = std::max(worst, (identity.apply(p) - p).norm());
  EXPECT_LT(worst, 2e-3f);
  EXPECT_LT(r.rms, 1e-3f);
}

TEST(Icp, AnchorKeepsAFlatPatchFromSliding) {
  // Two samplings of one plane, the source's grid off the target's: on a plane any tangential
  // slide fits, and the point-to-point term pulls the source's samples onto the target's (a
  // slide of (−0.02, −0.015)). The anchor must win.
  const Patch target = height_field(0.0f, 0.05f);
  const CodewordSurface surface(target.points, target.normals, 0.075f);
  std::vector<Vec3f> source;
  const Vec3f offset(0.02f, 0.015f, 0.01f);  // off the grid, and off the plane by 0.01
  for (const Vec3f& p : target.points) source.push_back(p + offset);

  IcpOptions options;
  options.max_iterations = 30;
  options.point_to_point_weight = 1.0f;
  options.anchor_weight = 20.0f;
  options.anchor = Vec3f(0, 0, 0.01f);  // not a sample: the centre of the source's samples
  const IcpResult r = align_point_to_plane(source, surface, options);
  const Vec3f landed = r.target_from_source.apply(options.anchor);
  EXPECT_LT(std::hypot(landed.x(), landed.y()), 2e-3f);
  EXPECT_NEAR(landed.z(), 0.0f, 1e-3f);  // the plane's own constraint still applies

  options.anchor_weight = 0;
  const IcpResult free = align_point_to_plane(source, surface, options);
  const Vec3f slid = free.target_from_source.apply(options.anchor);
  EXPECT_GT(std::hypot(slid.x(), slid.y()), 5e-3f);  // without it, the samples pull it away
}

}  // namespace
}  // namespace sspc::codec
