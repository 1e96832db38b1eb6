// The rate regression (issue: rate–distortion, item 7): the bundled bunny at levels 1, 5 and 9
// must keep its bits per point and its PSNR (the paper's, as `sspc eval` computes it), so that a
// later change to the codec cannot lose them silently. The pinned values are what this version
// measures; a change that improves them should pin the new values (the test prints them).
//
// It runs with the CLI's tests in the release build (scripts/test.sh): an encode of the bunny
// takes about a second there and ten under the sanitizers, which add nothing to a rate test.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>

#include "sspc/compressed_model.hpp"
#include "sspc/encoder.hpp"
#include "sspc/io.hpp"
#include "sspc/metrics.hpp"
#include "test_util.hpp"

namespace sspc {
namespace {

struct Pinned {
  int level;
  double bits_per_point;  // at most this (+0.5%)
  double psnr;            // at least this (−0.05 dB)
};

// Measured by this test on data/bunny.ply (34 834 points), format version 7 (version 6 wrote
// 9.9328, 3.3129 and 0.5206 bits per point at the same PSNR, its values' lengths in a bit tree,
// docs/FORMAT_NOTES.md, "Value lengths in unary"; version 5 wrote 10.0412, 3.3361 and 0.5225;
// version 4 wrote
// 10.5297 bits a point at 69.820 dB, 3.4435 at 55.079 and 0.5250 at 48.517, before the plane
// through each point's own column, the residual classes and the writer's choice of heights,
// docs/FORMAT_NOTES.md, "Heights at the point"; version 3 wrote
// 10.7334, 3.5551 and 0.5379 bits per point at the same PSNR; 10.7387 at level 1 before the
// writer priced each code word's cell size, cheapest_shift; 10.7047 at 70.014 dB and 3.5375 at
// 55.105 dB before the code words followed the scan's lattice, codebook_builder.cpp; 10.5814 at
// 70.070 dB, 3.4858 at 55.110 and 0.5239 at 48.491 before the encoder took the points in Morton
// order, which places the patch centres elsewhere: over the four scans' levels the bits at equal
// PSNR moved by -3% to +1%, docs/RESULTS.md). Level 9 decodes resampled, 3 × 3 points a stored
// point (docs/FORMAT.md, "Resampling"): 42.642 dB as stored.
constexpr Pinned kPinned[] = {
    {1, 9.9188, 69.820},
    {5, 3.2949, 55.019},
    {9, 0.5069, 48.505},
};

TEST(RateRegression, BunnyKeepsItsRateAndPsnrAtLevels1_5_9) {
  const std::filesystem::path source = std::filesystem::path(SSPC_SOURCE_DIR) / "data" / "bunny.ply";
  auto cloud = read_point_cloud(source);
  ASSERT_TRUE(cloud.ok()) << cloud.status().to_string();
  test::TempDir dir;
  for (const Pinned& pin : kPinned) {
    SCOPED_TRACE("level " + std::to_string(pin.level));
    EncodeOptions options;
    options.level = pin.level;
    const auto path = dir.path() / ("bunny." + std::to_string(pin.level) + ".sspc");
    auto stats = encode(*cloud, path, options);
    ASSERT_TRUE(stats.ok()) << stats.status().to_string();
    auto model = CompressedModel::open(path);
    ASSERT_TRUE(model.ok()) << model.status().to_string();
    auto decoded = model->decode_all();
    ASSERT_TRUE(decoded.ok()) << decoded.status().to_string();
    auto report = evaluate(*cloud, *decoded);
    ASSERT_TRUE(report.ok()) << report.status().to_string();
    std::printf("level %d: %.4f bits per point, %.3f dB\n", pin.level, stats->bits_per_point,
                report->psnr_paper);
    EXPECT_LE(stats->bits_per_point, pin.bits_per_point * 1.005);
    EXPECT_GE(report->psnr_paper, pin.psnr - 0.05);
  }
}

}  // namespace
}  // namespace sspc
