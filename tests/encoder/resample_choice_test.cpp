// The writer's measured choice of resampling (encoder/resample_choice.hpp): on a single surface
// and on a layered one (two sheets a fraction of a spacing apart, as overlapping scans lie), the
// m it writes decodes within noise of the best m a decoder could ask for, and never below the
// points as stored; at a coarse grid it resamples.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "sspc/compressed_model.hpp"
#include "sspc/encoder.hpp"
#include "sspc/metrics.hpp"
#include "sspc/synthetic.hpp"
#include "test_util.hpp"

namespace sspc {
namespace {

// Two copies of a bumpy sheet, the second 0.3 spacings above the first and shifted by half a
// spacing: one fitted surface between them is farther from both than their own points are.
PointCloud layered(std::size_t points) {
  const PointCloud sheet = synthetic::bumps(points, 1.0, 2, 0.05, {.seed = 11});
  const double spacing = 1.0 / std::sqrt(static_cast<double>(points));
  PointCloud out = sheet;
  for (const Vec3f& p : sheet.positions) {
    out.positions.push_back(p + Vec3f(static_cast<float>(0.5 * spacing), 0, static_cast<float>(0.3 * spacing)));
  }
  out.normals.clear();
  return out;
}

double psnr_of(const PointCloud& source, const CompressedModel& model, int m) {
  DecodeOptions options;
  options.resample = m;
  auto decoded = model.decode_all(options);
  EXPECT_TRUE(decoded.ok()) << decoded.status().to_string();
  auto report = evaluate(source, *decoded);
  EXPECT_TRUE(report.ok()) << report.status().to_string();
  return report.ok() ? report->psnr_paper : 0.0;
}

TEST(ResampleChoice, TheWrittenMDecodesNearTheBestAndNeverBelowTheStoredPoints) {
  test::TempDir dir;
  const PointCloud clouds[] = {synthetic::bumps(4000, 1.0, 3, 0.05, {.seed = 5}), layered(2000)};
  for (std::size_t c = 0; c < 2; ++c) {
    for (const int level : {6, 8}) {
      SCOPED_TRACE("cloud " + std::to_string(c) + ", level " + std::to_string(level));
      const auto path = dir.path() / "m.sspc";
      EncodeOptions options;
      options.level = level;
      auto stats = encode(clouds[c], path, options);
      ASSERT_TRUE(stats.ok()) << stats.status().to_string();
      auto model = CompressedModel::open(path);
      ASSERT_TRUE(model.ok());
      const int chosen = model->info().resample;
      EXPECT_EQ(chosen, stats->resample);
      const double written = psnr_of(clouds[c], *model, -1);
      const double stored = psnr_of(clouds[c], *model, 0);
      EXPECT_GE(written, stored - 0.01) << "m " << chosen;
      double best = stored;
      for (int m = 1; m <= 3; ++m) best = std::max(best, psnr_of(clouds[c], *model, m));
      EXPECT_GE(written, best - 0.3) << "m " << chosen;
      std::printf("cloud %zu level %d: m %d, %.3f dB (stored %.3f, best of 0-3 %.3f)\n", c, level, chosen,
                  written, stored, best);
    }
  }
}

TEST(ResampleChoice, ACoarseGridIsResampled) {
  test::TempDir dir;
  const PointCloud cloud = synthetic::bumps(4000, 1.0, 3, 0.05, {.seed = 5});
  EncodeOptions options;
  options.level = 9;
  ASSERT_TRUE(encode(cloud, dir.path() / "m.sspc", options).ok());
  auto model = CompressedModel::open(dir.path() / "m.sspc");
  ASSERT_TRUE(model.ok());
  EXPECT_GE(model->info().resample, 2);
  EXPECT_GT(psnr_of(cloud, *model, -1), psnr_of(cloud, *model, 0) + 1.0);
}

}  // namespace
}  // namespace sspc
