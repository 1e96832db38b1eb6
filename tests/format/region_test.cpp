// The region rule's two forms (format/region_decoder.hpp): claims() one point at a time, as the
// writer's trimming asks, and claims_all() a code word at a time, as the decoder asks. Every
// decode form must keep the same points, so the two must agree to the last bit, ties included.
#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

#include "format/region_decoder.hpp"
#include "sspc/synthetic.hpp"

// A namespace of its own: the suite compiles as one unity file with container_test.cpp.
namespace sspc::codec::region_test {
namespace {

std::vector<std::uint32_t> claims_all(const RegionTest& region, const std::vector<Vec3f>& points) {
  std::vector<float> norm2;
  for (const Vec3f& q : points) norm2.push_back(q.squaredNorm());
  std::vector<std::uint32_t> keep;
  region.claims_all(points.data(), norm2.data(), points.size(), keep);
  return keep;
}

// A point on the bisector of two centres is kept by the lower patch index only; a point nearer
// the other centre by neither form, one nearer its own by both.
TEST(Region, TiesGoToTheLowerIndexInBothForms) {
  const std::vector<Vec3f> points = {Vec3f(1, 0.5f, -0.25f), Vec3f(1.5f, 0, 0), Vec3f(0.5f, 0, 0)};
  for (const std::uint32_t k : {3u, 7u}) {
    RegionTest region;
    const std::vector<NeighbourInstance> neighbours = {{5, Vec3f(2, 0, 0)}};
    region.reset(k, Eigen::Matrix3f::Identity(), Vec3f::Zero(), neighbours);
    const auto keep = claims_all(region, points);
    ASSERT_EQ(keep.size(), 3u);
    EXPECT_EQ(keep[0] != 0, k < 5) << k;
    EXPECT_EQ(region.claims(points[0], points[0].squaredNorm()), k < 5) << k;
    EXPECT_EQ(keep[1], 0u);
    EXPECT_FALSE(region.claims(points[1], points[1].squaredNorm()));
    EXPECT_NE(keep[2], 0u);
    EXPECT_TRUE(region.claims(points[2], points[2].squaredNorm()));
  }
}

// Random rotations, centres and neighbourhoods (some neighbours far beyond reach, some at the
// same place): the two forms keep the same points, and both keep some and drop some.
TEST(Region, OneCodewordAtATimeKeepsWhatOnePointAtATimeKeeps) {
  synthetic::Rng rng(11);
  const auto uniform = [&](double lo, double hi) { return static_cast<float>(rng.uniform(lo, hi)); };
  std::size_t kept = 0, dropped = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const Eigen::Quaternionf turn = Eigen::Quaternionf::UnitRandom();
    const Eigen::Matrix3f rotation = turn.toRotationMatrix();
    const Vec3f centre(uniform(-5, 5), uniform(-5, 5), uniform(-5, 5));
    std::vector<NeighbourInstance> neighbours;
    const int count = static_cast<int>(rng.next_u64() % 24);
    for (int j = 0; j < count; ++j) {
      const float reach = j % 7 == 6 ? 8.0f : 2.0f;
      neighbours.push_back({static_cast<std::uint32_t>(rng.next_u64() % 50),
                            centre + Vec3f(uniform(-reach, reach), uniform(-reach, reach), uniform(-reach, reach))});
    }
    if (count > 2) neighbours.push_back({neighbours[0].index + 1, neighbours[0].centre});
    std::vector<Vec3f> points;
    const int n = static_cast<int>(rng.next_u64() % 300);
    for (int i = 0; i < n; ++i) points.emplace_back(uniform(-1.5, 1.5), uniform(-1.5, 1.5), uniform(-0.3, 0.3));
    RegionTest region;
    const auto k = static_cast<std::uint32_t>(rng.next_u64() % 50);
    region.reset(k, rotation, centre, neighbours);
    const auto keep = claims_all(region, points);
    ASSERT_EQ(keep.size(), points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
      const bool one = region.claims(points[i], points[i].squaredNorm());
      ASSERT_EQ(keep[i] != 0, one) << "trial " << trial << " point " << i;
      (one ? kept : dropped) += 1;
    }
  }
  EXPECT_GT(kept, 1000u);
  EXPECT_GT(dropped, 1000u);
}

}  // namespace
}  // namespace sspc::codec::region_test
