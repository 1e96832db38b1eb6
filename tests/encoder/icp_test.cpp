// Point-to-plane ICP recovers a known rigid motion of a curved patch.
#include "encoder/icp.hpp"

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
  const CodewordSurface surface(target.points, target.normals);
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

}  // namespace
}  // namespace sspc::codec
