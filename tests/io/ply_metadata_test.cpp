// What a file says about the cloud as a whole survives reading and writing: PLY comments and the
// CRS comment, world coordinates written as doubles when the cloud has an origin; and the XYZ
// variants whose extension names their columns (.xyzrgb, .xyzn).
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "double_cloud_files.hpp"
#include "io_test_util.hpp"
#include "sspc/io.hpp"
#include "test_util.hpp"

namespace sspc {
namespace {

TEST(PlyMetadata, CommentsAndTheCrsSurviveAWriteAndARead) {
  PointCloud cloud;
  for (int i = 0; i < 5; ++i) cloud.positions.emplace_back(float(i), 0.5f, -1.0f);
  cloud.metadata.comments = {"scanned 2024-05-01", "origin: site A"};
  cloud.metadata.crs_wkt = "PROJCRS[\"WGS 84 / UTM zone 32N\",\nBASEGEOGCRS[\"WGS 84\"]]";
  const std::string ply = encode_ply(cloud);
  const StatusOr<PointCloud> back = read_ply(test::bytes_of(ply), "m.ply");
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  EXPECT_EQ(back->metadata.comments, cloud.metadata.comments);
  // One header line: the line break becomes a space.
  EXPECT_EQ(back->metadata.crs_wkt, "PROJCRS[\"WGS 84 / UTM zone 32N\", BASEGEOGCRS[\"WGS 84\"]]");
}

TEST(PlyMetadata, AnOriginIsWrittenAsDoubleWorldCoordinates) {
  test::TempDir dir;
  const std::vector<Vec3d> far = test::shifted(test::wavy_patch(10), Vec3d(500000, 4500000, 100));
  test::write_bytes(dir.path() / "in.ply", test::ply_double(far, true));
  const StatusOr<PointCloud> cloud = read_point_cloud(dir.path() / "in.ply");
  ASSERT_TRUE(cloud.ok());
  for (const PlyEncoding encoding : {PlyEncoding::kBinaryLittleEndian, PlyEncoding::kAscii}) {
    PlyWriteOptions options;
    options.encoding = encoding;
    const std::string ply = encode_ply(*cloud, options);
    EXPECT_NE(ply.find("property double x"), std::string::npos);
    const StatusOr<PointCloud> back = read_ply(test::bytes_of(ply), "out.ply");
    ASSERT_TRUE(back.ok());
    EXPECT_EQ(back->origin, cloud->origin);
    for (std::size_t i = 0; i < far.size(); ++i) {
      // The local value as read the first time; the file's double within one float32 step.
      ASSERT_EQ(back->positions[i], cloud->positions[i]) << i;
      const Vec3d local = far[i] - cloud->origin;
      for (int k = 0; k < 3; ++k) {
        const auto f = static_cast<float>(local[k]);
        const double ulp = double{std::nextafter(std::abs(f), INFINITY)} - double{std::abs(f)};
        ASSERT_LE(std::abs(back->world(i)[k] - far[i][k]), ulp) << i;
      }
    }
  }
}

TEST(XyzByExtension, XyzrgbReadsColoursAsOpen3dWritesThem) {
  test::TempDir dir;
  test::write_bytes(dir.path() / "a.xyzrgb", "0 0 0 1 0.5 0\n1 0 0 0 0 1\n0 1 0 0.2 0.2 0.2\n");
  const StatusOr<PointCloud> unit = read_point_cloud(dir.path() / "a.xyzrgb");
  ASSERT_TRUE(unit.ok()) << unit.status().to_string();
  EXPECT_FALSE(unit->has_normals());
  ASSERT_TRUE(unit->has_colours());
  EXPECT_EQ(unit->colours[0], (Rgb8{255, 128, 0}));
  EXPECT_EQ(unit->colours[2], (Rgb8{51, 51, 51}));
  test::write_bytes(dir.path() / "b.xyzrgb", "0 0 0 255 128 0\n1 0 0 0 0 1\n");
  const StatusOr<PointCloud> bytes = read_point_cloud(dir.path() / "b.xyzrgb");
  ASSERT_TRUE(bytes.ok());
  EXPECT_EQ(bytes->colours[0], (Rgb8{255, 128, 0}));
  EXPECT_EQ(bytes->colours[1], (Rgb8{0, 0, 1}));
  test::write_bytes(dir.path() / "c.xyzrgb", "0 0 0 1.5 0 0\n");
  EXPECT_FALSE(read_point_cloud(dir.path() / "c.xyzrgb").ok());
  // The same values in .xyz are normals (the guess), and in .xyzn always.
  test::write_bytes(dir.path() / "n.xyzn", "0 0 0 0 0 1\n1 0 0 0 1 0\n");
  const StatusOr<PointCloud> normals = read_point_cloud(dir.path() / "n.xyzn");
  ASSERT_TRUE(normals.ok());
  EXPECT_TRUE(normals->has_normals());
  EXPECT_FALSE(normals->has_colours());
}

}  // namespace
}  // namespace sspc
