// The readers' warnings as the commands print them, and sspc eval on clouds far from the origin.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "cli_util.hpp"
#include "double_cloud_files.hpp"
#include "test_util.hpp"

namespace sspc {
namespace {

double json_number(const std::string& json, const std::string& key) {
  const auto at = json.find("\"" + key + "\":");
  EXPECT_NE(at, std::string::npos) << key << " in " << json;
  return at == std::string::npos ? 0.0 : std::stod(json.substr(at + key.size() + 3));
}

TEST(CliReadWarnings, FarFromZeroTheCommandsShowTheOriginAndWarnOfNothing) {
  test::TempDir dir;
  const std::vector<Vec3d> near = test::wavy_patch(30);
  const auto near_path = dir.path() / "near.xyz";
  const auto far_path = dir.path() / "far.xyz";
  test::write_bytes(near_path, test::xyz_text(near));
  test::write_bytes(far_path, test::xyz_text(test::shifted(near, Vec3d(500000, 4000000, 100))));

  const CliRun info = sspc(dir, "info " + far_path.string());
  EXPECT_EQ(info.exit_code, 0) << info.err;
  EXPECT_EQ(info.err.find("warning"), std::string::npos) << info.err;
  EXPECT_NE(info.out.find("origin      500000 4000000 100"), std::string::npos) << info.out;
  const CliRun normals =
      sspc(dir, "normals " + far_path.string() + " " + (dir.path() / "n.ply").string());
  EXPECT_EQ(normals.exit_code, 0) << normals.err;
  EXPECT_EQ(normals.err.find("warning"), std::string::npos) << normals.err;
  const CliRun quiet = sspc(dir, "info " + near_path.string());
  EXPECT_EQ(quiet.exit_code, 0) << quiet.err;
  EXPECT_EQ(quiet.out.find("origin"), std::string::npos) << quiet.out;
}

TEST(CliReadWarnings, EvalFarFromTheOriginMeasuresTheCloudsNotTheRounding) {
  test::TempDir dir;
  const std::vector<Vec3d> ref = test::wavy_patch(30);
  const std::vector<Vec3d> decoded = test::perturbed(ref, 2e-4);
  const Vec3d far(500000, 4000000, 100);
  const auto write = [&](const char* name, const std::vector<Vec3d>& points) {
    const auto path = dir.path() / name;
    test::write_bytes(path, test::ply_double(points, true));
    return path.string();
  };
  const std::string near_args = write("near_ref.ply", ref) + " " + write("near_dec.ply", decoded);
  const std::string far_args = write("far_ref.ply", test::shifted(ref, far)) + " " +
                               write("far_dec.ply", test::shifted(decoded, far));
  const CliRun near_eval = sspc(dir, "eval --json --no-estimate-normals " + near_args);
  const CliRun far_eval = sspc(dir, "eval --json --no-estimate-normals " + far_args);
  ASSERT_EQ(near_eval.exit_code, 0) << near_eval.err;
  ASSERT_EQ(far_eval.exit_code, 0) << far_eval.err;
  EXPECT_EQ(far_eval.err.find("warning"), std::string::npos) << far_eval.err;
  EXPECT_NEAR(json_number(far_eval.out, "psnr"), json_number(near_eval.out, "psnr"), 0.01);
  EXPECT_NEAR(json_number(far_eval.out, "d1_psnr"), json_number(near_eval.out, "d1_psnr"), 0.01);
}

}  // namespace
}  // namespace sspc
