// A model keeps where it lies in the world: the origin, the LAS grid, the CRS and comments go
// through the container's metadata part (docs/FORMAT.md, "Metadata"), which a corrupt file
// cannot turn into a crash; and the codec's error is the same wherever the cloud lies, because
// it codes local positions.
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/format_number.hpp"
#include "double_cloud_files.hpp"
#include "encoder/container_writer.hpp"
#include "format/container_test_models.hpp"
#include "format/metadata_section.hpp"
#include "sspc/compressed_model.hpp"
#include "sspc/encoder.hpp"
#include "sspc/io.hpp"
#include "sspc/metrics.hpp"
#include "test_util.hpp"

namespace sspc {
namespace {

codec::EncodedModel model_with_metadata() {
  codec::EncodedModel m = test::make_plane_model({});
  m.metadata.origin = Vec3d(500000.25, 4500000.5, 100);
  m.metadata.cloud.comments = {"first", "second comment"};
  m.metadata.cloud.crs_wkt = "PROJCRS[\"ETRS89 / UTM zone 32N\"]";
  m.metadata.cloud.crs_records.push_back({"LASF_Projection", 34735, "", std::string(8, '\3')});
  LasSource las;
  las.point_format = 6;
  las.scale = Vec3d(0.01, 0.01, 0.001);
  las.offset = Vec3d(500000, 4500000, 0);
  las.global_encoding = 1;
  las.file_source_id = 9;
  m.metadata.cloud.las = las;
  return m;
}

std::string encode_or_die(const codec::EncodedModel& m) {
  StatusOr<std::string> bytes = codec::encode_container(m, {});
  EXPECT_TRUE(bytes.ok()) << bytes.status().to_string();
  return bytes.ok() ? *bytes : std::string();
}

TEST(Georeference, MetadataRoundTripsAndDecodedCloudsCarryTheOrigin) {
  const codec::EncodedModel m = model_with_metadata();
  auto model = CompressedModel::from_bytes(encode_or_die(m));
  ASSERT_TRUE(model.ok()) << model.status().to_string();
  EXPECT_EQ(model->origin(), m.metadata.origin);
  EXPECT_EQ(model->metadata().comments, m.metadata.cloud.comments);
  EXPECT_EQ(model->metadata().crs_wkt, m.metadata.cloud.crs_wkt);
  ASSERT_EQ(model->metadata().crs_records.size(), 1u);
  EXPECT_EQ(model->metadata().crs_records[0].data, m.metadata.cloud.crs_records[0].data);
  ASSERT_TRUE(model->metadata().las.has_value());
  EXPECT_EQ(model->metadata().las->scale, m.metadata.cloud.las->scale);
  EXPECT_EQ(model->metadata().las->offset, m.metadata.cloud.las->offset);
  EXPECT_EQ(model->metadata().las->point_format, 6);
  const StatusOr<PointCloud> all = model->decode_all();
  ASSERT_TRUE(all.ok());
  EXPECT_EQ(all->origin, m.metadata.origin);
  const StatusOr<PointCloud> one = model->decode_patch(0);
  ASSERT_TRUE(one.ok());
  EXPECT_EQ(one->origin, m.metadata.origin);
}

TEST(Georeference, AFileWithoutMetadataIsUnchangedAndHasOriginZero) {
  codec::EncodedModel m = test::make_plane_model({});
  const std::string plain = encode_or_die(m);
  auto model = CompressedModel::from_bytes(plain);
  ASSERT_TRUE(model.ok());
  EXPECT_EQ(model->origin(), Vec3d::Zero());
  // The flag and the part appear together: the same model with metadata is the plain file plus
  // the part, and a different flags field.
  const std::string with = encode_or_die(model_with_metadata());
  EXPECT_GT(with.size(), plain.size());
  EXPECT_EQ(static_cast<int>(plain[10]) & 4, 0);
  EXPECT_EQ(static_cast<int>(with[10]) & 4, 4);
}

TEST(Georeference, EveryTruncationOrBitFlipOfTheMetadataIsAnError) {
  const std::string plain = encode_or_die(test::make_plane_model({}));
  const std::string bytes = encode_or_die(model_with_metadata());
  // Cut anywhere inside the part: the sections still end where they did, the part does not.
  for (std::size_t n = plain.size(); n < bytes.size(); ++n) {
    auto model = CompressedModel::from_bytes(bytes.substr(0, n));
    ASSERT_FALSE(model.ok()) << n;
    EXPECT_EQ(model.status().code(), StatusCode::kCorrupt) << n;
  }
  // Any flipped bit fails the CRC (or the size); one more byte is trailing.
  for (std::size_t at = plain.size(); at < bytes.size(); ++at) {
    std::string bad = bytes;
    bad[at] = static_cast<char>(bad[at] ^ 0x10);
    ASSERT_FALSE(CompressedModel::from_bytes(bad).ok()) << at;
  }
  EXPECT_FALSE(CompressedModel::from_bytes(bytes + std::string(1, '\0')).ok());
}

// An origin past kMaxCoordinate verified and then failed every box query (its world to local
// conversion leaves float's range): the reader refuses it, naming the value, and the writer does
// not write it.
TEST(Georeference, AnOriginBeyondTheCoordinateLimitIsRefused) {
  for (const double far : {1e308, -1e308, 2e18}) {
    codec::ModelMetadata metadata;
    metadata.origin = Vec3d(0, far, 0);
    const std::string part = codec::encode_metadata(metadata);
    const auto decoded = codec::decode_metadata(std::as_bytes(std::span(part.data(), part.size())), 100, "far.sspc");
    ASSERT_FALSE(decoded.ok()) << far;
    EXPECT_EQ(decoded.status().code(), StatusCode::kCorrupt);
    EXPECT_NE(decoded.status().message().find("origin (0, " + format_number(far) + ", 0) beyond +-1e18"),
              std::string::npos)
        << decoded.status().message();
    codec::EncodedModel m = test::make_plane_model({});
    m.metadata.origin = metadata.origin;
    EXPECT_FALSE(codec::encode_container(m, {}).ok()) << far;
  }
  codec::ModelMetadata near;
  near.origin = Vec3d(1e18, -1e18, 6.4e6);
  const std::string part = codec::encode_metadata(near);
  EXPECT_TRUE(codec::decode_metadata(std::as_bytes(std::span(part.data(), part.size())), 100, "near.sspc").ok());
}

// The bunny scaled to 150 m, as a double PLY at (0, 0, 0) and at (500000, 4500000, 100).
StatusOr<PointCloud> bunny_at(const test::TempDir& dir, const Vec3d& where, const char* name) {
  StatusOr<PointCloud> bunny = read_point_cloud(std::string(SSPC_SOURCE_DIR) + "/data/bunny.ply");
  if (!bunny.ok()) return bunny.status();
  std::vector<Vec3d> points;
  for (const Vec3f& p : bunny->positions) points.push_back(p.cast<double>() * 1000.0 + where);
  test::write_bytes(dir.path() / name, test::ply_double(points, true));
  return read_point_cloud(dir.path() / name);
}

TEST(Georeference, TheCodecsErrorIsTheSameAtZeroAndFarAway) {
  test::TempDir dir;
  double rms[2] = {0, 0};
  const Vec3d places[2] = {Vec3d::Zero(), Vec3d(500000, 4500000, 100)};
  for (int i = 0; i < 2; ++i) {
    const StatusOr<PointCloud> source = bunny_at(dir, places[i], i == 0 ? "zero.ply" : "far.ply");
    ASSERT_TRUE(source.ok()) << source.status().to_string();
    const auto sspc = dir.path() / (i == 0 ? "zero.sspc" : "far.sspc");
    ASSERT_TRUE(encode(*source, sspc).ok());
    auto model = CompressedModel::open(sspc);
    ASSERT_TRUE(model.ok());
    EXPECT_EQ(model->origin(), source->origin);
    const StatusOr<PointCloud> decoded = model->decode_all();
    ASSERT_TRUE(decoded.ok());
    // Both in the frame of the same origin: the local values compare as they are.
    const StatusOr<EvalReport> report = evaluate(*source, *decoded);
    ASSERT_TRUE(report.ok());
    rms[i] = report->rms_max;
  }
  EXPECT_GT(rms[0], 0);
  EXPECT_NEAR(rms[1], rms[0], 0.05 * rms[0]) << "at zero " << rms[0] << ", far " << rms[1];
}

}  // namespace
}  // namespace sspc
