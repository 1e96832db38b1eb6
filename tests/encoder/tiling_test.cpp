// Tiled encoding (encoder/tiling.hpp): the plan's leaves partition the cloud, and a tiled encode
// is the untiled one up to the centres' placement: the same PSNR within 0.2 dB, every point
// covered, no hole along the tiles' borders. (That its bytes do not depend on where the tiles
// ran is python/tests/test_distributed.py's.)
#include "encoder/tiling.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "sspc/compressed_model.hpp"
#include "sspc/encoder.hpp"
#include "sspc/metrics.hpp"
#include "sspc/neighbours.hpp"
#include "sspc/synthetic.hpp"
#include "sspc/tiled_encoder.hpp"
#include "test_util.hpp"

namespace sspc::codec {
namespace {

TEST(Tiling, LeavesPartitionTheCloudAndHoldAtMostTheLimit) {
  const PointCloud cloud = synthetic::torus(20000, 1.0, 0.3);
  const TilePlan plan = plan_tiles(cloud.positions, 3000);
  ASSERT_GT(plan.size(), 6u);
  std::vector<std::uint64_t> counted(plan.size(), 0);
  for (const Vec3f& p : cloud.positions) {
    const std::uint32_t t = plan.tile_of(p);
    ASSERT_LT(t, plan.size());
    ++counted[t];
    EXPECT_TRUE(plan.boxes[t].contains(p));
  }
  EXPECT_EQ(counted, plan.points);  // every point in exactly the leaf the plan counted it in
  for (std::size_t t = 0; t < plan.size(); ++t) {
    EXPECT_LE(plan.points[t], 3000u);
    EXPECT_GT(plan.points[t], 0u);
  }
  // Boxes do not overlap beyond their faces.
  for (std::size_t t = 0; t < plan.size(); ++t) {
    for (std::size_t u = t + 1; u < plan.size(); ++u) {
      EXPECT_LT(plan.boxes[t].intersection(plan.boxes[u]).volume(), 1e-9f);
    }
  }
  EXPECT_EQ(plan_tiles(cloud.positions, 1u << 30).size(), 1u);  // one tile: the bounds
}

// A tiled encode holds a tile's code book until the last tile that can reach it is encoded
// (encoder/container_writer.cpp), so that wait must not grow with the cloud: on a surface of n
// tiles, a tile's last touching neighbour comes within about 2√n tiles of it. In the splits'
// depth-first order this terrain's worst wait is over half its 128 tiles.
TEST(Tiling, SweptLeavesWaitForFewTiles) {
  std::vector<Vec3f> points;
  for (int y = 0; y < 300; ++y) {
    for (int x = 0; x < 400; ++x) {
      points.emplace_back(0.01f * static_cast<float>(x), 0.01f * static_cast<float>(y),
                          0.05f * std::sin(0.05f * static_cast<float>(x + y)));
    }
  }
  const TilePlan plan = plan_tiles(points, 1000);
  ASSERT_GE(plan.size(), 100u);
  std::size_t worst = 0;
  for (std::size_t t = 0; t < plan.size(); ++t) {
    // Touching with a margin of a tenth of the smallest tile side, as a patch's reach is.
    const Box3f grown(plan.boxes[t].min() - Vec3f::Constant(0.01f), plan.boxes[t].max() + Vec3f::Constant(0.01f));
    for (std::size_t u = t + 1; u < plan.size(); ++u) {
      if (grown.intersects(plan.boxes[u])) worst = std::max(worst, u - t);
    }
    if (t > 0) {
      EXPECT_LE(plan.boxes[t - 1].min().x(), plan.boxes[t].min().x());  // swept along x, the longest
    }
  }
  std::printf("%zu tiles, worst wait %zu tiles\n", plan.size(), worst);
  EXPECT_LE(static_cast<double>(worst), 2 * std::sqrt(static_cast<double>(plan.size())) + 2);
}

// The grid bounds a leaf's size: a cell of one grid cell holding more than the limit stays one
// tile (larger than asked), never split below the grid.
TEST(Tiling, ACellFinerThanTheGridIsNotSplit) {
  std::vector<Vec3f> points(100, Vec3f(0.5f, 0.5f, 0.5f));
  points.push_back(Vec3f::Zero());
  points.push_back(Vec3f::Ones());
  const TilePlan plan = plan_tiles(points, 10);
  EXPECT_EQ(plan.points[plan.tile_of(points[0])], 100u);
  EXPECT_EQ(plan.size(), 3u);
}

// A memory limit sizes tiles from what is left after what the writer holds for the whole model,
// which grows with the cloud, and refuses, naming the least limit, rather than overrun it.
TEST(Tiling, TileSizeLeavesRoomForTheWholeModelsRecords) {
  constexpr std::uint64_t kLimit = 2ull << 30;
  const auto small = tile_points_for_memory(kLimit, 10'000'000);
  const auto large = tile_points_for_memory(kLimit, 1'000'000'000);
  ASSERT_TRUE(small.ok() && large.ok());
  EXPECT_GT(*small, *large);
  EXPECT_GE(*small - *large, 1'000'000'000ull / 512 * 100 / 470);  // 100 bytes a patch, 470 a tile point
  const auto huge = tile_points_for_memory(kLimit, 40'000'000'000);
  ASSERT_FALSE(huge.ok());
  EXPECT_EQ(huge.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(huge.status().message().find("MiB"), std::string::npos) << huge.status().message();
  EXPECT_FALSE(tile_points_for_memory(64ull << 20, 1000).ok());
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

TEST(Tiling, ATiledModelStoresNormalsWhenAsked) {
  // A tile's code words keep their normals only when the file stores them: the job must carry
  // the choice to the worker, and the result must bring them back.
  test::TempDir dir;
  const PointCloud cloud = synthetic::torus(6000, 1.0, 0.35, {.seed = 5});
  ASSERT_TRUE(cloud.has_normals());
  EncodeOptions options;
  options.level = 4;
  options.patch_points = 256;
  options.tile_points = 1600;
  options.store_normals = true;
  const auto stats = encode(cloud, dir.path() / "n.sspc", options);
  ASSERT_TRUE(stats.ok()) << stats.status().message();
  EXPECT_GE(stats->tiles, 2u);
  auto model = CompressedModel::open(dir.path() / "n.sspc");
  ASSERT_TRUE(model.ok());
  const PointCloud decoded = model->decode_all().value();
  ASSERT_TRUE(decoded.has_normals());
  // Each decoded normal is its nearest source point's, up to the codec's quantisation.
  const KdTree3 source(cloud.positions);
  std::size_t off = 0;
  for (std::size_t i = 0; i < decoded.size(); ++i) {
    float d2 = 0;
    const std::uint32_t j = source.nearest(decoded.positions[i], &d2);
    off += decoded.normals[i].dot(cloud.normals[j]) < 0.94f;  // 20 degrees
  }
  EXPECT_LE(off, decoded.size() / 100);
}

}  // namespace
}  // namespace sspc::codec
