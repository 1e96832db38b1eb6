// The SAH BVH over spheres reports exactly the spheres a brute-force test of every sphere finds,
// with the same entry and exit, for clustered and degenerate (coincident) sets.
#include "render/sphere_bvh.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <tuple>
#include <vector>

namespace sspc::render {
namespace {

using Visit = std::tuple<std::uint32_t, float, float>;

std::vector<Visit> brute_force(const std::vector<Sphere>& spheres, const Vec3f& o, const Vec3f& d, float t_max) {
  std::vector<Visit> out;
  for (std::uint32_t s = 0; s < spheres.size(); ++s) {
    const Vec3f oc = o - spheres[s].centre;
    const float b = oc.dot(d), c = oc.squaredNorm() - spheres[s].radius * spheres[s].radius;
    const float disc = b * b - c;
    if (disc < 0) continue;
    const float enter = -b - std::sqrt(disc), leave = -b + std::sqrt(disc);
    if (leave < 0 || enter > t_max) continue;
    out.emplace_back(s, std::max(enter, 0.0f), leave);
  }
  return out;
}

void expect_same_as_brute_force(const std::vector<Sphere>& spheres, std::mt19937& rng) {
  const SphereBvh bvh(spheres);
  std::uniform_real_distribution<float> u(-1.5f, 1.5f);
  for (int ray = 0; ray < 2000; ++ray) {
    const Vec3f o(u(rng), u(rng), u(rng));
    Vec3f d(u(rng), u(rng), u(rng));
    if (d.norm() < 1e-3f) continue;
    d.normalize();
    const float t_max = ray % 3 == 0 ? 0.7f : 1e30f;
    std::vector<Visit> got;
    bvh.intersect(o, d, t_max, [&](std::uint32_t s, float t0, float t1) { got.emplace_back(s, t0, t1); });
    std::sort(got.begin(), got.end());
    const std::vector<Visit> expected = brute_force(spheres, o, d, t_max);
    ASSERT_EQ(got, expected) << "ray " << ray;
  }
}

TEST(SphereBvh, FindsExactlyWhatABruteForceScanFinds) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> u(-1, 1), r(0.01f, 0.08f);
  std::vector<Sphere> spheres;
  // A surface-like cluster and some scattered spheres.
  for (int i = 0; i < 3000; ++i) {
    const float a = u(rng) * 3.14159f, b = u(rng) * 1.5f;
    spheres.push_back({Vec3f(std::cos(a) * std::cos(b), std::sin(a) * std::cos(b), std::sin(b)), r(rng)});
  }
  for (int i = 0; i < 300; ++i) spheres.push_back({Vec3f(u(rng), u(rng), u(rng)), r(rng)});
  expect_same_as_brute_force(spheres, rng);
}

TEST(SphereBvh, CoincidentAndEmptySets) {
  std::mt19937 rng(3);
  std::vector<Sphere> same(500, Sphere{Vec3f(0.1f, 0.2f, 0.3f), 0.25f});
  expect_same_as_brute_force(same, rng);
  const SphereBvh empty({});
  int visits = 0;
  empty.intersect(Vec3f::Zero(), Vec3f::UnitX(), 1e30f, [&](std::uint32_t, float, float) { ++visits; });
  EXPECT_EQ(visits, 0);
}

}  // namespace
}  // namespace sspc::render
