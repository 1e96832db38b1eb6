// Coordinates that float32 cannot hold to the cloud's own detail: the readers warn (in every
// format that stores more than float32), and give the file's own values in double on request.
#include <bit>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "double_cloud_files.hpp"
#include "io/text_scanner.hpp"
#include "io_test_util.hpp"
#include "sspc/io.hpp"
#include "test_util.hpp"

namespace sspc {
namespace {

const Vec3d kFarAway(500000, 4000000, 100);

struct Format {
  const char* file;
  std::string (*encode)(const std::vector<Vec3d>&);
};

const Format kFormats[] = {
    {"points.xyz", [](const std::vector<Vec3d>& p) { return test::xyz_text(p); }},
    {"ascii.ply", [](const std::vector<Vec3d>& p) { return test::ply_double(p, false); }},
    {"binary.ply", [](const std::vector<Vec3d>& p) { return test::ply_double(p, true); }},
    {"ascii.pcd", [](const std::vector<Vec3d>& p) { return test::pcd_double(p, false); }},
    {"binary.pcd", [](const std::vector<Vec3d>& p) { return test::pcd_double(p, true); }},
};

std::vector<std::string> warnings_of(const std::filesystem::path& path) {
  std::vector<std::string> warnings;
  ReadOptions options;
  options.warnings = &warnings;
  const StatusOr<PointCloud> cloud = read_point_cloud(path, options);
  EXPECT_TRUE(cloud.ok()) << cloud.status().to_string();
  return warnings;
}

TEST(PrecisionWarning, FarFromTheOriginInEveryFormatThatStoresDoubles) {
  test::TempDir dir;
  const std::vector<Vec3d> near = test::wavy_patch(30);
  const std::vector<Vec3d> far = test::shifted(near, kFarAway);
  for (const Format& format : kFormats) {
    const auto near_path = dir.path() / (std::string("near-") + format.file);
    const auto far_path = dir.path() / (std::string("far-") + format.file);
    test::write_bytes(near_path, format.encode(near));
    test::write_bytes(far_path, format.encode(far));
    EXPECT_TRUE(warnings_of(near_path).empty()) << format.file;
    const std::vector<std::string> warnings = warnings_of(far_path);
    ASSERT_EQ(warnings.size(), 1u) << format.file;
    const std::string& w = warnings[0];
    // y is the worst axis: steps of 0.25 at 4e6 against a cloud 0.15 across.
    EXPECT_EQ(w.rfind(far_path.string() + ": coordinates reach 4000000.1 on y but the cloud "
                                          "spans only 0.15: float32 keeps steps of 0.25 there",
                      0),
              0u)
        << w;
    EXPECT_NE(w.find("also on x"), std::string::npos) << w;
    EXPECT_NE(w.find("subtract an origin first"), std::string::npos) << w;
  }
}

TEST(PrecisionWarning, NotForFloat32FilesWhichLoseNothingWhenRead) {
  test::TempDir dir;
  PointCloud cloud;
  for (const Vec3d& p : test::shifted(test::wavy_patch(10), kFarAway)) {
    cloud.positions.push_back(p.cast<float>());
  }
  const auto path = dir.path() / "float.ply";
  ASSERT_TRUE(write_ply(cloud, path).ok());
  EXPECT_TRUE(warnings_of(path).empty());
}

TEST(PrecisionWarning, IntegersThatFloat32HoldsExactlyAreFine) {
  test::TempDir dir;
  const auto path = dir.path() / "grid.xyz";
  test::write_bytes(path, "4000000 1 2\n4000001 3 4\n4000002 5 6\n");
  EXPECT_TRUE(warnings_of(path).empty());
}

TEST(PositionsF64, TheFilesOwnValuesIndexForIndex) {
  test::TempDir dir;
  const std::vector<Vec3d> far = test::shifted(test::wavy_patch(12), kFarAway);
  for (const Format& format : kFormats) {
    const auto path = dir.path() / format.file;
    test::write_bytes(path, format.encode(far));
    std::vector<Vec3d> f64 = {Vec3d(1, 2, 3)};  // replaced, not appended to
    std::vector<std::string> warnings;
    ReadOptions options;
    options.positions_f64 = &f64;
    options.warnings = &warnings;
    const StatusOr<PointCloud> cloud = read_point_cloud(path, options);
    ASSERT_TRUE(cloud.ok()) << cloud.status().to_string();
    ASSERT_EQ(f64.size(), far.size()) << format.file;
    EXPECT_TRUE(f64 == far) << format.file;
    for (std::size_t i = 0; i < far.size(); ++i) {
      ASSERT_EQ(cloud->positions[i], far[i].cast<float>()) << format.file << " point " << i;
    }
    // The caller works from the doubles, so float32's loss is not its concern.
    EXPECT_TRUE(warnings.empty()) << format.file;
  }
}

TEST(PositionsF64, Float32FilesGiveTheirFloatsExactly) {
  test::TempDir dir;
  const PointCloud cloud = test::sample_cloud(5, false, false);
  const auto path = dir.path() / "float.ply";
  ASSERT_TRUE(write_ply(cloud, path).ok());
  std::vector<Vec3d> f64;
  ReadOptions options;
  options.positions_f64 = &f64;
  ASSERT_TRUE(read_point_cloud(path, options).ok());
  ASSERT_EQ(f64.size(), cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i)
    EXPECT_EQ(f64[i], cloud.positions[i].cast<double>());
}

// Reading text also in double must not change the floats: one parse of a double, rounded to
// float, is the nearest float except when that double is exactly halfway between two floats.
TEST(ParseFloatAndDouble, GivesTheFloatThatParsingAFloatGives) {
  const char* tokens[] = {
      "1.00000005960464477539062500000001",  // just above 1 + 2^-24: its double is the midpoint
      "1.00000005960464477539062499999999",  // just below
      "1.000000059604644775390625",          // the midpoint itself: ties to even
      "0.1",
      "-0.0",
      "0",
      "4000000.15",
      "16777217",
      "3.4028235e38",
      "3.4028236e38",
      "1e39",
      "1e-40",
      "1e-46",
      "-1.17549435e-38",
      "nan",
      "inf",
      "1e400",
      "abc",
      "+2.5"};
  for (const char* token : tokens) {
    float expected = 0, f = 0;
    double d = 0;
    const bool ok = io::parse_number(token, expected);
    ASSERT_EQ(io::parse_float_and_double(token, f, d), ok) << token;
    if (!ok) continue;
    EXPECT_TRUE(std::bit_cast<std::uint32_t>(f) == std::bit_cast<std::uint32_t>(expected) ||
                (std::isnan(f) && std::isnan(expected)))
        << token << ": " << f << " vs " << expected;
  }
  float f = 0;
  double d = 0;
  ASSERT_TRUE(io::parse_float_and_double("4000000.15", f, d));
  EXPECT_EQ(d, 4000000.15);
  EXPECT_EQ(f, 4000000.25f);
}

}  // namespace
}  // namespace sspc
