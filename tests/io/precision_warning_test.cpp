// Coordinates that float32 cannot hold to the cloud's own detail: the readers give the cloud an
// origin (in every format that stores more than float32), so that every local position is within
// half a float32 step of the file's value minus the origin, and give the file's own values in
// double on request.
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

// Half of float32's step at `v`: the most that narrowing a double to float32 moves it.
double half_float_step(double v) {
  const auto f = static_cast<float>(std::abs(v));
  return (double{std::nextafter(f, INFINITY)} - double{f}) / 2;
}

TEST(PrecisionOrigin, FarFromZeroGetsAnOriginInEveryFormatThatStoresDoubles) {
  test::TempDir dir;
  const std::vector<Vec3d> near = test::wavy_patch(30);
  const std::vector<Vec3d> far = test::shifted(near, kFarAway);
  for (const Format& format : kFormats) {
    const auto near_path = dir.path() / (std::string("near-") + format.file);
    const auto far_path = dir.path() / (std::string("far-") + format.file);
    test::write_bytes(near_path, format.encode(near));
    test::write_bytes(far_path, format.encode(far));
    EXPECT_TRUE(warnings_of(near_path).empty()) << format.file;
    EXPECT_TRUE(warnings_of(far_path).empty()) << format.file;
    const StatusOr<PointCloud> n = read_point_cloud(near_path);
    const StatusOr<PointCloud> f = read_point_cloud(far_path);
    ASSERT_TRUE(n.ok() && f.ok()) << format.file;
    EXPECT_EQ(n->origin, Vec3d::Zero()) << format.file;
    // The centre rounded to a tenth (the cloud spans 0.15): a number a person can read.
    EXPECT_EQ(f->origin, Vec3d(500000, 4000000, 100)) << format.file;
    for (std::size_t i = 0; i < far.size(); ++i) {
      const Vec3d local = far[i] - f->origin;
      for (int k = 0; k < 3; ++k) {
        ASSERT_LE(std::abs(double{f->positions[i][k]} - local[k]), half_float_step(local[k]))
            << format.file << " point " << i;
      }
    }
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
      ASSERT_EQ(cloud->positions[i], (far[i] - cloud->origin).cast<float>())
          << format.file << " point " << i;
    }
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
