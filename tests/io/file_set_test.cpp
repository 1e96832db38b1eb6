// Several files as one cloud (sspc/io.hpp: input_files, FileSetOrigin, read_point_clouds): the
// points of each in turn about one origin, the arrays every file has, one CRS.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "double_cloud_files.hpp"
#include "sspc/io.hpp"
#include "sspc/synthetic.hpp"
#include "test_util.hpp"

namespace sspc {
namespace {

std::vector<std::filesystem::path> write_parts(const test::TempDir& dir, const PointCloud& cloud, int parts) {
  std::vector<std::filesystem::path> files;
  for (int k = 0; k < parts; ++k) {
    const std::size_t begin = cloud.size() * static_cast<std::size_t>(k) / static_cast<std::size_t>(parts);
    const std::size_t end = cloud.size() * static_cast<std::size_t>(k + 1) / static_cast<std::size_t>(parts);
    files.push_back(dir.path() / ("part" + std::to_string(k) + ".ply"));
    EXPECT_TRUE(write_ply(cloud.slice(begin, end), files.back()).ok());
  }
  return files;
}

TEST(FileSet, FilesThatShareAnOriginReadAsTheirConcatenation) {
  const test::TempDir dir;
  const PointCloud cloud = synthetic::torus(3000, 1.0, 0.3);
  const auto files = write_parts(dir, cloud, 3);
  const StatusOr<PointCloud> read = read_point_clouds(files);
  ASSERT_TRUE(read.ok()) << read.status().message();
  EXPECT_EQ(read->positions, cloud.positions);
  EXPECT_EQ(read->normals, cloud.normals);
  EXPECT_EQ(read->origin, Vec3d::Zero());
  // A file without normals: the set has none.
  PointCloud bare = cloud.slice(0, 100);
  bare.normals.clear();
  ASSERT_TRUE(write_ply(bare, dir.path() / "bare.ply").ok());
  std::vector<std::filesystem::path> mixed = files;
  mixed.push_back(dir.path() / "bare.ply");
  const StatusOr<PointCloud> without = read_point_clouds(mixed);
  ASSERT_TRUE(without.ok());
  EXPECT_EQ(without->size(), cloud.size() + 100);
  EXPECT_FALSE(without->has_normals());
}

// Georeferenced tiles: each file's reader picks an origin of its own; the set takes the rounded
// centre of their union, and every point keeps its place to float32's rounding.
TEST(FileSet, GeoreferencedTilesShareOneOriginAndKeepTheirPlaces) {
  const test::TempDir dir;
  std::vector<std::filesystem::path> files;
  std::vector<Vec3d> all;
  for (int k = 0; k < 3; ++k) {
    const auto points = test::shifted(test::wavy_patch(20), Vec3d(500000.0 + 40.0 * k, 4500000.0, 100.0));
    all.insert(all.end(), points.begin(), points.end());
    files.push_back(dir.path() / ("tile" + std::to_string(k) + ".ply"));
    test::write_bytes(files.back(), test::ply_double(points, true));
  }
  const StatusOr<PointCloud> read = read_point_clouds(files);
  ASSERT_TRUE(read.ok()) << read.status().message();
  ASSERT_EQ(read->size(), all.size());
  const StatusOr<PointCloud> first = read_point_cloud(files[0]);
  ASSERT_TRUE(first.ok());
  EXPECT_NE(first->origin, read->origin) << "each tile alone has its own origin";
  for (std::size_t i = 0; i < all.size(); ++i) {
    EXPECT_LT((read->world(i) - all[i]).cwiseAbs().maxCoeff(), 1e-5) << i;
  }
}

TEST(FileSet, TheFilesMustShareTheirCrs) {
  const test::TempDir dir;
  PointCloud cloud = synthetic::plane(400, 1.0);
  auto files = write_parts(dir, cloud, 2);
  cloud.metadata.crs_wkt = "PROJCRS[\"other\"]";
  ASSERT_TRUE(write_ply(cloud.slice(0, 50), dir.path() / "other.ply").ok());
  files.push_back(dir.path() / "other.ply");
  const StatusOr<PointCloud> read = read_point_clouds(files);
  ASSERT_FALSE(read.ok());
  EXPECT_NE(read.status().message().find("other.ply: its coordinate reference system differs from"), std::string::npos)
      << read.status().message();
}

TEST(FileSet, ArgumentsNameFilesFoldersAndPatterns) {
  const test::TempDir dir;
  const auto files = write_parts(dir, synthetic::plane(300, 1.0), 3);
  { std::ofstream(dir.path() / "notes.txt.bak") << "not a cloud"; }
  const std::string folder = dir.path().string();
  auto listed = input_files(std::vector<std::string>{folder});
  ASSERT_TRUE(listed.ok()) << listed.status().message();
  EXPECT_EQ(*listed, files) << "the folder's clouds, by name";
  listed = input_files(std::vector<std::string>{folder + "/part[12].ply", files[0].string()});
  ASSERT_TRUE(listed.ok());
  EXPECT_EQ(*listed, (std::vector<std::filesystem::path>{files[1], files[2], files[0]}));
  EXPECT_NE(input_files(std::vector<std::string>{folder + "/*.las"}).status().message().find("no file matches"),
            std::string::npos);
  EXPECT_NE(input_files(std::vector<std::string>{files[0].string(), folder}).status().message().find("given twice"),
            std::string::npos);
  const test::TempDir empty;
  EXPECT_NE(input_files(std::vector<std::string>{empty.path().string()}).status().message().find("no point-cloud files"),
            std::string::npos);
}

}  // namespace
}  // namespace sspc
