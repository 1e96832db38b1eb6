// LAS as a user meets it: sspc convert both ways, info on a LAS file, decode to LAS, encode's
// warning for the fields it drops, LAZ refused by name; and a georeferenced cloud that comes back
// from a pass-through to the millimetre.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "cli_util.hpp"
#include "double_cloud_files.hpp"
#include "sspc/io.hpp"
#include "sspc/neighbours.hpp"
#include "test_util.hpp"

namespace sspc {
namespace {

TEST(CliLas, ConvertInfoEncodeDecode) {
  test::TempDir dir;
  const std::string las = (dir.path() / "bunny.las").string();
  const CliRun to_las = sspc(dir, "convert --json " + bunny() + " " + las);
  ASSERT_EQ(to_las.exit_code, 0) << to_las.err;
  EXPECT_NE(to_las.out.find("\"points\":34834"), std::string::npos) << to_las.out;
  const CliRun again = sspc(dir, "convert " + bunny() + " " + las);
  EXPECT_EQ(again.exit_code, 1) << "an existing output needs --force";
  const CliRun info = sspc(dir, "info " + las);
  ASSERT_EQ(info.exit_code, 0) << info.err;
  EXPECT_NE(info.out.find("las         version 1.2, point format 0"), std::string::npos)
      << info.out;
  EXPECT_NE(info.out.find("las scale   1e-07"), std::string::npos) << info.out;
  const CliRun json = sspc(dir, "info --json " + las);
  EXPECT_NE(json.out.find("\"las_point_format\":0"), std::string::npos) << json.out;

  const std::string model = (dir.path() / "b.sspc").string();
  const CliRun encode = sspc(dir, "encode -q " + las + " " + model);
  ASSERT_EQ(encode.exit_code, 0) << encode.err;
  const std::string out_las = (dir.path() / "out.las").string();
  const CliRun decode = sspc(dir, "decode " + model + " " + out_las);
  ASSERT_EQ(decode.exit_code, 0) << decode.err;
  const StatusOr<PointCloud> decoded = read_point_cloud(out_las);
  ASSERT_TRUE(decoded.ok()) << decoded.status().to_string();
  ASSERT_TRUE(decoded->metadata.las.has_value());
  EXPECT_EQ(decoded->metadata.las->scale, Vec3d::Constant(1e-7)) << "the source's grid";

  const CliRun bad = sspc(dir, "convert " + las + " " + (dir.path() / "x.e57").string());
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.err.find("sspc writes .ply and .las"), std::string::npos) << bad.err;
  const CliRun help = sspc(dir, "convert --help");
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.out.find("--force"), std::string::npos) << help.out;
}

TEST(CliLas, DroppedFieldsAreNamedAndLazIsRefusedWithTheWayOut) {
  test::TempDir dir;
  PointCloud cloud;
  for (int i = 0; i < 64; ++i) {
    cloud.positions.emplace_back(float(i % 8), float(i / 8), 0.01f * float(i % 3));
    cloud.las.intensity.push_back(static_cast<std::uint16_t>(100 + i));
    cloud.las.classification.push_back(2);
  }
  const auto las = dir.path() / "in.las";
  ASSERT_TRUE(write_las(cloud, las).ok());
  const CliRun ply = sspc(dir, "convert " + las.string() + " " + (dir.path() / "o.ply").string());
  ASSERT_EQ(ply.exit_code, 0) << ply.err;
  EXPECT_NE(ply.err.find("dropped intensity, classification"), std::string::npos) << ply.err;
  // encode keeps them (per point, FORMAT.md "Attributes") unless told not to, and then names them.
  const CliRun encode =
      sspc(dir, "encode -q " + las.string() + " " + (dir.path() / "o.sspc").string());
  ASSERT_EQ(encode.exit_code, 0) << encode.err;
  EXPECT_EQ(encode.err.find("not kept"), std::string::npos) << encode.err;
  const CliRun none = sspc(dir, "encode -q --attributes none " + las.string() + " " +
                                    (dir.path() / "n.sspc").string());
  EXPECT_NE(none.err.find("not kept in the .sspc model: intensity, classification"),
            std::string::npos)
      << none.err;
  const CliRun decode = sspc(dir, "decode -q " + (dir.path() / "o.sspc").string() + " " +
                                      (dir.path() / "back.las").string());
  ASSERT_EQ(decode.exit_code, 0) << decode.err;
  StatusOr<PointCloud> back = read_point_cloud(dir.path() / "back.las");
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  ASSERT_EQ(back->las.intensity.size(), back->size());
  ASSERT_EQ(back->las.classification.size(), back->size());
  const KdTree3 tree(cloud.positions);
  for (std::size_t i = 0; i < back->size(); ++i) {
    float d2 = 0;
    const std::uint32_t s = tree.nearest(back->positions[i], &d2);
    EXPECT_EQ(back->las.intensity[i], cloud.las.intensity[s]) << i;
    EXPECT_EQ(back->las.classification[i], cloud.las.classification[s]) << i;
  }

  // A decode names what its output cannot hold: PLY has no property for intensity or
  // classification, and --overlap decodes positions only (LAS would write 0 for each field).
  const std::string model = (dir.path() / "o.sspc").string();
  const CliRun to_ply = sspc(dir, "decode -q " + model + " " + (dir.path() / "back.ply").string());
  ASSERT_EQ(to_ply.exit_code, 0) << to_ply.err;
  EXPECT_NE(to_ply.err.find("back.ply: PLY output keeps positions and colours; dropped intensity, classification"),
            std::string::npos)
      << to_ply.err;
  const CliRun to_stdout = sspc(dir, "decode -q " + model + " - --format ply");
  EXPECT_NE(to_stdout.err.find("stdout: PLY output keeps positions and colours; dropped intensity"), std::string::npos)
      << to_stdout.err;
  const CliRun overlap = sspc(dir, "decode -q --overlap " + model + " " + (dir.path() / "o.las").string());
  ASSERT_EQ(overlap.exit_code, 0) << overlap.err;
  EXPECT_NE(overlap.err.find("--overlap decodes positions only (LAS writes 0 for each); dropped intensity, classification"),
            std::string::npos)
      << overlap.err;
  const CliRun plain = sspc(dir, "decode -q " + (dir.path() / "n.sspc").string() + " " + (dir.path() / "n.ply").string());
  EXPECT_EQ(plain.err.find("dropped"), std::string::npos) << "nothing kept, nothing to name: " << plain.err;

  std::string bytes = slurp(las);
  bytes[104] = static_cast<char>(bytes[104] | 0x80);  // LASzip's compressed bit
  test::write_bytes(dir.path() / "in.laz", bytes);
  const CliRun laz = sspc(dir, "info " + (dir.path() / "in.laz").string());
  EXPECT_EQ(laz.exit_code, 1);
  EXPECT_NE(laz.err.find("LAZ (LASzip-compressed LAS) is not supported"), std::string::npos)
      << laz.err;
  EXPECT_NE(laz.err.find("laszip -i in.laz -o out.las"), std::string::npos) << laz.err;
}

TEST(CliLas, PlyCommentsAndTheCrsSurviveEncodeAndDecode) {
  test::TempDir dir;
  StatusOr<PointCloud> cloud = read_point_cloud(bunny());
  ASSERT_TRUE(cloud.ok());
  ASSERT_FALSE(cloud->metadata.comments.empty());
  cloud->metadata.crs_wkt = "LOCAL_CS[\"bunny\"]";
  const auto in = dir.path() / "in.ply";
  ASSERT_TRUE(write_ply(*cloud, in).ok());
  const std::string model = (dir.path() / "m.sspc").string();
  ASSERT_EQ(sspc(dir, "encode -q " + in.string() + " " + model).exit_code, 0);
  const auto out = dir.path() / "out.ply";
  ASSERT_EQ(sspc(dir, "decode " + model + " " + out.string()).exit_code, 0);
  const StatusOr<PointCloud> decoded = read_point_cloud(out);
  ASSERT_TRUE(decoded.ok());
  const std::vector<std::string>& c = decoded->metadata.comments;
  ASSERT_EQ(c.size(), cloud->metadata.comments.size() + 1) << "and decode's own";
  EXPECT_TRUE(
      std::equal(cloud->metadata.comments.begin(), cloud->metadata.comments.end(), c.begin()));
  EXPECT_EQ(decoded->metadata.crs_wkt, cloud->metadata.crs_wkt);
}

// The case: the bunny scaled to 150 m at (500000, 4500000) came back 0.25 m off from a
// pass-through `sspc normals` when positions were float32 without an origin.
TEST(CliLas, AGeoreferencedPassThroughComesBackToTheMillimetre) {
  test::TempDir dir;
  const StatusOr<PointCloud> bunny_cloud = read_point_cloud(bunny());
  ASSERT_TRUE(bunny_cloud.ok());
  std::vector<Vec3d> far;
  for (const Vec3f& p : bunny_cloud->positions) {
    far.push_back(p.cast<double>() * 1000.0 + Vec3d(500000, 4500000, 0));
  }
  const auto in = dir.path() / "far.ply";
  test::write_bytes(in, test::ply_double(far, true));
  const auto out = dir.path() / "far_normals.ply";
  const CliRun normals = sspc(dir, "normals " + in.string() + " " + out.string());
  ASSERT_EQ(normals.exit_code, 0) << normals.err;
  std::vector<Vec3d> back;
  ReadOptions options;
  options.positions_f64 = &back;
  ASSERT_TRUE(read_point_cloud(out, options).ok());
  ASSERT_EQ(back.size(), far.size());
  double worst = 0;
  for (std::size_t i = 0; i < far.size(); ++i) {
    worst = std::max(worst, (back[i] - far[i]).cwiseAbs().maxCoeff());
  }
  EXPECT_LT(worst, 1e-5) << "metres";
}

}  // namespace
}  // namespace sspc
