// read_point_cloud: format by option, by extension and by content; file-level errors.
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

#include "io_test_util.hpp"
#include "sspc/io.hpp"
#include "test_util.hpp"

namespace sspc {
namespace {

void write_text(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

TEST(FormatFromExtension, KnownAndUnknown) {
  EXPECT_EQ(format_from_extension("a/b.ply"), PointCloudFormat::kPly);
  EXPECT_EQ(format_from_extension("B.PLY"), PointCloudFormat::kPly);
  EXPECT_EQ(format_from_extension("c.pcd"), PointCloudFormat::kPcd);
  EXPECT_EQ(format_from_extension("d.xyz"), PointCloudFormat::kXyz);
  EXPECT_EQ(format_from_extension("d.pts"), PointCloudFormat::kXyz);
  EXPECT_EQ(format_from_extension("d.txt"), PointCloudFormat::kXyz);
  EXPECT_EQ(format_from_extension("e.las"), PointCloudFormat::kLas);
  EXPECT_EQ(format_from_extension("e.LAZ"), PointCloudFormat::kLas);
  EXPECT_EQ(format_from_extension("f.xyzrgb"), PointCloudFormat::kXyzRgb);
  EXPECT_EQ(format_from_extension("f.xyzn"), PointCloudFormat::kXyzN);
  EXPECT_EQ(format_from_extension("e.e57"), PointCloudFormat::kAuto);
  EXPECT_EQ(format_from_extension("noext"), PointCloudFormat::kAuto);
}

TEST(ReadPointCloud, SniffsTheContentWhenTheExtensionSaysNothing) {
  test::TempDir dir;
  write_text(dir.path() / "a.dat", encode_ply(test::sample_cloud(3, false, false)));
  write_text(dir.path() / "b.dat",
             "# .PCD v0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nDATA ascii\n1 2 3\n");
  write_text(dir.path() / "c.dat", "1 2 3\n4 5 6\n");
  EXPECT_EQ(read_point_cloud(dir.path() / "a.dat")->size(), 3u);
  EXPECT_EQ(read_point_cloud(dir.path() / "b.dat")->size(), 1u);
  EXPECT_EQ(read_point_cloud(dir.path() / "c.dat")->size(), 2u);
}

TEST(ReadPointCloud, TheOptionOverridesTheExtension) {
  test::TempDir dir;
  const auto path = dir.path() / "points.ply";
  write_text(path, "1 2 3\n");
  EXPECT_FALSE(read_point_cloud(path).ok());
  ReadOptions options;
  options.format = PointCloudFormat::kXyz;
  const StatusOr<PointCloud> c = read_point_cloud(path, options);
  ASSERT_TRUE(c.ok()) << c.status().to_string();
  EXPECT_EQ(c->positions[0], Vec3f(1, 2, 3));
}

TEST(ReadPointCloud, ErrorsNameThePath) {
  test::TempDir dir;
  const auto path = dir.path() / "broken.ply";
  write_text(path, "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n");
  const StatusOr<PointCloud> c = read_point_cloud(path);
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.status().message().find(path.string() + ": line 3"), std::string::npos)
      << c.status().message();
}

TEST(ReadPointCloud, MissingAndEmptyFiles) {
  test::TempDir dir;
  EXPECT_EQ(read_point_cloud(dir.path() / "nope.ply").status().code(), StatusCode::kNotFound);
  write_text(dir.path() / "empty.xyz", "");
  const StatusOr<PointCloud> c = read_point_cloud(dir.path() / "empty.xyz");
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.status().code(), StatusCode::kInvalidArgument);
}

class CountingProgress final : public Progress {
 public:
  void begin_stage(std::string_view, std::uint64_t total, std::string_view) override {
    total_ = total;
    ++stages_;
  }
  void advance(std::uint64_t done) override { done_ += done; }
  void end_stage() override { ++ended_; }
  std::uint64_t total_ = 0, done_ = 0;
  int stages_ = 0, ended_ = 0;
};

TEST(ReadPointCloud, ReportsProgressInBytes) {
  test::TempDir dir;
  const auto path = dir.path() / "p.ply";
  ASSERT_TRUE(write_ply(test::sample_cloud(1000, true, true), path).ok());
  CountingProgress progress;
  ReadOptions options;
  options.progress = &progress;
  ASSERT_TRUE(read_point_cloud(path, options).ok());
  EXPECT_EQ(progress.stages_, 1);
  EXPECT_EQ(progress.ended_, 1);
  EXPECT_EQ(progress.done_, progress.total_);
  EXPECT_EQ(progress.total_, std::filesystem::file_size(path));
}

TEST(ReadPointCloud, ReportsProgressInBytesForEveryFormat) {
  test::TempDir dir;
  std::string pcd = "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nDATA binary\n";
  for (float v : {1.0f, 2.0f, 3.0f}) test::put(pcd, v);
  pcd += "padding";  // ignored, but read
  write_text(dir.path() / "p.pcd", pcd);
  write_text(dir.path() / "p.xyz", "1 2 3\n4 5 6\n");
  PlyWriteOptions ascii;
  ascii.encoding = PlyEncoding::kAscii;
  write_text(dir.path() / "a.ply", encode_ply(test::sample_cloud(5, true, false), ascii));
  for (const char* name : {"p.pcd", "p.xyz", "a.ply"}) {
    CountingProgress progress;
    ReadOptions options;
    options.progress = &progress;
    ASSERT_TRUE(read_point_cloud(dir.path() / name, options).ok()) << name;
    EXPECT_EQ(progress.done_, progress.total_) << name;
    EXPECT_EQ(progress.total_, std::filesystem::file_size(dir.path() / name)) << name;
  }
}

TEST(ReadPointCloud, AFifoIsAnErrorNotAHang) {
  test::TempDir dir;
  const auto path = dir.path() / "pipe.xyz";
  ASSERT_EQ(mkfifo(path.c_str(), 0600), 0);
  alarm(10);  // a blocking open() would otherwise hang until CTest's timeout
  const StatusOr<PointCloud> c = read_point_cloud(path);
  alarm(0);
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.status().message(), path.string() + ": not a regular file (a FIFO)");
}

}  // namespace
}  // namespace sspc
