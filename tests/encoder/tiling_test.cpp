// Tiled encoding (encoder/tiling.hpp): the plan's leaves partition the cloud, and a tiled encode
// is the untiled one up to the centres' placement: the same PSNR within 0.2 dB, every point
// covered, no hole along the tiles' borders. (That its bytes do not depend on where the tiles
// ran is python/tests/test_distributed.py's.)
#include "encoder/tiling.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

#include "sspc/compressed_model.hpp"
#include "sspc/encoder.hpp"
#include "sspc/metrics.hpp"
#include "sspc/neighbours.hpp"
#include "sspc/synthetic.hpp"
#include "test_util.hpp"

namespace sspc::codec {
namespace {

TEST(Tiling, LeavesPartitionTheCloudAndHoldAtMostTheLimit) {
  const PointCloud cloud = synthetic::torus(20000, 1.0, 0.3);
  const TilePlan plan = plan_tiles(cloud.positions, 3000);
  ASSERT_GT(plan.boxes.size(), 6u);
  std::vector<int> seen(cloud.size(), 0);
  for (std::size_t t = 0; t < plan.boxes.size(); ++t) {
    EXPECT_LE(plan.points[t].size(), 3000u);
    EXPECT_FALSE(plan.points[t].empty());
    EXPECT_TRUE(std::is_sorted(plan.points[t].begin(), plan.points[t].end()));
    for (std::uint32_t i : plan.points[t]) {
      ++seen[i];
      EXPECT_TRUE(plan.boxes[t].contains(cloud.positions[i]));
    }
  }
  EXPECT_EQ(std::count(seen.begin(), seen.end(), 1), static_cast<std::ptrdiff_t>(cloud.size()));
  EXPECT_EQ(plan_tiles(cloud.positions, 1u << 30).boxes.size(), 1u);  // one tile: the bounds
}

TEST(Tiling, ATiledModelDecodesLikeTheUntiledOne) {
  test::TempDir dir;
  const PointCloud cloud = synthetic::torus(8000, 1.0, 0.35, {.seed = 3, .normals = false});
  // Tiles of several patches each, as tiles of millions of points hold thousands.
  EncodeOptions untiled;
  untiled.level = 4;
  untiled.patch_points = 256;
  EncodeOptions tiled = untiled;
  tiled.tile_points = 1600;
  auto a = encode(cloud, dir.path() / "a.sspc", untiled);
  auto b = encode(cloud, dir.path() / "b.sspc", tiled);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->tiles, 0u);
  EXPECT_GE(b->tiles, 6u);
  EXPECT_LE(b->max_coverage_distance, b->coverage_radius);  // every point covered across borders
  // The cost of the borders' extra patches is small.
  EXPECT_LT(b->bits_per_point, 1.1 * a->bits_per_point);

  auto decode = [&](const char* name) {
    auto model = CompressedModel::open(dir.path() / name);
    EXPECT_TRUE(model.ok());
    return model->decode_all().value();
  };
  const PointCloud da = decode("a.sspc"), db = decode("b.sspc");
  const double psnr_a = evaluate(cloud, da)->psnr_paper, psnr_b = evaluate(cloud, db)->psnr_paper;
  EXPECT_NEAR(psnr_b, psnr_a, 0.2);
  // No more holes than untiled, the tiles' borders included: points with no decoded point
  // within two spacings (random sampling leaves a few anyway).
  const double spacing = nominal_spacing(cloud);
  auto holes = [&](const PointCloud& d) {
    const KdTree3 decoded(d.positions);
    std::size_t n = 0;
    for (const Vec3f& p : cloud.positions) {
      float d2 = 0;
      decoded.nearest(p, &d2);
      n += double{d2} > 4 * spacing * spacing;
    }
    return n;
  };
  std::printf("holes: untiled %zu, tiled %zu\n", holes(da), holes(db));
  // Without the margin the tiles' borders leave 344 of these 8,000 points uncovered.
  EXPECT_LE(holes(db), holes(da) + cloud.size() / 1000);
}

}  // namespace
}  // namespace sspc::codec
