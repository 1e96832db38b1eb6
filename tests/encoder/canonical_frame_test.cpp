#include "encoder/canonical_frame.hpp"

#include <gtest/gtest.h>

#include <numeric>
#include <vector>

#include "sspc/synthetic.hpp"

namespace sspc {
namespace {

// A curved, asymmetric patch z = 0.3x² + 0.1xy + 0.2y³ over the unit disc, with exact normals.
void make_patch(std::vector<Vec3f>& positions, std::vector<Vec3f>& normals) {
  synthetic::Rng rng(42);
  while (positions.size() < 400) {
    const double x = rng.uniform(-1, 1), y = rng.uniform(-1, 1);
    if (x * x + y * y > 1) continue;
    const double z = 0.3 * x * x + 0.1 * x * y + 0.2 * y * y * y;
    const Vec3d n = Vec3d(-(0.6 * x + 0.1 * y), -(0.1 * x + 0.6 * y * y), 1.0).normalized();
    positions.emplace_back(Vec3d(x, y, z).cast<float>());
    normals.emplace_back(n.cast<float>());
  }
}

std::vector<std::uint32_t> all_indices(std::size_t n) {
  std::vector<std::uint32_t> idx(n);
  std::iota(idx.begin(), idx.end(), 0u);
  return idx;
}

TEST(CanonicalFrame, IsARotationAndMapsTheMeanNormalToZ) {
  std::vector<Vec3f> p, n;
  make_patch(p, n);
  const auto idx = all_indices(p.size());
  const CanonicalFrame frame = canonical_frame(p, n, idx);
  const Eigen::Matrix3f r = frame.world_from_canonical.rotation;
  EXPECT_TRUE(is_rotation(r));
  Vec3f mean = Vec3f::Zero();
  for (const Vec3f& v : n) mean += v;
  const Vec3f canonical_mean = (r.transpose() * mean.normalized());
  EXPECT_NEAR(canonical_mean.z(), 1.0f, 1e-5f);
  // The origin is the centroid.
  Vec3f centroid = Vec3f::Zero();
  for (const Vec3f& v : p) centroid += v;
  centroid /= static_cast<float>(p.size());
  EXPECT_LT((frame.world_from_canonical.translation - centroid).norm(), 1e-5f);
}

TEST(CanonicalFrame, IsInvariantToRigidMotion) {
  std::vector<Vec3f> p, n;
  make_patch(p, n);
  const auto idx = all_indices(p.size());
  const CanonicalFrame a = canonical_frame(p, n, idx);

  RigidTransform motion;
  motion.rotation = Eigen::AngleAxisf(1.1f, Vec3f(0.3f, -0.5f, 0.8f).normalized()).toRotationMatrix();
  motion.translation = Vec3f(10.0f, -3.0f, 7.5f);
  std::vector<Vec3f> q(p.size()), m(n.size());
  for (std::size_t i = 0; i < p.size(); ++i) {
    q[i] = motion.apply(p[i]);
    m[i] = motion.apply_vector(n[i]);
  }
  const CanonicalFrame b = canonical_frame(q, m, idx);
  EXPECT_GT(a.azimuth_confidence, 0.05f);  // the patch has an azimuth to recover
  const RigidTransform ca = a.world_from_canonical.inverse();
  const RigidTransform cb = b.world_from_canonical.inverse();
  float worst = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    worst = std::max(worst, (ca.apply(p[i]) - cb.apply(q[i])).norm());
  }
  EXPECT_LT(worst, 1e-4f);
}

TEST(CanonicalFrame, FlatPatchHasNoAzimuthConfidence) {
  const PointCloud plane = synthetic::plane(300, 1.0);
  const auto idx = all_indices(plane.size());
  const CanonicalFrame frame = canonical_frame(plane.positions, plane.normals, idx);
  EXPECT_TRUE(is_rotation(frame.world_from_canonical.rotation));
  EXPECT_EQ(frame.azimuth_confidence, 0.0f);
}

TEST(CanonicalFrame, EmptyPatchIsIdentity) {
  const CanonicalFrame frame = canonical_frame({}, {}, {});
  EXPECT_TRUE(frame.world_from_canonical.rotation.isIdentity());
  EXPECT_TRUE(frame.world_from_canonical.translation.isZero());
}

}  // namespace
}  // namespace sspc
