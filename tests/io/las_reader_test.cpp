// read_las against files built byte by byte (las_test_files.hpp): the fields of point formats 1
// and 3, exact integers far from zero, the CRS records, and hostile headers: truncation at every
// length, LAZ and COPC, records that run past their bounds.
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "double_cloud_files.hpp"
#include "io/reader_common.hpp"
#include "io_test_util.hpp"
#include "las_test_files.hpp"
#include "sspc/io.hpp"
#include "test_util.hpp"

namespace sspc {
namespace {

constexpr double kScale = 0.01;

// The integer a LAS writer with the file's scale and offset would store for point i.
std::int64_t stored_integer(const PointCloud& cloud, std::size_t i, int axis, double offset) {
  return std::llround((cloud.origin[axis] - offset) / kScale +
                      double{cloud.positions[i][axis]} / kScale);
}

TEST(LasReader, HandBuiltFormats1And3KeepEveryFieldAndEveryInteger) {
  const std::vector<test::HandLasPoint> points = test::hand_points(50);
  for (const int format : {1, 3}) {
    const std::string bytes = test::hand_las12(format, points, kScale, 0, 0, 0);
    const StatusOr<PointCloud> cloud = read_las(test::bytes_of(bytes), "hand.las");
    ASSERT_TRUE(cloud.ok()) << cloud.status().to_string();
    ASSERT_EQ(cloud->size(), points.size());
    // Far from zero: an origin, on a round number.
    EXPECT_NE(cloud->origin, Vec3d::Zero());
    ASSERT_TRUE(cloud->metadata.las.has_value());
    EXPECT_EQ(cloud->metadata.las->point_format, format);
    EXPECT_EQ(cloud->metadata.las->version_minor, 2);
    EXPECT_EQ(cloud->metadata.las->scale, Vec3d::Constant(kScale));
    const LasPointAttributes& a = cloud->las;
    for (std::size_t i = 0; i < points.size(); ++i) {
      const test::HandLasPoint& p = points[i];
      ASSERT_EQ(stored_integer(*cloud, i, 0, 0), p.x) << i;
      ASSERT_EQ(stored_integer(*cloud, i, 1, 0), p.y) << i;
      ASSERT_EQ(stored_integer(*cloud, i, 2, 0), p.z) << i;
      EXPECT_EQ(a.intensity[i], p.intensity);
      EXPECT_EQ(a.return_number[i], p.return_number);
      EXPECT_EQ(a.number_of_returns[i], p.number_of_returns);
      EXPECT_EQ(a.classification[i], p.classification);
      EXPECT_EQ(a.scan_angle[i], static_cast<float>(p.scan_angle));
      EXPECT_EQ(a.user_data[i], p.user_data);
      EXPECT_EQ(a.point_source_id[i], p.point_source_id);
      EXPECT_EQ(a.gps_time[i], p.gps_time);
    }
    if (format == 3) {
      ASSERT_EQ(a.rgb.size(), points.size());
      EXPECT_EQ(a.rgb[5][0], points[5].r);
      // 16-bit colours give the cloud their high bytes.
      EXPECT_EQ(cloud->colours[5], (Rgb8{5, static_cast<std::uint8_t>((65535 - 500) >> 8), 16}));
    } else {
      EXPECT_TRUE(a.rgb.empty());
      EXPECT_FALSE(cloud->has_colours());
    }
  }
}

TEST(LasReader, NearZeroNeedsNoOrigin) {
  std::vector<test::HandLasPoint> points = test::hand_points(20);
  for (auto& p : points) p.x -= 50000000, p.y -= 450000000;
  const std::string bytes = test::hand_las12(0, points, kScale, 0, 0, 0);
  const StatusOr<PointCloud> cloud = read_las(test::bytes_of(bytes), "near.las");
  ASSERT_TRUE(cloud.ok()) << cloud.status().to_string();
  EXPECT_EQ(cloud->origin, Vec3d::Zero());
  EXPECT_EQ(cloud->positions[3].x(), static_cast<float>(points[3].x * kScale));
}

TEST(LasReader, KeepsTheCrsAndNamesTheRecordsItDrops) {
  const std::vector<test::HandVlr> vlrs = {
      {"LASF_Projection", 34735, std::string("\x01\x00\x01\x00\x00\x00\x01\x00", 8)},
      {"LASF_Projection", 2112, std::string("PROJCS[\"WGS 84 / UTM zone 10N\"]") + '\0'},
      {"LASF_Spec", 3, "a text area"},
  };
  const std::string bytes = test::hand_las12(1, test::hand_points(10), kScale, 0, 0, 0, vlrs);
  test::TempDir dir;
  const auto path = dir.path() / "crs.dat";  // no extension: sniffed by its signature
  test::write_bytes(path, bytes);
  std::vector<std::string> warnings;
  ReadOptions options;
  options.warnings = &warnings;
  const StatusOr<PointCloud> cloud = read_point_cloud(path, options);
  ASSERT_TRUE(cloud.ok()) << cloud.status().to_string();
  EXPECT_EQ(cloud->metadata.crs_wkt, "PROJCS[\"WGS 84 / UTM zone 10N\"]");
  ASSERT_EQ(cloud->metadata.crs_records.size(), 1u);
  EXPECT_EQ(cloud->metadata.crs_records[0].record_id, 34735);
  EXPECT_EQ(cloud->metadata.crs_records[0].data, vlrs[0].data);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("'LASF_Spec' 3"), std::string::npos) << warnings[0];
}

TEST(LasReader, EveryTruncationIsAnErrorNamingTheFile) {
  const std::vector<test::HandVlr> vlrs = {{"LASF_Projection", 34735, std::string(16, '\1')}};
  const std::string bytes = test::hand_las12(3, test::hand_points(3), kScale, 0, 0, 0, vlrs);
  for (std::size_t n = 0; n < bytes.size(); ++n) {
    const StatusOr<PointCloud> cloud = read_las(test::bytes_of(bytes.substr(0, n)), "cut.las");
    ASSERT_FALSE(cloud.ok()) << n;
    const std::string message = cloud.status().to_string();
    ASSERT_NE(message.find("cut.las: "), std::string::npos) << message;
    // Past the signature every refusal says where.
    if (n >= 4) {
      ASSERT_NE(message.find("byte offset "), std::string::npos) << n << message;
    }
  }
}

std::string with_byte(std::string bytes, std::size_t at, std::uint8_t value) {
  bytes[at] = static_cast<char>(value);
  return bytes;
}

TEST(LasReader, RefusesLazAndCopcByNameWithTheWayOut) {
  const std::string las = test::hand_las12(1, test::hand_points(4), kScale, 0, 0, 0);
  const auto refusal = [](const std::string& bytes) {
    const StatusOr<PointCloud> cloud = read_las(test::bytes_of(bytes), "in.laz");
    EXPECT_EQ(cloud.status().code(), StatusCode::kUnsupported);
    return cloud.status().to_string();
  };
  // The compressed bit of the point format (LASzip sets bit 7).
  const std::string laz = refusal(with_byte(las, 104, 0x81));
  EXPECT_NE(laz.find("LAZ"), std::string::npos) << laz;
  EXPECT_NE(laz.find("pdal translate in.laz out.las"), std::string::npos) << laz;
  EXPECT_NE(laz.find("laszip -i in.laz -o out.las"), std::string::npos) << laz;
  // LASzip's record, even with the bit clear.
  const std::string zip = refusal(
      test::hand_las12(1, test::hand_points(4), kScale, 0, 0, 0, {{"laszip encoded", 22204, "x"}}));
  EXPECT_NE(zip.find("LAZ"), std::string::npos) << zip;
  const std::string copc =
      refusal(test::hand_las12(1, test::hand_points(4), kScale, 0, 0, 0, {{"copc", 1, "info"}}));
  EXPECT_NE(copc.find("COPC"), std::string::npos) << copc;
}

TEST(LasReader, RefusesHeadersThatDoNotAddUp) {
  const std::string las = test::hand_las12(0, test::hand_points(4), kScale, 0, 0, 0);
  const auto message = [](const std::string& bytes) {
    const StatusOr<PointCloud> cloud = read_las(test::bytes_of(bytes), "bad.las");
    EXPECT_FALSE(cloud.ok());
    return cloud.status().to_string();
  };
  EXPECT_NE(message(with_byte(las, 105, 19))
                .find("point record length 19 is less than point format 0's 20"),
            std::string::npos);
  EXPECT_NE(message(with_byte(las, 104, 11)).find("point data record format 11"),
            std::string::npos);
  EXPECT_NE(message(with_byte(las, 25, 5)).find("LAS version 1.5"), std::string::npos);
  EXPECT_NE(message(with_byte(las, 107, 5)).find("promises 5 points"), std::string::npos);
  EXPECT_NE(message(with_byte(las, 100, 1)).find("starts past the point data offset"),
            std::string::npos);
  std::string zero_scale = las;
  for (int b = 0; b < 8; ++b) zero_scale[131 + static_cast<std::size_t>(b)] = 0;
  EXPECT_NE(message(zero_scale).find("scale factor is zero"), std::string::npos);
  // Found by the fuzzer: a scale among float's subnormals cannot give the integers back.
  std::string tiny_scale = las;
  const double tiny = 1e-287;
  std::memcpy(tiny_scale.data() + 131, &tiny, sizeof tiny);
  EXPECT_NE(message(tiny_scale).find("scale factor 1e-287 is outside 1e-30 to 1e30"), std::string::npos)
      << "six digits, not std::to_string's 0.000000";
  // A header that counts fewer points than the file holds: reading it would drop the rest.
  EXPECT_NE(message(with_byte(las, 107, 3)).find("the header counts 3 points, but the point data holds 4 records"),
            std::string::npos)
      << message(with_byte(las, 107, 3));
  // Fewer bytes than a record after the last one are not a record (padding is read as before).
  EXPECT_TRUE(read_las(test::bytes_of(las + std::string(7, '\0')), "padded.las").ok());
}

}  // namespace
}  // namespace sspc
