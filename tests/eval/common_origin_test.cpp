// sspc eval on clouds far from the origin: both files' own values, in double, about one common
// origin, give the PSNR of the same clouds near the origin (docs/METRICS.md, "Coordinates far
// from the origin").
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "double_cloud_files.hpp"
#include "sspc/io.hpp"
#include "sspc/metrics.hpp"
#include "test_util.hpp"

namespace sspc {
namespace {

struct Pair {
  PointCloud ref, test;
  std::vector<Vec3d> ref_f64, test_f64;
  std::vector<std::string> warnings;  // what reading them for anything but eval would say
};

Pair read_pair(const std::filesystem::path& ref_path, const std::filesystem::path& test_path) {
  Pair p;
  ReadOptions options;
  options.positions_f64 = &p.ref_f64;
  p.ref = read_point_cloud(ref_path, options).value();
  options.positions_f64 = &p.test_f64;
  p.test = read_point_cloud(test_path, options).value();
  ReadOptions plain;
  plain.warnings = &p.warnings;
  EXPECT_TRUE(read_point_cloud(ref_path, plain).ok());
  EXPECT_TRUE(read_point_cloud(test_path, plain).ok());
  return p;
}

EvalReport evaluate_about_common_origin(Pair& p) {
  const StatusOr<Vec3d> origin = move_to_common_origin(p.ref, p.ref_f64, p.test, p.test_f64);
  EXPECT_TRUE(origin.ok()) << origin.status().to_string();
  const StatusOr<EvalReport> report = evaluate(p.ref, p.test);
  EXPECT_TRUE(report.ok()) << report.status().to_string();
  return *report;
}

// The bunny-sized patch moved by (500000, 4000000, 100): about a common origin in double it has
// the near cloud's PSNR (read as float32 without an origin, y would collapse to a couple of
// values and the error drown in rounding).
TEST(CommonOrigin, FarCloudsEvaluateLikeTheSameCloudsNearTheOrigin) {
  test::TempDir dir;
  const std::vector<Vec3d> ref = test::wavy_patch(40);
  const std::vector<Vec3d> decoded = test::perturbed(ref, 2e-4);
  const Vec3d far(500000, 4000000, 100);
  const struct {
    const char* ext;
    std::string (*encode)(const std::vector<Vec3d>&);
  } formats[] = {
      {".xyz", [](const std::vector<Vec3d>& p) { return test::xyz_text(p); }},
      {".ply", [](const std::vector<Vec3d>& p) { return test::ply_double(p, true); }},
  };
  for (const auto& format : formats) {
    const auto path = [&](const char* stem) {
      return dir.path() / (stem + std::string(format.ext));
    };
    test::write_bytes(path("near_ref"), format.encode(ref));
    test::write_bytes(path("near_test"), format.encode(decoded));
    test::write_bytes(path("far_ref"), format.encode(test::shifted(ref, far)));
    test::write_bytes(path("far_test"), format.encode(test::shifted(decoded, far)));

    Pair near_pair = read_pair(path("near_ref"), path("near_test"));
    Pair far_pair = read_pair(path("far_ref"), path("far_test"));
    EXPECT_TRUE(near_pair.warnings.empty()) << format.ext;
    // The readers give far clouds an origin instead of a warning (io/wide_positions.hpp).
    EXPECT_TRUE(far_pair.warnings.empty()) << format.ext;

    const EvalReport near_report = evaluate_about_common_origin(near_pair);
    const EvalReport far_report = evaluate_about_common_origin(far_pair);
    EXPECT_GT(near_report.psnr_paper, 50.0);  // the perturbation, not rounding, is measured
    EXPECT_NEAR(far_report.psnr_paper, near_report.psnr_paper, 0.01) << format.ext;
    EXPECT_NEAR(far_report.d1_psnr, near_report.d1_psnr, 0.01) << format.ext;
    EXPECT_NEAR(far_report.ref_diagonal, near_report.ref_diagonal, 1e-6) << format.ext;
  }
}

TEST(CommonOrigin, TheOriginIsTheCentreOfRefsBoundingBox) {
  PointCloud ref, test;
  const std::vector<Vec3d> ref_f64 = {{1e7, -2, 3}, {1e7 + 2, 4, 3.5}};
  const std::vector<Vec3d> test_f64 = {{1e7 + 1, 1, 3.25}};
  for (const Vec3d& p : ref_f64) ref.positions.push_back(p.cast<float>());
  for (const Vec3d& p : test_f64) test.positions.push_back(p.cast<float>());
  const StatusOr<Vec3d> origin = move_to_common_origin(ref, ref_f64, test, test_f64);
  ASSERT_TRUE(origin.ok());
  EXPECT_EQ(*origin, Vec3d(1e7 + 1, 1, 3.25));
  EXPECT_EQ(ref.positions[0], Vec3f(-1, -3, -0.25f));
  EXPECT_EQ(ref.positions[1], Vec3f(1, 3, 0.25f));
  EXPECT_EQ(test.positions[0], Vec3f(0, 0, 0));
}

TEST(CommonOrigin, TheDoublesMustMatchTheClouds) {
  PointCloud ref, test;
  ref.positions = {Vec3f(0, 0, 0)};
  test.positions = {Vec3f(0, 0, 0)};
  const std::vector<Vec3d> none;
  const std::vector<Vec3d> one = {Vec3d(0, 0, 0)};
  EXPECT_EQ(move_to_common_origin(ref, none, test, one).status().code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(move_to_common_origin(ref, one, test, none).status().code(),
            StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace sspc
