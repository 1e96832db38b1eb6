// Pins the format versions. tests/data/codec/golden_vN.sspc was written by version N's writer
// from the fixed model below and must keep decoding to the points in golden_vN_decoded.txt;
// writing the model again must give golden_v2.sspc's to golden_v7.sspc's bytes. Regenerate the current version's
// pair (only when the format version changes) with SSPC_UPDATE_GOLDEN=1; older pairs are never
// regenerated.
#include <gtest/gtest.h>
#include <zstd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "container_test_models.hpp"
#include "encoder/container_writer.hpp"
#include "sspc/compressed_model.hpp"
#include "test_util.hpp"

namespace sspc::codec {
namespace {

EncodedModel golden_model() {
  test::ModelShape s;
  s.side = 6;
  s.patch_radius = 2.0f;
  s.centre_step = 2.5f;
  s.codewords = 2;
  s.full_rotations = true;  // rotations from sqrt only: bit-identical on every libm
  s.seed = 2024;
  return test::make_plane_model(s);
}

QuantOptions golden_options() {
  QuantOptions o;
  o.patches_per_block = 3;
  o.codewords_per_block = 1;
  return o;
}

std::string describe(const PointCloud& c) {
  std::string out;
  char line[256];
  for (std::size_t i = 0; i < c.size(); ++i) {
    const Vec3f& p = c.positions[i];
    const Vec3f& n = c.normals[i];
    std::snprintf(line, sizeof line, "%.9g %.9g %.9g %.9g %.9g %.9g %u %u %u\n", double{p.x()},
                  double{p.y()}, double{p.z()}, double{n.x()}, double{n.y()}, double{n.z()},
                  unsigned{c.colours[i].r}, unsigned{c.colours[i].g}, unsigned{c.colours[i].b});
    out += line;
  }
  return out;
}

using test::read_file;

// (b) A committed file decodes to its committed points.
void expect_decodes_to_committed_points(const std::string& version) {
  const auto sspc_path = test::data_path("codec/golden_" + version + ".sspc");
  const std::string expected = read_file(test::data_path("codec/golden_" + version + "_decoded.txt"));
  ASSERT_FALSE(expected.empty()) << version;
  auto model = CompressedModel::open(sspc_path);
  ASSERT_TRUE(model.ok()) << model.status().to_string();
  EXPECT_TRUE(model->verify().ok());
  auto all = model->decode_all();
  ASSERT_TRUE(all.ok()) << all.status().to_string();
  EXPECT_EQ(describe(*all), expected.substr(expected.find('\n') + 1));
}

TEST(GoldenTest, Version1FileStillDecodes) { expect_decodes_to_committed_points("v1"); }

// (a) Writing the model again with `options` gives the committed bytes, and (b) they decode to
// the committed points.
void expect_reproduced(const std::string& version, const QuantOptions& options) {
  const auto sspc_path = test::data_path("codec/golden_" + version + ".sspc");
  const auto points_path = test::data_path("codec/golden_" + version + "_decoded.txt");
  auto bytes = encode_container(golden_model(), options);
  ASSERT_TRUE(bytes.ok()) << bytes.status().to_string();
  const std::string zstd_line = "# zstd " + std::to_string(ZSTD_versionNumber()) + "\n";

  if (std::getenv("SSPC_UPDATE_GOLDEN") != nullptr && version == "v" + std::to_string(kFormatVersion)) {
    auto model = CompressedModel::from_bytes(*bytes);
    ASSERT_TRUE(model.ok());
    auto all = model->decode_all();
    ASSERT_TRUE(all.ok());
    std::ofstream(sspc_path, std::ios::binary) << *bytes;
    std::ofstream(points_path, std::ios::binary) << zstd_line << describe(*all);
    GTEST_SKIP() << "golden files rewritten";
  }
  expect_decodes_to_committed_points(version);

  // zstd's output may differ between zstd releases (the format does not), so the byte
  // comparison needs the release that wrote it.
  const std::string golden = read_file(sspc_path);
  const std::string expected = read_file(points_path);
  const std::size_t newline = expected.find('\n');
  if (expected.substr(0, newline + 1) != zstd_line) {
    GTEST_SKIP() << "golden file written with " << expected.substr(0, newline)
                 << ", this build has zstd " << ZSTD_versionNumber();
  }
  EXPECT_TRUE(*bytes == golden) << "the writer no longer reproduces golden_" << version << ".sspc";
}

// Version 2 stored every point as it came; the writer still writes it on request.
TEST(GoldenTest, Version2FileIsReproducedAndDecodes) {
  QuantOptions options = golden_options();
  options.format_version = 2;
  options.keep_duplicates = true;
  expect_reproduced("v2", options);
}

// Version 3's columns without version 4's plane-reach contexts; the writer still writes it on
// request.
TEST(GoldenTest, Version3FileIsReproducedAndDecodes) {
  QuantOptions options = golden_options();
  options.format_version = 3;
  expect_reproduced("v3", options);
}

// Version 4's heights predicted at the cells' offsets, without the residual classes, and coded
// where they lie; the writer still writes it on request.
TEST(GoldenTest, Version4FileIsReproducedAndDecodes) {
  QuantOptions options = golden_options();
  options.format_version = 4;
  expect_reproduced("v4", options);
}

// Version 5's occupancy bits under the ten cells alone; the writer still writes it on request.
TEST(GoldenTest, Version5FileIsReproducedAndDecodes) {
  QuantOptions options = golden_options();
  options.format_version = 5;
  expect_reproduced("v5", options);
}

// Version 6's value lengths in a bit tree; the writer still writes it on request.
TEST(GoldenTest, Version6FileIsReproducedAndDecodes) {
  QuantOptions options = golden_options();
  options.format_version = 6;
  expect_reproduced("v6", options);
}

TEST(GoldenTest, Version7FileIsReproducedAndDecodes) {
  ASSERT_EQ(kFormatVersion, 7) << "a new version needs its own golden pair";
  expect_reproduced("v7", golden_options());
}

}  // namespace
}  // namespace sspc::codec
