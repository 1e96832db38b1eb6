#include "encoder/descriptor.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "sspc/synthetic.hpp"

namespace sspc {
namespace {

std::vector<float> describe(const std::vector<Vec3f>& normals, const DescriptorParams& params = {}) {
  std::vector<float> d(static_cast<std::size_t>(params.dimension()));
  compute_descriptor(normals, params, d);
  return d;
}

TEST(Descriptor, FlatPatchPutsAllMassInTheCentreBin) {
  const std::vector<Vec3f> up(50, Vec3f::UnitZ());
  DescriptorParams params;
  params.bins = 8;
  const auto d = describe(up, params);
  ASSERT_EQ(d.size(), 14u);
  // Cumulative x histogram: 0 below the centre bin (index 4), 1 from it on.
  for (int i = 0; i < 7; ++i) EXPECT_EQ(d[static_cast<std::size_t>(i)], i < 4 ? 0.0f : 1.0f) << i;
  EXPECT_EQ(describe({}, params), d);  // an empty patch describes as flat
}

TEST(Descriptor, CumulativeEntriesAreMonotoneInUnitInterval) {
  synthetic::Rng rng(3);
  std::vector<Vec3f> normals;
  for (int i = 0; i < 200; ++i) {
    normals.emplace_back(Vec3d(rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), 1).normalized().cast<float>());
  }
  DescriptorParams params;
  const auto d = describe(normals, params);
  const std::size_t half = static_cast<std::size_t>(params.bins - 1);
  for (std::size_t axis = 0; axis < 2; ++axis) {
    for (std::size_t i = 0; i < half; ++i) {
      const float v = d[axis * half + i];
      EXPECT_GE(v, 0.0f);
      EXPECT_LE(v, 1.0f);
      if (i > 0) {
        EXPECT_GE(v, d[axis * half + i - 1]);
      }
    }
  }
}

TEST(Descriptor, MatchDistanceIsTheEarthMoversDistanceBetweenShiftedSpikes) {
  // All normals in one bin versus all in the next bin: the cumulative histograms differ in
  // exactly one entry, by 1, on each axis; so the distance is 2.
  DescriptorParams params;
  params.bins = 8;
  params.stretch = 1e-3f;  // nearly linear binning: bin width 0.25 in x
  const std::vector<Vec3f> a(10, Vec3f(0.1f, 0.1f, 1).normalized());
  const std::vector<Vec3f> b(10, Vec3f(0.35f, 0.35f, 1).normalized());
  const auto da = describe(a, params), db = describe(b, params);
  EXPECT_FLOAT_EQ(match_distance(da, db), 2.0f);
  EXPECT_FLOAT_EQ(match_distance(da, da), 0.0f);
  EXPECT_FLOAT_EQ(match_distance(da, db), match_distance(db, da));
}

TEST(Descriptor, StretchWidensTheCentre) {
  // Two normals tilted 2° and 6° fall in the same bin without the stretch and in different
  // bins with it: the stretch resolves the fine variation near +Z that the paper wants.
  const float t1 = std::sin(2.0f * 3.14159265f / 180.0f), t2 = std::sin(6.0f * 3.14159265f / 180.0f);
  DescriptorParams linear;
  linear.stretch = 1e-3f;
  DescriptorParams stretched;
  stretched.stretch = 3.0f;
  const std::vector<Vec3f> a{Vec3f(t1, 0, 1).normalized()}, b{Vec3f(t2, 0, 1).normalized()};
  EXPECT_EQ(match_distance(describe(a, linear), describe(b, linear)), 0.0f);
  EXPECT_GT(match_distance(describe(a, stretched), describe(b, stretched)), 0.0f);
}

}  // namespace
}  // namespace sspc
