// write_las: a LAS file read and written again gives back its point records byte for byte;
// every point format keeps every field; the origin, the CRS and the extra bytes survive; a cloud
// from another format is stored on a grid that float32 returns exactly.
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "double_cloud_files.hpp"
#include "io_test_util.hpp"
#include "las_test_files.hpp"
#include "sspc/io.hpp"
#include "test_util.hpp"

namespace sspc {
namespace {

StatusOr<PointCloud> read_bytes(const std::string& bytes) {
  return read_las(test::bytes_of(bytes), "mem.las");
}

std::uint32_t u32_at(const std::string& bytes, std::size_t at) {
  std::uint32_t v = 0;
  std::memcpy(&v, bytes.data() + at, sizeof v);
  return v;
}

// The point records of a LAS file: from the point data offset to the end.
std::string records_of(const std::string& bytes) {
  return bytes.substr(u32_at(bytes, 96));
}

TEST(LasWriter, PassThroughGivesBackTheSameRecordsByteForByte) {
  for (const int format : {0, 1, 2, 3}) {
    const std::string source = test::hand_las12(format, test::hand_points(200), 0.01, 0, 0, 0);
    const StatusOr<PointCloud> cloud = read_bytes(source);
    ASSERT_TRUE(cloud.ok()) << cloud.status().to_string();
    const StatusOr<std::string> written = encode_las(*cloud);
    ASSERT_TRUE(written.ok()) << written.status().to_string();
    EXPECT_EQ(written->substr(0, 4), "LASF");
    EXPECT_EQ(static_cast<int>((*written)[104]), format);
    EXPECT_TRUE(records_of(*written) == records_of(source)) << "format " << format;
  }
}

TEST(LasWriter, EveryPointFormatKeepsEveryField) {
  const StatusOr<PointCloud> source =
      read_bytes(test::hand_las12(3, test::hand_points(100), 0.01, 10, 20, 30));
  ASSERT_TRUE(source.ok());
  PointCloud cloud = *source;
  cloud.las.nir.assign(cloud.size(), 0);
  for (std::size_t i = 0; i < cloud.size(); ++i) cloud.las.nir[i] = static_cast<std::uint16_t>(i);
  cloud.las.classification[7] = 200;  // needs formats 6-10
  for (const int format : {6, 7, 8}) {
    LasWriteOptions options;
    options.point_format = format;
    const StatusOr<std::string> bytes = encode_las(cloud, options);
    ASSERT_TRUE(bytes.ok()) << bytes.status().to_string();
    EXPECT_EQ(static_cast<int>((*bytes)[25]), 4) << "formats 6-10 are LAS 1.4";
    const StatusOr<PointCloud> back = read_bytes(*bytes);
    ASSERT_TRUE(back.ok()) << back.status().to_string();
    ASSERT_EQ(back->size(), cloud.size());
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      ASSERT_EQ(back->world(i), cloud.world(i)) << i;
    }
    const LasPointAttributes& a = back->las;
    EXPECT_EQ(a.intensity, cloud.las.intensity);
    EXPECT_EQ(a.return_number, cloud.las.return_number);
    EXPECT_EQ(a.number_of_returns, cloud.las.number_of_returns);
    EXPECT_EQ(a.classification, cloud.las.classification);
    // Formats 6-10 store steps of 0.006°, which whole degrees fall between.
    ASSERT_EQ(a.scan_angle.size(), cloud.las.scan_angle.size());
    for (std::size_t i = 0; i < a.scan_angle.size(); ++i) {
      EXPECT_NEAR(a.scan_angle[i], cloud.las.scan_angle[i], 0.003) << i;
    }
    EXPECT_EQ(a.user_data, cloud.las.user_data);
    EXPECT_EQ(a.point_source_id, cloud.las.point_source_id);
    EXPECT_EQ(a.gps_time, cloud.las.gps_time);
    if (format >= 7) {
      EXPECT_EQ(a.rgb, cloud.las.rgb);
    }
    if (format == 8) {
      EXPECT_EQ(a.nir, cloud.las.nir);
    }
    // And written again, the same bytes: nothing drifts.
    const StatusOr<std::string> again = encode_las(*back, options);
    ASSERT_TRUE(again.ok());
    EXPECT_TRUE(records_of(*again) == records_of(*bytes)) << format;
  }
  // Without a format asked for, a class above 31 and NIR choose format 8.
  const StatusOr<std::string> chosen = encode_las(cloud);
  ASSERT_TRUE(chosen.ok());
  EXPECT_EQ(static_cast<int>((*chosen)[104]), 8);
}

TEST(LasWriter, CrsAndExtraBytesSurvive) {
  StatusOr<PointCloud> cloud =
      read_bytes(test::hand_las12(1, test::hand_points(30), 0.01, 0, 0, 0));
  ASSERT_TRUE(cloud.ok());
  cloud->metadata.crs_wkt = "PROJCS[\"NAD83 / Oregon GIC Lambert (ft)\"]";
  cloud->las.extra_bytes_per_point = 3;
  cloud->las.extra_bytes.resize(cloud->size() * 3);
  for (std::size_t i = 0; i < cloud->las.extra_bytes.size(); ++i) {
    cloud->las.extra_bytes[i] = static_cast<std::uint8_t>(i * 7);
  }
  cloud->metadata.extra_bytes_records.push_back({"LASF_Spec", 4, "extra", std::string(192, '\0')});
  const StatusOr<std::string> bytes = encode_las(*cloud);
  ASSERT_TRUE(bytes.ok()) << bytes.status().to_string();
  EXPECT_EQ(static_cast<int>((*bytes)[25]), 4) << "WKT asks for LAS 1.4";
  EXPECT_EQ(static_cast<int>((*bytes)[6]) & 16, 16) << "global encoding: WKT";
  const StatusOr<PointCloud> back = read_bytes(*bytes);
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  EXPECT_EQ(back->metadata.crs_wkt, cloud->metadata.crs_wkt);
  EXPECT_EQ(back->las.extra_bytes, cloud->las.extra_bytes);
  EXPECT_EQ(back->metadata.extra_bytes_records.size(), 1u);
}

// A record longer than a VLR's 65,535 bytes (a WKT2 CRS can be) goes after the points as an
// EVLR of LAS 1.4, and comes back; a 65,535-byte CRS (65,536 with its NUL) likewise.
TEST(LasWriter, LongCrsRecordsBecomeEvlrsAndComeBack) {
  StatusOr<PointCloud> cloud = read_bytes(test::hand_las12(1, test::hand_points(30), 0.01, 0, 0, 0));
  ASSERT_TRUE(cloud.ok());
  for (const std::size_t length : {std::size_t{65534}, std::size_t{65535}, std::size_t{1} << 20}) {
    cloud->metadata.crs_wkt = "PROJCS[\"long\"," + std::string(length - 15, 'x') + "]";
    ASSERT_EQ(cloud->metadata.crs_wkt.size(), length);
    const StatusOr<std::string> bytes = encode_las(*cloud);
    ASSERT_TRUE(bytes.ok()) << bytes.status().to_string();
    EXPECT_EQ(static_cast<int>((*bytes)[25]), 4);
    std::uint32_t evlrs = 0;
    std::memcpy(&evlrs, bytes->data() + 243, 4);
    EXPECT_EQ(evlrs, length >= 65535 ? 1u : 0u) << length;
    const StatusOr<PointCloud> back = read_bytes(*bytes);
    ASSERT_TRUE(back.ok()) << back.status().to_string();
    EXPECT_EQ(back->metadata.crs_wkt, cloud->metadata.crs_wkt) << length;
    ASSERT_EQ(back->size(), cloud->size());
    for (std::size_t i = 0; i < cloud->size(); ++i) ASSERT_EQ(back->world(i), cloud->world(i)) << i;
  }
}

// Every stored scan angle passes through, those outside the specification's ±90° included.
TEST(LasWriter, ScanAnglesAtTheirExtremesPassThrough) {
  StatusOr<PointCloud> cloud = read_bytes(test::hand_las12(1, test::hand_points(6), 0.01, 0, 0, 0));
  ASSERT_TRUE(cloud.ok());
  cloud->las.scan_angle = {-128.0f, 127.0f, -91.0f, 91.0f, 0.0f, 90.0f};
  StatusOr<std::string> bytes = encode_las(*cloud);
  ASSERT_TRUE(bytes.ok());
  StatusOr<PointCloud> back = read_bytes(*bytes);
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(back->las.scan_angle, cloud->las.scan_angle);
  // Formats 6-10: steps of 0.006°, the int16's whole range.
  LasWriteOptions six;
  six.point_format = 6;
  cloud->las.scan_angle = {-32768 * 0.006f, 32767 * 0.006f, -30001 * 0.006f, 30001 * 0.006f, 0.0f, 0.006f};
  bytes = encode_las(*cloud, six);
  ASSERT_TRUE(bytes.ok());
  back = read_bytes(*bytes);
  ASSERT_TRUE(back.ok());
  const StatusOr<std::string> again = encode_las(*back, six);
  ASSERT_TRUE(again.ok());
  EXPECT_TRUE(records_of(*again) == records_of(*bytes));
  for (std::size_t i = 0; i < 6; ++i) {
    std::int16_t stored = 0;
    std::memcpy(&stored, records_of(*bytes).data() + 30 * i + 18, 2);
    EXPECT_EQ(stored, static_cast<std::int16_t>(std::lround(cloud->las.scan_angle[i] / 0.006f))) << i;
  }
}

// A source grid that cannot hold the cloud (a decode spans a little more than its source; a
// scale of 1e-30 spans 2e-21 units) gives way to the writer's own, rather than no file.
TEST(LasWriter, ASourceScaleTooFineForTheCloudGivesWay) {
  StatusOr<PointCloud> cloud = read_bytes(test::hand_las12(1, test::hand_points(30), 0.01, 0, 0, 0));
  ASSERT_TRUE(cloud.ok());
  cloud->metadata.las->scale = Vec3d::Constant(1e-30);
  const StatusOr<std::string> bytes = encode_las(*cloud);
  ASSERT_TRUE(bytes.ok()) << bytes.status().to_string();
  const StatusOr<PointCloud> back = read_bytes(*bytes);
  ASSERT_TRUE(back.ok());
  for (std::size_t i = 0; i < cloud->size(); ++i) {
    EXPECT_LT((back->world(i) - cloud->world(i)).norm(), 1e-5) << i;
  }
  // An explicit scale is kept, and its refusal reads as a number.
  LasWriteOptions fine;
  fine.scale = Vec3d::Constant(1e-30);
  const StatusOr<std::string> refused = encode_las(*cloud, fine);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("at scale 1e-30"), std::string::npos) << refused.status().message();
}

TEST(LasWriter, CloudsFromOtherFormatsComeBackFromTheirOwnGrid) {
  // Georeferenced: a double PLY at (500000, 4500000, 100), read with an origin.
  test::TempDir dir;
  const std::vector<Vec3d> far = test::shifted(test::wavy_patch(20), Vec3d(500000, 4500000, 100));
  test::write_bytes(dir.path() / "far.ply", test::ply_double(far, true));
  const StatusOr<PointCloud> cloud = read_point_cloud(dir.path() / "far.ply");
  ASSERT_TRUE(cloud.ok());
  ASSERT_NE(cloud->origin, Vec3d::Zero());
  const auto path = dir.path() / "far.las";
  ASSERT_TRUE(write_point_cloud(*cloud, path).ok());
  const StatusOr<PointCloud> back = read_point_cloud(path);
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  const double scale = back->metadata.las->scale.x();
  EXPECT_LE(scale, 0.15 / (1 << 20)) << "the grid is as fine as float32's detail";
  for (std::size_t i = 0; i < far.size(); ++i) {
    EXPECT_LE((back->world(i) - cloud->world(i)).cwiseAbs().maxCoeff(), scale) << i;
  }
  // A second pass is exact: the cloud is on the grid now.
  const auto path2 = dir.path() / "far2.las";
  ASSERT_TRUE(write_point_cloud(*back, path2).ok());
  const StatusOr<PointCloud> back2 = read_point_cloud(path2);
  ASSERT_TRUE(back2.ok());
  for (std::size_t i = 0; i < far.size(); ++i) ASSERT_EQ(back2->world(i), back->world(i)) << i;
}

TEST(WritePointCloud, RefusesExtensionsItDoesNotWrite) {
  test::TempDir dir;
  PointCloud cloud;
  cloud.positions.emplace_back(1, 2, 3);
  const Status s = write_point_cloud(cloud, dir.path() / "out.laz");
  EXPECT_EQ(s.code(), StatusCode::kUnsupported);
  EXPECT_NE(s.to_string().find("out.las"), std::string::npos) << s.to_string();
}

}  // namespace
}  // namespace sspc
