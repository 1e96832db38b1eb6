// write→read round trips of the PLY writer in every encoding, and the atomic file write.
#include <fstream>
#include <sstream>
#include <tuple>

#include <gtest/gtest.h>

#include "io_test_util.hpp"
#include "sspc/io.hpp"
#include "test_util.hpp"

namespace sspc {
namespace {

using test::bytes_of;
using test::same_bits;

class PlyRoundTrip
    : public ::testing::TestWithParam<std::tuple<PlyEncoding, bool /*normals*/, bool /*colours*/>> {
};

TEST_P(PlyRoundTrip, FloatsAndColoursComeBackBitExact) {
  const auto [encoding, normals, colours] = GetParam();
  const PointCloud cloud = test::sample_cloud(50, normals, colours);
  PlyWriteOptions options;
  options.encoding = encoding;
  const std::string bytes = encode_ply(cloud, options);
  const StatusOr<PointCloud> back = read_ply(bytes_of(bytes), "memory.ply");
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  ASSERT_EQ(back->size(), cloud.size());
  EXPECT_EQ(back->has_normals(), normals);
  EXPECT_EQ(back->has_colours(), colours);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    EXPECT_TRUE(same_bits(back->positions[i], cloud.positions[i])) << "point " << i;
    if (normals) {
      EXPECT_TRUE(same_bits(back->normals[i], cloud.normals[i])) << "normal " << i;
    }
    if (colours) {
      EXPECT_EQ(back->colours[i], cloud.colours[i]) << "colour " << i;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(AllEncodings, PlyRoundTrip,
                         ::testing::Combine(::testing::Values(PlyEncoding::kBinaryLittleEndian,
                                                              PlyEncoding::kBinaryBigEndian,
                                                              PlyEncoding::kAscii),
                                            ::testing::Bool(), ::testing::Bool()));

TEST(PlyWriter, HeaderNamesTheLayoutAndKeepsComments) {
  PlyWriteOptions options;
  options.comments = {"made by a test", "two\nlines"};
  const std::string bytes = encode_ply(test::sample_cloud(2, true, true), options);
  EXPECT_EQ(bytes.rfind(
                "ply\nformat binary_little_endian 1.0\ncomment made by a test\ncomment two lines\n"
                "element vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
                "property float nx\nproperty float ny\nproperty float nz\n"
                "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n",
                0),
            0u);
  EXPECT_EQ(bytes.size(), bytes.find("end_header\n") + 11 + 2 * 27);
}

TEST(PlyWriter, OptionsCanDropNormalsAndColours) {
  PlyWriteOptions options;
  options.write_normals = false;
  options.write_colours = false;
  const std::string bytes = encode_ply(test::sample_cloud(3, true, true), options);
  const StatusOr<PointCloud> back = read_ply(bytes_of(bytes), "memory.ply");
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  EXPECT_FALSE(back->has_normals());
  EXPECT_FALSE(back->has_colours());
}

TEST(PlyWriter, WritePlyReplacesTheFileAtomically) {
  test::TempDir dir;
  const auto path = dir.path() / "out.ply";
  const PointCloud cloud = test::sample_cloud(10, true, false);
  ASSERT_TRUE(write_ply(cloud, path).ok());
  ASSERT_TRUE(write_ply(cloud, path).ok());      // over an existing file
  EXPECT_EQ(test::count_files(dir.path()), 1u);  // no temporary left behind
  const StatusOr<PointCloud> back = read_point_cloud(path);
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  EXPECT_EQ(back->size(), 10u);
  EXPECT_TRUE(back->has_normals());
}

TEST(PlyWriter, WritePlyRefusesAnInvalidCloudAndLeavesNoFile) {
  test::TempDir dir;
  PointCloud cloud = test::sample_cloud(4, true, false);
  cloud.normals.pop_back();
  const Status s = write_ply(cloud, dir.path() / "bad.ply");
  EXPECT_FALSE(s.ok());
  EXPECT_EQ(test::count_files(dir.path()), 0u);
}

TEST(PlyWriter, WritePlyIntoAMissingDirectoryFails) {
  test::TempDir dir;
  const Status s = write_ply(test::sample_cloud(4, false, false), dir.path() / "no" / "x.ply");
  EXPECT_EQ(s.code(), StatusCode::kIoError) << s.to_string();
}

// PlyStreamWriter: chunks joined give write_ply's bytes of the whole cloud (header from the first
// chunk, fields from the first non-empty one), with the body in memory or spilled beside the
// output (memory_bytes 1: every chunk spills), and no file left but the output.
TEST(PlyStreamWriter, ChunksGiveTheBytesOfTheWholeCloud) {
  PointCloud cloud = test::sample_cloud(100, true, true);
  cloud.origin = Vec3d(1000.5, -2, 3);
  cloud.metadata.comments = {"scanned by a test"};
  cloud.metadata.crs_wkt = "LOCAL_CS[\"test\"]";
  for (const PlyEncoding encoding : {PlyEncoding::kBinaryLittleEndian, PlyEncoding::kAscii}) {
    for (const std::size_t memory : {std::size_t{1} << 20, std::size_t{1}}) {
      test::TempDir dir;
      PlyWriteOptions options;
      options.encoding = encoding;
      options.comments = {"written in chunks"};
      ASSERT_TRUE(write_ply(cloud, dir.path() / "whole.ply", options).ok());
      auto writer = PlyStreamWriter::open(dir.path() / "chunks.ply", options, memory);
      ASSERT_TRUE(writer.ok()) << writer.status().to_string();
      const std::size_t cuts[] = {0, 0, 7, 50, 100};
      for (std::size_t k = 0; k + 1 < std::size(cuts); ++k) {
        PointCloud chunk;
        chunk.origin = cloud.origin;
        chunk.metadata = cloud.metadata;
        for (std::size_t i = cuts[k]; i < cuts[k + 1]; ++i) {
          chunk.positions.push_back(cloud.positions[i]);
          chunk.normals.push_back(cloud.normals[i]);
          chunk.colours.push_back(cloud.colours[i]);
        }
        ASSERT_TRUE(writer->write(chunk).ok());
        if (memory == 1 && k == 1) {
          EXPECT_EQ(test::count_files(dir.path()), 2u) << "whole.ply and the spilled body";
        }
      }
      EXPECT_EQ(writer->points(), 100u);
      EXPECT_EQ(test::count_files(dir.path()), memory == 1 ? 2u : 1u);
      ASSERT_TRUE(writer->finish().ok());
      EXPECT_EQ(test::read_file(dir.path() / "chunks.ply"), test::read_file(dir.path() / "whole.ply"))
          << "memory " << memory;
      EXPECT_EQ(test::count_files(dir.path()), 2u) << "no body left behind";
    }
  }
}

TEST(PlyStreamWriter, ChunksThatDisagreeFailAndNothingIsLeftBehind) {
  test::TempDir dir;
  const auto path = dir.path() / "out.ply";
  {
    auto writer = PlyStreamWriter::open(path, {}, 1);
    ASSERT_TRUE(writer.ok());
    ASSERT_TRUE(writer->write(test::sample_cloud(10, true, false)).ok());
    const Status fields = writer->write(test::sample_cloud(10, false, false));
    EXPECT_EQ(fields.code(), StatusCode::kInvalidArgument);
    EXPECT_NE(fields.message().find("out.ply"), std::string::npos) << fields.to_string();
    PointCloud moved = test::sample_cloud(10, true, false);
    moved.origin = Vec3d(1, 0, 0);
    EXPECT_EQ(writer->write(moved).code(), StatusCode::kInvalidArgument);
    PointCloud invalid = test::sample_cloud(4, true, false);
    invalid.normals.pop_back();
    EXPECT_FALSE(writer->write(invalid).ok());
    EXPECT_EQ(test::count_files(dir.path()), 1u);  // the spilled body
  }  // dropped before finish(): nothing written, the body removed
  EXPECT_EQ(test::count_files(dir.path()), 0u);
  auto empty = PlyStreamWriter::open(path);
  ASSERT_TRUE(empty.ok());
  EXPECT_EQ(empty->finish().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(test::count_files(dir.path()), 0u);
}

}  // namespace
}  // namespace sspc
