// Runs the sspc executable the way a user does and checks exit codes, messages and outputs.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "cli_util.hpp"
#include "sspc/io.hpp"
#include "sspc/synthetic.hpp"
#include "test_util.hpp"

namespace sspc {
namespace {

TEST(Cli, HelpAndUsageErrors) {
  test::TempDir dir;
  EXPECT_EQ(sspc(dir, "--help").exit_code, 0);
  EXPECT_EQ(sspc(dir, "eval --help").exit_code, 0);
  CliRun none = sspc(dir, "");
  EXPECT_EQ(none.exit_code, 2);
  CliRun missing_arg = sspc(dir, "eval " + bunny());
  EXPECT_EQ(missing_arg.exit_code, 2);
  CliRun unknown = sspc(dir, "info --no-such-flag " + bunny());
  EXPECT_EQ(unknown.exit_code, 2);
  CliRun bad_k = sspc(dir, "normals " + bunny() + " " + (dir.path() / "o.ply").string() + " -k 1");
  EXPECT_EQ(bad_k.exit_code, 2);
  CliRun bad_viewpoint = sspc(dir, "normals " + bunny() + " x.ply --viewpoint 1,2");
  EXPECT_EQ(bad_viewpoint.exit_code, 2);
}

TEST(Cli, InfoReportsTheBunny) {
  test::TempDir dir;
  CliRun run = sspc(dir, "info --json " + bunny());
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("\"points\":34834"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("\"normals\":true"), std::string::npos) << run.out;
  EXPECT_TRUE(run.err.empty()) << "progress must stay off when stderr is not a terminal: " << run.err;
}

TEST(Cli, MissingAndMalformedInputsFailWithTheFileName) {
  test::TempDir dir;
  CliRun missing = sspc(dir, "info " + (dir.path() / "absent.ply").string());
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_NE(missing.err.find("absent.ply"), std::string::npos) << missing.err;

  const auto bad = dir.path() / "bad.ply";
  { std::ofstream(bad) << "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nend_header\n1\n"; }
  const auto out = dir.path() / "out.ply";
  CliRun run = sspc(dir, "normals " + bad.string() + " " + out.string());
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("bad.ply"), std::string::npos) << run.err;
  EXPECT_FALSE(std::filesystem::exists(out)) << "no output after a failure";
}

TEST(Cli, NormalsThenEvalAgainstTheOriginal) {
  test::TempDir dir;
  const auto out = dir.path() / "bunny_normals.ply";
  CliRun normals = sspc(dir, "normals " + bunny() + " " + out.string() + " --normals estimate");
  ASSERT_EQ(normals.exit_code, 0) << normals.err;
  ASSERT_TRUE(std::filesystem::exists(out));
  CliRun eval = sspc(dir, "eval --json " + bunny() + " " + out.string());
  ASSERT_EQ(eval.exit_code, 0) << eval.err;
  // Same positions: zero error, infinite PSNR written as null, and normals that agree with the
  // mesh-derived ones of the file to within a few degrees on average.
  EXPECT_NE(eval.out.find("\"identical\":true"), std::string::npos) << eval.out;
  EXPECT_NE(eval.out.find("\"psnr\":null"), std::string::npos) << eval.out;
  const auto pos = eval.out.find("\"normal_angle_mean_deg\":");
  ASSERT_NE(pos, std::string::npos) << eval.out;
  const double mean_angle = std::stod(eval.out.substr(pos + 24));
  EXPECT_LT(mean_angle, 15.0) << eval.out;
}

TEST(Cli, NormalsOutputIsIdenticalForOneAndTwoThreads) {
  test::TempDir dir;
  const auto one = dir.path() / "one.ply";
  const auto two = dir.path() / "two.ply";
  ASSERT_EQ(sspc(dir, "--threads 1 normals " + bunny() + " " + one.string()).exit_code, 0);
  ASSERT_EQ(sspc(dir, "--threads 2 normals " + bunny() + " " + two.string()).exit_code, 0);
  EXPECT_EQ(slurp(one), slurp(two));
}

TEST(Cli, RefusesToOverwriteWithoutForce) {
  test::TempDir dir;
  const auto out = dir.path() / "exists.ply";
  { std::ofstream(out) << "keep me"; }
  CliRun run = sspc(dir, "normals " + bunny() + " " + out.string());
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_EQ(slurp(out), "keep me");
  EXPECT_EQ(sspc(dir, "normals " + bunny() + " " + out.string() + " --force").exit_code, 0);
  EXPECT_NE(slurp(out), "keep me");
}

TEST(Cli, EvalOfANoisyCopyGivesAFinitePsnrAndBitsPerPoint) {
  test::TempDir dir;
  synthetic::Options clean;
  const PointCloud ref = synthetic::sphere(5000, 1.0, clean);
  synthetic::Options noisy_options;
  noisy_options.noise = 0.001;
  const PointCloud noisy = synthetic::sphere(5000, 1.0, noisy_options);
  ASSERT_TRUE(write_ply(ref, dir.path() / "ref.ply").ok());
  ASSERT_TRUE(write_ply(noisy, dir.path() / "noisy.ply").ok());
  CliRun run = sspc(dir, "eval --json " + (dir.path() / "ref.ply").string() + " " +
                          (dir.path() / "noisy.ply").string() + " --compressed " +
                          (dir.path() / "noisy.ply").string());
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("\"identical\":false"), std::string::npos) << run.out;
  EXPECT_EQ(run.out.find("\"psnr\":null"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("\"bits_per_point\":"), std::string::npos) << run.out;
  CliRun bad_peak = sspc(dir, "eval " + (dir.path() / "ref.ply").string() + " " +
                               (dir.path() / "noisy.ply").string() + " --peak -1");
  EXPECT_EQ(bad_peak.exit_code, 1);
}

// Colour PSNR end to end: two PLY files with the same points, TEST's colours 5 levels brighter
// in every channel, give MSE 25 and 10·log10(65025/25) = 34.151 dB under the documented keys.
TEST(Cli, EvalReportsColourPsnrWhenBothFilesHaveColours) {
  test::TempDir dir;
  PointCloud ref = synthetic::sphere(3000, 1.0);
  ref.colours.resize(ref.size());
  for (std::size_t i = 0; i < ref.size(); ++i) {
    ref.colours[i] =
        Rgb8{static_cast<std::uint8_t>(i % 250), static_cast<std::uint8_t>(i * 7 % 250),
             static_cast<std::uint8_t>(i * 13 % 250)};
  }
  PointCloud brighter = ref;
  for (Rgb8& c : brighter.colours) {
    c = Rgb8{static_cast<std::uint8_t>(c.r + 5), static_cast<std::uint8_t>(c.g + 5),
             static_cast<std::uint8_t>(c.b + 5)};
  }
  const std::string r = (dir.path() / "ref.ply").string();
  const std::string t = (dir.path() / "brighter.ply").string();
  ASSERT_TRUE(write_ply(ref, r).ok());
  ASSERT_TRUE(write_ply(brighter, t).ok());

  const CliRun run = sspc(dir, "eval --json " + r + " " + t);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json json = nlohmann::json::parse(run.out, nullptr, false);
  ASSERT_TRUE(json.is_object()) << run.out;
  EXPECT_EQ(json["identical"], true) << "positions unchanged";
  EXPECT_EQ(json["colour_mse"].get<double>(), 25.0) << run.out;
  EXPECT_EQ(json["ref_to_test"]["colour_mse"].get<double>(), 25.0) << run.out;
  EXPECT_EQ(json["test_to_ref"]["colour_mse"].get<double>(), 25.0) << run.out;
  EXPECT_NEAR(json["colour_psnr"].get<double>(), 34.151, 5e-4) << run.out;

  const CliRun same = sspc(dir, "eval --json " + r + " " + r);
  ASSERT_EQ(same.exit_code, 0) << same.err;
  const nlohmann::json identical = nlohmann::json::parse(same.out, nullptr, false);
  ASSERT_TRUE(identical.contains("colour_psnr")) << same.out;
  EXPECT_TRUE(identical["colour_psnr"].is_null()) << "infinite PSNR is null: " << same.out;

  const CliRun text = sspc(dir, "eval " + r + " " + t);
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_NE(text.out.find("colour PSNR (RGB, 255) 34.1514 dB"), std::string::npos) << text.out;

  // A TEST without colours: no colour keys, rather than a meaningless number.
  const std::string plain = (dir.path() / "plain.ply").string();
  ASSERT_TRUE(write_ply(synthetic::sphere(3000, 1.0), plain).ok());
  const CliRun without = sspc(dir, "eval --json " + r + " " + plain);
  ASSERT_EQ(without.exit_code, 0) << without.err;
  EXPECT_EQ(without.out.find("colour"), std::string::npos) << without.out;
}

// encode → verify → decode on the bundled bunny: the same bytes on 1 and 2 threads, a decoded
// point count within 10% of the input, and a refusal to overwrite the input.
TEST(Cli, EncodeDecodeRoundTrip) {
  test::TempDir dir;
  const std::string one = (dir.path() / "one.sspc").string();
  const std::string two = (dir.path() / "two.sspc").string();
  ASSERT_EQ(sspc(dir, "--threads 1 encode " + bunny() + " " + one).exit_code, 0);
  ASSERT_EQ(sspc(dir, "--threads 2 encode " + bunny() + " " + two).exit_code, 0);
  EXPECT_EQ(slurp(one), slurp(two));
  EXPECT_EQ(sspc(dir, "verify " + one).exit_code, 0);
  const std::string decoded = (dir.path() / "decoded.ply").string();
  ASSERT_EQ(sspc(dir, "decode " + one + " " + decoded).exit_code, 0);
  auto cloud = read_point_cloud(decoded);
  ASSERT_TRUE(cloud.ok());
  EXPECT_NEAR(static_cast<double>(cloud->size()), 34834.0, 3483.0);
  EXPECT_FALSE(cloud->has_normals());  // positions only by default
  // A whole decode to PLY streams in chunks: the bytes of the box decode of everything, which
  // is written whole.
  const std::string boxed = (dir.path() / "boxed.ply").string();
  ASSERT_EQ(sspc(dir, "decode " + one + " " + boxed + " --box -1e9,-1e9,-1e9,1e9,1e9,1e9").exit_code, 0);
  EXPECT_EQ(slurp(decoded), slurp(boxed));

  // Whole spheres (the paper's layout) make a larger file that decodes to the same points as
  // stored (a resampled decode fits the points a code word keeps); with --store-normals the
  // decoded cloud has normals.
  const std::string full = (dir.path() / "full.sspc").string();
  const std::string full_decoded = (dir.path() / "full.ply").string();
  const std::string stored = (dir.path() / "stored.ply").string();
  // On an eighth of the bunny (a third of the test's time under the sanitizers on all of it).
  const std::string input = small_bunny(dir);
  const std::string trimmed = (dir.path() / "trimmed.sspc").string();
  ASSERT_EQ(sspc(dir, "encode " + input + " " + trimmed).exit_code, 0);
  ASSERT_EQ(sspc(dir, "encode " + input + " " + full + " --full-spheres --store-normals").exit_code, 0);
  ASSERT_EQ(sspc(dir, "decode --stored " + full + " " + full_decoded).exit_code, 0);
  ASSERT_EQ(sspc(dir, "decode --stored " + trimmed + " " + stored).exit_code, 0);
  EXPECT_GT(slurp(full).size(), slurp(trimmed).size());
  auto with_normals = read_point_cloud(full_decoded);
  auto as_stored = read_point_cloud(stored);
  ASSERT_TRUE(with_normals.ok() && as_stored.ok());
  EXPECT_TRUE(with_normals->has_normals());
  EXPECT_EQ(with_normals->positions, as_stored->positions);

  EXPECT_EQ(sspc(dir, "encode " + one + " " + one + " -f").exit_code, 1);
  EXPECT_EQ(sspc(dir, "encode " + bunny() + " " + one).exit_code, 1);  // exists, no --force
  EXPECT_EQ(sspc(dir, "encode " + bunny() + " " + one + " --level 10").exit_code, 2);
}

// A coarse level decodes resampled (docs/FORMAT.md, "Resampling"): `info` names it, `decode`
// writes m² points a stored point, `--stored` the points as stored, `--resample off` a file
// that asks for none and decodes to those same points.
TEST(Cli, CoarseLevelsDecodeResampledUnlessAskedNotTo) {
  test::TempDir dir;
  const std::string input = small_bunny(dir);
  const std::string model = (dir.path() / "l9.sspc").string();
  const std::string off = (dir.path() / "off.sspc").string();
  ASSERT_EQ(sspc(dir, "encode " + input + " " + model + " --level 9").exit_code, 0);
  ASSERT_EQ(sspc(dir, "encode " + input + " " + off + " --level 9 --resample off").exit_code, 0);
  const CliRun info = sspc(dir, "info --json " + model);
  ASSERT_EQ(info.exit_code, 0) << info.err;
  const int m = nlohmann::json::parse(info.out)["resample"].get<int>();
  EXPECT_GE(m, 2);
  EXPECT_EQ(nlohmann::json::parse(sspc(dir, "info --json " + off).out)["resample"].get<int>(), 0);

  const auto decoded = [&](const std::string& file, const std::string& options) {
    const std::string out = (dir.path() / "decoded.ply").string();
    EXPECT_EQ(sspc(dir, "decode -f " + file + " " + out + options).exit_code, 0);
    auto cloud = read_point_cloud(out);
    EXPECT_TRUE(cloud.ok());
    return cloud.ok() ? std::move(cloud).value() : PointCloud();
  };
  const PointCloud resampled = decoded(model, "");
  const PointCloud stored = decoded(model, " --stored");
  ASSERT_GT(stored.size(), 0u);
  EXPECT_EQ(resampled.size(), static_cast<std::size_t>(m * m) * stored.size());
  EXPECT_EQ(decoded(off, "").positions, stored.positions);
  EXPECT_EQ(sspc(dir, "encode -f " + input + " " + off + " --resample 5").exit_code, 2);
}

// encode never overwrites its input, not even with --force or through a hard link, and an
// existing output only with --force; decode likewise refuses to write over its input.
TEST(Cli, EncodeRefusesToOverwriteItsInputOrAnExistingOutput) {
  test::TempDir dir;
  const auto input = dir.path() / "in.ply";
  std::filesystem::copy_file(small_bunny(dir), input);
  const std::string original = slurp(input);
  const auto link = dir.path() / "link.ply";
  std::filesystem::create_hard_link(input, link);
  for (const auto& out : {input, link}) {
    const CliRun run = sspc(dir, "encode " + input.string() + " " + out.string() + " --force");
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_NE(run.err.find("is the input"), std::string::npos) << run.err;
  }
  EXPECT_EQ(slurp(input), original);

  const auto out = dir.path() / "out.sspc";
  { std::ofstream(out) << "keep me"; }
  const CliRun exists = sspc(dir, "encode " + input.string() + " " + out.string() + " --level 9");
  EXPECT_EQ(exists.exit_code, 1);
  EXPECT_NE(exists.err.find("--force"), std::string::npos) << exists.err;
  EXPECT_EQ(slurp(out), "keep me");
  ASSERT_EQ(sspc(dir, "encode " + input.string() + " " + out.string() + " --level 9 -f").exit_code, 0);
  EXPECT_EQ(slurp(out).substr(1, 3), "SPC");
  EXPECT_EQ(sspc(dir, "decode " + out.string() + " " + out.string() + " -f").exit_code, 1);
  EXPECT_EQ(slurp(out).substr(1, 3), "SPC");
}

// Runs `sspc ARGS` under a file-size limit of about 8 KB: the shell's `ulimit -f` stands in
// for a full disk.
CliRun sspc_with_small_disk(const test::TempDir& dir, const std::string& args) {
  return sspc(dir, args, "ulimit -f 16; ");
}

// Every command that writes a file, on a full disk: exit 1 with a message, the old output
// intact, no temporary file beside it.
TEST(Cli, AFullDiskLeavesTheOldOutputAndNoTemporary) {
  test::TempDir dir;
  const auto model = dir.path() / "model.sspc";
  ASSERT_EQ(sspc(dir, "encode " + bunny() + " " + model.string() + " --level 5").exit_code, 0);
  ASSERT_GT(std::filesystem::file_size(model), 8192u);
  const auto out_dir = dir.path() / "out";
  std::filesystem::create_directory(out_dir);
  const auto out = out_dir / "old";
  const std::vector<std::string> commands = {
      "encode " + bunny() + " " + out.string() + " --level 5 -f",
      "decode " + model.string() + " " + out.string() + " -f",
      "normals " + bunny() + " " + out.string() + " -f",
  };
  for (const std::string& command : commands) {
    { std::ofstream(out) << "keep me"; }
    const CliRun run = sspc_with_small_disk(dir, command);
    EXPECT_EQ(run.exit_code, 1) << command << ": " << run.err;
    EXPECT_NE(run.err.find(out.string()), std::string::npos) << command << ": " << run.err;
    EXPECT_EQ(slurp(out), "keep me") << command;
    EXPECT_EQ(test::count_files(out_dir), 1u) << command;
  }
}

// Ctrl-C in the middle of a command: the output is the old file or the complete new one, and
// no temporary file is left.
TEST(Cli, AnInterruptLeavesTheOldOutputOrTheNewOneAndNoTemporary) {
  test::TempDir dir;
  const auto out_dir = dir.path() / "out";
  std::filesystem::create_directory(out_dir);
  const auto reference = dir.path() / "reference.ply";
  ASSERT_EQ(sspc(dir, "normals " + bunny() + " " + reference.string()).exit_code, 0);
  const auto out = out_dir / "normals.ply";
  for (const char* delay : {"0.05", "0.2", "0.5"}) {
    { std::ofstream(out) << "keep me"; }
    sspc(dir, "normals " + bunny() + " " + out.string() + " -f",
         "timeout -s INT " + std::string(delay) + " ");
    const std::string now = slurp(out);
    EXPECT_TRUE(now == "keep me" || now == slurp(reference)) << "after " << delay << " s";
    EXPECT_EQ(test::count_files(out_dir), 1u) << "after " << delay << " s";
  }
}

// render writes a PNG of the bunny, the same bytes on 1 and 2 threads, and of its compressed
// model; a bad size is refused.
TEST(Cli, RenderWritesAPng) {
  test::TempDir dir;
  const std::string one = (dir.path() / "one.png").string();
  const std::string two = (dir.path() / "two.png").string();
  ASSERT_EQ(sspc(dir, "--threads 1 render " + bunny() + " -o " + one + " --size 48x40").exit_code, 0);
  ASSERT_EQ(sspc(dir, "--threads 2 render " + bunny() + " -o " + two + " --size 48x40 --json").exit_code, 0);
  const std::string png = slurp(one);
  ASSERT_GT(png.size(), 8u);
  EXPECT_EQ(png.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  EXPECT_EQ(png, slurp(two));
  EXPECT_EQ(sspc(dir, "render " + bunny() + " -o " + one + " -f --size 48").exit_code, 2);  // a usage error
  const std::string model = (dir.path() / "m.sspc").string();
  ASSERT_EQ(sspc(dir, "encode " + bunny() + " " + model).exit_code, 0);
  EXPECT_EQ(sspc(dir, "render " + model + " -o " + one + " -f --size 48x40 --shade codeword").exit_code, 0);
  EXPECT_EQ(slurp(one).substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
}

// render --json reports the camera it rendered, the automatic one included: given back as
// --eye, --target, --up and --fov it renders the same image (how the render of a decode, whose
// bounding box and so automatic camera differ, is compared with the model's).
TEST(Cli, RenderReportsTheCameraItUsed) {
  test::TempDir dir;
  const std::string model = (dir.path() / "m.sspc").string();
  ASSERT_EQ(sspc(dir, "encode " + bunny() + " " + model).exit_code, 0);
  const std::string automatic = (dir.path() / "a.png").string(), given = (dir.path() / "g.png").string();
  const CliRun run = sspc(dir, "render " + model + " -o " + automatic + " --size 40x32 --json");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json json = nlohmann::json::parse(run.out, nullptr, false);
  ASSERT_FALSE(json.is_discarded()) << run.out;
  const auto vec = [&](const char* key) {
    const auto& v = json.at(key);
    return v.at(0).dump() + "," + v.at(1).dump() + "," + v.at(2).dump();
  };
  const CliRun again = sspc(dir, "render " + model + " -o " + given + " --size 40x32 --eye " + vec("eye") + " --target " +
                                     vec("target") + " --up " + vec("up") + " --fov " + json.at("fov_degrees").dump());
  ASSERT_EQ(again.exit_code, 0) << again.err;
  EXPECT_EQ(slurp(automatic), slurp(given));
  // Another camera gives another image: the comparison can fail.
  const CliRun moved = sspc(dir, "render " + model + " -o " + given + " -f --size 40x32 --eye " + vec("target") +
                                     " --target " + vec("eye"));
  ASSERT_EQ(moved.exit_code, 0) << moved.err;
  EXPECT_NE(slurp(automatic), slurp(given));
}

// render --camera-path renders one frame per camera line, OUT_0000.png on, and writes each
// frame's time to a CSV; a malformed line is refused with its line number.
TEST(Cli, RenderCameraPathWritesFramesAndTimes) {
  test::TempDir dir;
  const auto path = dir.path() / "path.txt";
  {
    std::ofstream out(path);
    out << "# eye, target [, up [, fov]]\n"
        << "0 0.1 0.4  -0.02 0.1 0\n"
        << "0.3,0.1,0.3, -0.02,0.1,0, 0,1,0\n"
        << "\n"
        << "0.4 0.1 0 -0.02 0.1 0 0 1 0 30\n";
  }
  const std::string frames = (dir.path() / "f.png").string();
  const CliRun run = sspc(dir, "render " + bunny() + " -o " + frames + " --size 32x24 --camera-path " + path.string() + " --json");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  for (const char* name : {"f_0000.png", "f_0001.png", "f_0002.png"}) {
    EXPECT_EQ(slurp(dir.path() / name).substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8)) << name;
  }
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "f_0003.png"));
  std::ifstream csv(dir.path() / "f.csv");
  std::string line;
  std::vector<std::string> lines;
  while (std::getline(csv, line)) lines.push_back(line);
  ASSERT_EQ(lines.size(), 4u);
  EXPECT_EQ(lines[0].substr(0, 6), "frame,");
  EXPECT_EQ(lines[3].substr(0, 2), "2,");
  EXPECT_NE(run.out.find("\"frames\":3"), std::string::npos) << run.out;
  // Existing frames are not overwritten without --force.
  EXPECT_EQ(sspc(dir, "render " + bunny() + " -o " + frames + " --size 32x24 --camera-path " + path.string()).exit_code, 1);

  {
    std::ofstream out(path);
    out << "0 0.1 0.4 -0.02 0.1 0\n0 0.1 0.4 oops 0.1 0\n";
  }
  const CliRun bad = sspc(dir, "render " + bunny() + " -o " + frames + " -f --size 32x24 --camera-path " + path.string());
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.err.find(":2:"), std::string::npos) << bad.err;
}

}  // namespace
}  // namespace sspc
