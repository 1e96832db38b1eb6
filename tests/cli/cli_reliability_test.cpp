// Hostile and unusual inputs and outputs at the command line: every case ends within seconds with
// a clear message and the documented exit code, and nothing is lost or overwritten.
#include <gtest/gtest.h>

#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>
#include <zlib.h>

#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>

#include "cli_util.hpp"
#include "sspc/io.hpp"
#include "sspc/synthetic.hpp"
#include "test_util.hpp"

namespace sspc {
namespace {

// Every run gets a hard time limit: a hang fails the test instead of the suite.
const std::string kLimit = "timeout 60 ";

std::string write_cloud(const test::TempDir& dir, const std::string& name, const PointCloud& cloud) {
  const auto path = dir.path() / name;
  EXPECT_TRUE(write_ply(cloud, path).ok());
  return path.string();
}

PointCloud read_bunny() {
  auto cloud = read_point_cloud(bunny());
  EXPECT_TRUE(cloud.ok());
  return std::move(cloud).value();
}

// Every third point of the bunny, positions only: a tiled encode of it takes a third of the
// whole bunny's time.
PointCloud third_of_bunny() {
  const PointCloud bunny_points = read_bunny();
  PointCloud third;
  for (std::size_t i = 0; i < bunny_points.size(); i += 3) third.positions.push_back(bunny_points.positions[i]);
  return third;
}

// A small cloud with normals, for the cases where the size does not matter.
PointCloud small_sphere() { return synthetic::sphere(3000, 1.0); }

// The bunny with every point written twice: the median nearest-neighbour distance is 0 and a
// march whose step was derived from it never moved.
TEST(CliReliability, RenderOfADoubledCloudFinishes) {
  test::TempDir dir;
  PointCloud doubled = read_bunny();
  const std::size_t n = doubled.size();
  for (std::size_t i = 0; i < n; ++i) {
    doubled.positions.push_back(doubled.positions[i]);
    doubled.normals.push_back(doubled.normals[i]);
  }
  const std::string input = write_cloud(dir, "doubled.ply", doubled);
  const std::string single = (dir.path() / "single.png").string(), twice = (dir.path() / "twice.png").string();
  ASSERT_EQ(sspc(dir, "render " + bunny() + " -o " + single + " --size 40x32").exit_code, 0);
  const CliRun run = sspc(dir, "render " + input + " -o " + twice + " --size 40x32", kLimit);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  // Twice the points with the same normals: the same weighted averages, the same surface.
  EXPECT_EQ(slurp(single), slurp(twice));
}

// A valid .sspc whose header spacing is 0 or a denormal (the format allows it) is refused by
// render with a message, instead of a march that never advances.
TEST(CliReliability, RenderOfAModelWithAVanishingSpacingFails) {
  test::TempDir dir;
  const std::string model = (dir.path() / "m.sspc").string();
  const std::string input = write_cloud(dir, "sphere.ply", small_sphere());
  ASSERT_EQ(sspc(dir, "encode " + input + " " + model + " -l 9").exit_code, 0);
  std::string bytes = slurp(model);
  for (const float spacing : {0.0f, 1e-30f, 1.4e-45f}) {
    std::string hostile = bytes;
    std::memcpy(hostile.data() + 24, &spacing, 4);  // header: spacing at byte 24, CRC32 of 0..191 at 192
    const auto crc = static_cast<std::uint32_t>(crc32(0, reinterpret_cast<const Bytef*>(hostile.data()), 192));
    std::memcpy(hostile.data() + 192, &crc, 4);
    const auto path = dir.path() / "hostile.sspc";
    { std::ofstream(path, std::ios::binary) << hostile; }
    ASSERT_EQ(sspc(dir, "verify " + path.string()).exit_code, 0) << "the model must be valid but for its spacing";
    const CliRun run = sspc(dir, "render " + path.string() + " -o " + (dir.path() / "x.png").string() + " --size 32x32", kLimit);
    EXPECT_EQ(run.exit_code, 1) << spacing;
    EXPECT_NE(run.err.find("spacing"), std::string::npos) << run.err;
    EXPECT_FALSE(std::filesystem::exists(dir.path() / "x.png"));
  }
}

// Coordinates float32 cannot square (an outlier at 1e20, a cloud scaled by 1e30 or 1e-30) are
// refused by every geometric command, naming the problem, instead of an overflow in a grid index
// or an internal error.
TEST(CliReliability, OutOfRangeCoordinatesFailClearly) {
  test::TempDir dir;
  const PointCloud base = small_sphere();
  PointCloud outlier = base;
  outlier.positions[0].x() = 1e20f;
  PointCloud huge = base, tiny = base, spread = base;
  for (Vec3f& p : huge.positions) p *= 1e30f;
  for (Vec3f& p : tiny.positions) p *= 1e-30f;
  spread.positions[0].x() = 1e16f;  // within float's range, but 10^18 spacings from the rest
  struct Case {
    const char* name;
    const PointCloud* cloud;
    const char* says;
  };
  for (const Case& c : {Case{"outlier.ply", &outlier, "coordinates reach"}, Case{"huge.ply", &huge, "coordinates reach"},
                        Case{"tiny.ply", &tiny, "spacing"}, Case{"spread.ply", &spread, "spacings"}}) {
    const std::string input = write_cloud(dir, c.name, *c.cloud);
    const std::string out = (dir.path() / "out").string();
    for (const std::string& command : {"encode " + input + " " + out + ".sspc", "render " + input + " -o " + out + ".png --size 32x32"}) {
      const CliRun run = sspc(dir, command, kLimit);
      EXPECT_EQ(run.exit_code, 1) << command << "\n" << run.err;
      EXPECT_NE(run.err.find(c.says), std::string::npos) << command << "\n" << run.err;
      EXPECT_NE(run.err.find(c.name), std::string::npos) << run.err;
      EXPECT_EQ(run.err.find(": :"), std::string::npos) << "an empty context: " << run.err;
    }
  }
}

TEST(CliReliability, MalformedValuesAreUsageErrors) {
  test::TempDir dir;
  const std::string png = " -o " + (dir.path() / "x.png").string();
  const std::string model = " " + (dir.path() / "x.sspc").string();
  for (const std::string& args :
       {"render " + bunny() + png + " --size 12x", "render " + bunny() + png + " --size 0x8",
        "render " + bunny() + png + " --size 99999x8", "render " + bunny() + png + " --fov nan",
        "render " + bunny() + png + " --bandwidth nan", "render " + bunny() + png + " --bandwidth inf",
        "render " + bunny() + png + " --memory-budget 8 --page-dir /nonexistent-sspc",
        "render " + bunny() + png + " --orbit 2 --camera-path " + bunny(), "encode " + bunny() + model + " --epsilon nan",
        "encode " + bunny() + model + " --tau nan", "encode " + bunny() + model + " --epsilon 1e30",
        "encode " + bunny() + model + " --tau 0", "encode " + bunny() + model + " --memory-limit 2X",
        "encode " + bunny() + model + " --memory-limit -1G", "encode - " + model + " --memory-limit 1G",
        "encode " + bunny() + model + " --memory-limit ''", "encode " + bunny() + model + " --memory-limit ' '",
        "encode " + bunny() + " " + (dir.path() / "model.ply").string(),
        "encode " + bunny() + " " + (dir.path() / "model.las").string(),
        "decode " + model + " " + (dir.path() / "o.ply").string() + " --patch 99999999999999999999",
        "decode " + model + " " + (dir.path() / "o.ply").string() + " --patch -1"}) {
    const CliRun run = sspc(dir, args);
    EXPECT_EQ(run.exit_code, 2) << args << "\n" << run.err;
  }
  EXPECT_EQ(test::count_files(dir.path()), 2u) << "only stdout.txt and stderr.txt";
}

// What a command prints on stdout is its output: a stdout that cannot take it (a full disk) fails
// the command with exit 1, whether the report is text or --json.
TEST(CliReliability, AReportToAFullStdoutFails) {
  test::TempDir dir;
  const std::string model = (dir.path() / "b.sspc").string();
  ASSERT_EQ(sspc(dir, "encode -q -l 9 " + bunny() + " " + model).exit_code, 0);
  const std::string err = (dir.path() / "err.txt").string();
  for (const std::string& args : {"info " + model, "info --json " + model, "verify " + model, "info " + bunny(),
                                  "eval " + bunny() + " " + bunny(), "verify --json " + model}) {
    const std::string command = std::string(SSPC_CLI_PATH) + " " + args + " >/dev/full 2>" + err + " </dev/null";
    const int status = std::system(command.c_str());
    ASSERT_TRUE(WIFEXITED(status)) << args;
    EXPECT_EQ(WEXITSTATUS(status), 1) << args;
    EXPECT_NE(slurp(err).find("stdout: No space left on device"), std::string::npos) << args << ": " << slurp(err);
  }
}

// Every output is checked before anything is written: not an input (even with --force), not a
// special file, not existing without --force, frames of a sequence included.
TEST(CliReliability, OutputsAreCheckedBeforeAnythingIsWritten) {
  test::TempDir dir;
  const auto input = dir.path() / "in.ply";
  std::filesystem::copy_file(bunny(), input);
  const std::string before = slurp(input);
  CliRun run = sspc(dir, "render " + input.string() + " -o " + input.string() + " -f --size 16x16");
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("is the input"), std::string::npos) << run.err;
  EXPECT_EQ(slurp(input), before);

  // The third frame exists: the orbit stops before its first frame.
  { std::ofstream(dir.path() / "f_0002.png") << "keep"; }
  run = sspc(dir, "render " + input.string() + " -o " + (dir.path() / "f.png").string() + " --orbit 4 --size 16x16");
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("f_0002.png: exists"), std::string::npos) << run.err;
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "f_0000.png"));
  EXPECT_EQ(slurp(dir.path() / "f_0002.png"), "keep");

  // Special files are refused even with --force: the rename would replace the node.
  const auto fifo = dir.path() / "pipe";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  run = sspc(dir, "decode x.sspc " + fifo.string() + " -f", kLimit);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("a FIFO"), std::string::npos) << run.err;
  run = sspc(dir, "normals " + input.string() + " /dev/null -f");
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("character device"), std::string::npos) << run.err;
  EXPECT_TRUE(std::filesystem::is_character_file("/dev/null"));
  run = sspc(dir, "normals " + input.string() + " " + dir.path().string() + " -f");
  EXPECT_EQ(run.exit_code, 1);
  run = sspc(dir, "normals " + input.string() + " " + (dir.path() / "no-such-folder" / "o.ply").string());
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("does not exist"), std::string::npos) << run.err;

  // A 250-byte name is legal (NAME_MAX is 255), and so must be its temporary name.
  const std::string long_name = std::string(246, 'a') + ".ply";
  run = sspc(dir, "normals " + input.string() + " " + (dir.path() / long_name).string());
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(std::filesystem::exists(dir.path() / long_name));
  run = sspc(dir, "normals " + input.string() + " " + (dir.path() / (std::string(256, 'b') + ".ply")).string());
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("longer than"), std::string::npos) << run.err;
}

// A sequence whose third camera cannot be rendered leaves neither the frames before it nor a
// temporary folder.
TEST(CliReliability, AFailedSequenceLeavesNoFrames) {
  test::TempDir dir;
  const auto path = dir.path() / "path.txt";
  { std::ofstream(path) << "0 0.1 0.4 -0.02 0.1 0\n0.3 0.1 0.3 -0.02 0.1 0\n1 1 1 1 1 1\n"; }
  const auto out = dir.path() / "out";
  std::filesystem::create_directory(out);
  const CliRun run =
      sspc(dir, "render " + bunny() + " -o " + (out / "f.png").string() + " --size 16x16 --camera-path " + path.string());
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("frame 2"), std::string::npos) << run.err;
  EXPECT_EQ(test::count_files(out), 0u);
}

// The user's check of a compressed render (issue: direct render against the render of the
// decode): `render --compare` reads the other PNG and reports the image PSNR over the pixels both
// hit and the pixels hit in one only; in JSON too. Against itself: +inf (null) and none.
TEST(CliReliability, RenderCompareReportsImagePsnr) {
  test::TempDir dir;
  const std::string model = (dir.path() / "bunny.sspc").string();
  const std::string decoded = (dir.path() / "decoded.ply").string();
  const std::string a = (dir.path() / "direct.png").string(), b = (dir.path() / "decoded.png").string();
  // An eighth of the bunny: the comparison is what is tested, not the renderer.
  ASSERT_EQ(sspc(dir, "encode " + small_bunny(dir) + " " + model + " --quiet", kLimit).exit_code, 0);
  ASSERT_EQ(sspc(dir, "decode " + model + " " + decoded + " --quiet", kLimit).exit_code, 0);
  // One camera for both: the automatic one frames each input's own bounds, and the decoded
  // cloud's differ from the source's by the codec's error.
  const std::string camera = " --size 64x64 --eye -0.017,0.11,0.3 --target -0.017,0.11,0";
  ASSERT_EQ(sspc(dir, "render " + decoded + " -o " + b + camera, kLimit).exit_code, 0);
  const CliRun run = sspc(dir, "render " + model + " -o " + a + camera + " --compare " + b + " --json", kLimit);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto number = [&](const std::string& key) {
    const auto at = run.out.find("\"" + key + "\":");
    EXPECT_NE(at, std::string::npos) << key << " in " << run.out;
    if (at == std::string::npos) return -1.0;
    const char* value = run.out.c_str() + at + key.size() + 3;
    // null: the images agree exactly where both are hit (PSNR +inf), as a direct render of the
    // bunny and the render of its decode now do.
    return std::strncmp(value, "null", 4) == 0 ? std::numeric_limits<double>::infinity() : std::atof(value);
  };
  EXPECT_GE(number("psnr_hit_db"), 35.0);
  EXPECT_GT(number("hit_both"), 500.0);
  EXPECT_LE(number("hit_one_only_fraction"), 0.002);
  const CliRun self =
      sspc(dir, "render " + decoded + " -o " + (dir.path() / "again.png").string() + camera + " --compare " + b, kLimit);
  ASSERT_EQ(self.exit_code, 0) << self.err;
  EXPECT_NE(self.out.find("image PSNR inf dB"), std::string::npos) << self.out;
  // --lod is for compressed models: on a point cloud it is ignored, and said so.
  const CliRun lod = sspc(dir, "render " + decoded + " -o " + a + " -f --size 16x16 --lod 1", kLimit);
  EXPECT_EQ(lod.exit_code, 0) << lod.err;
  EXPECT_NE(lod.err.find("--lod applies to compressed models (.sspc) only"), std::string::npos) << lod.err;
  // A reference twice the size each way is a supersampled one, box-filtered to the render's size.
  const CliRun half = sspc(dir, "render " + decoded + " -o " + a + " -f --size 32x32 --eye -0.017,0.11,0.3 "
                           "--target -0.017,0.11,0 --compare " + b + " --json", kLimit);
  EXPECT_EQ(half.exit_code, 0) << half.err;
  EXPECT_NE(half.out.find("\"hit_both\":"), std::string::npos) << half.out;
  // A PNG of another size, and a file that is no PNG, fail naming the file.
  const CliRun size = sspc(dir, "render " + model + " -o " + a + " -f --size 48x48 --compare " + b, kLimit);
  EXPECT_EQ(size.exit_code, 1);
  EXPECT_NE(size.err.find("decoded.png: 64x64 pixels"), std::string::npos) << size.err;
  const CliRun text = sspc(dir, "render " + model + " -o " + a + " -f --size 64x64 --compare " + decoded, kLimit);
  EXPECT_EQ(text.exit_code, 1);
  EXPECT_NE(text.err.find("decoded.ply: not a PNG"), std::string::npos) << text.err;
}

// --memory-limit reads the input in passes and tiles it: the bytes of the same tiles of the cloud
// held in memory, and nothing left behind beside the output (its tiles' folder is removed).
// A third of the bunny's points in four tiles: as many tiles as the whole bunny in tiles of 9000,
// a third of the time (20 s under the sanitizers with the whole bunny).
TEST(CliReliability, AMemoryLimitEncodesTheBytesOfTheCloudInMemory) {
  test::TempDir dir;
  const PointCloud third = third_of_bunny();
  const std::string input = write_cloud(dir, "third.ply", third);
  const std::string a = (dir.path() / "a.sspc").string(), b = (dir.path() / "b.sspc").string();
  const CliRun limited = sspc(dir, "encode " + input + " " + a + " -l 5 --memory-limit 0.5G --tile-points 3000 --json", kLimit);
  ASSERT_EQ(limited.exit_code, 0) << limited.err;
  EXPECT_NE(limited.out.find("\"tiles\":"), std::string::npos) << limited.out;
  EXPECT_EQ(limited.out.find("\"tiles\":1,"), std::string::npos) << limited.out;
  const CliRun in_memory = sspc(dir, "encode " + input + " " + b + " -l 5 --tile-points 3000", kLimit);
  ASSERT_EQ(in_memory.exit_code, 0) << in_memory.err;
  EXPECT_EQ(slurp(a), slurp(b));
  EXPECT_EQ(test::count_files(dir.path()), 5u) << "third.ply, a.sspc, b.sspc, stdout.txt and stderr.txt";
}

// SIGKILL (the OOM killer's) of an encode under --memory-limit left its staged tiles (about 1.8
// times the input) and an empty temporary beside the output, and later runs never removed them:
// the next command writing there removes them once their owner is gone, and says so.
TEST(CliReliability, AKilledEncodesLeftoversAreRemovedByTheNextRun) {
  test::TempDir dir;
  const std::string model = (dir.path() / "m.sspc").string();
  const std::string command = std::string(SSPC_CLI_PATH) + " encode -q " + bunny() + " " + model +
                              " -l 5 --memory-limit 0.5G --tile-points 3000 >/dev/null 2>&1 & echo $!";
  std::FILE* shell = popen(command.c_str(), "r");
  ASSERT_NE(shell, nullptr);
  long pid = 0;
  ASSERT_EQ(std::fscanf(shell, "%ld", &pid), 1);
  pclose(shell);
  auto leftovers = [&] {
    std::size_t n = 0;
    for (const auto& e : std::filesystem::directory_iterator(dir.path())) n += e.path().filename().string()[0] == '.';
    return n;
  };
  for (int wait = 0; wait < 600 && leftovers() < 2; ++wait) usleep(10000);  // the staging folder and the temporary
  ASSERT_EQ(kill(static_cast<pid_t>(pid), SIGKILL), 0);
  usleep(200000);
  ASSERT_GE(leftovers(), 1u) << "the encode finished before it could be killed";
  // Aged past the minute within which a temporary may be being made.
  for (const auto& e : std::filesystem::directory_iterator(dir.path())) {
    std::filesystem::last_write_time(e.path(), std::filesystem::file_time_type::clock::now() - std::chrono::minutes(5));
  }
  const CliRun again = sspc(dir, "encode -q " + bunny() + " " + model + " -l 9", kLimit);
  ASSERT_EQ(again.exit_code, 0) << again.err;
  EXPECT_NE(again.err.find("left by an interrupted run"), std::string::npos) << again.err;
  EXPECT_EQ(leftovers(), 0u);
}

// A survey arrives as many tiles: a folder, a pattern or a list of files encode as one cloud, the
// bytes of their concatenation as one file, whole or read in passes under --memory-limit.
TEST(CliReliability, ManyFilesEncodeAsTheirConcatenation) {
  test::TempDir dir;
  const PointCloud third = third_of_bunny();
  const std::string whole = write_cloud(dir, "whole.ply", third);
  std::filesystem::create_directory(dir.path() / "tiles");
  for (int k = 0; k < 4; ++k) {
    const std::size_t n = third.size();
    ASSERT_TRUE(write_ply(third.slice(n * static_cast<std::size_t>(k) / 4, n * static_cast<std::size_t>(k + 1) / 4),
                          dir.path() / "tiles" / ("t" + std::to_string(k) + ".ply"))
                    .ok());
  }
  const std::string tiles = (dir.path() / "tiles").string();
  auto model = [&](const std::string& name) { return (dir.path() / name).string(); };
  for (const std::string& limit : {std::string(), std::string(" --memory-limit 0.5G --tile-points 3000")}) {
    SCOPED_TRACE(limit);
    ASSERT_EQ(sspc(dir, "encode -q -f -l 5 " + whole + " " + model("whole.sspc") + limit, kLimit).exit_code, 0);
    const CliRun folder = sspc(dir, "encode -f -l 5 " + tiles + " " + model("folder.sspc") + limit, kLimit);
    ASSERT_EQ(folder.exit_code, 0) << folder.err;
    EXPECT_NE(folder.out.find("t0.ply and 3 more files: " + std::to_string(third.size()) + " points"), std::string::npos)
        << folder.err;
    EXPECT_EQ(slurp(model("folder.sspc")), slurp(model("whole.sspc")));
    const CliRun pattern = sspc(dir, "encode -q -f -l 5 '" + tiles + "/t*.ply' " + model("pattern.sspc") + limit, kLimit);
    ASSERT_EQ(pattern.exit_code, 0) << pattern.err;
    EXPECT_EQ(slurp(model("pattern.sspc")), slurp(model("whole.sspc")));
  }
  const CliRun none = sspc(dir, "encode '" + tiles + "/*.las' " + model("none.sspc"));
  EXPECT_EQ(none.exit_code, 1);
  EXPECT_NE(none.err.find("no file matches"), std::string::npos) << none.err;
  const CliRun with_stdin = sspc(dir, "encode - " + whole + " " + model("none.sspc"));
  EXPECT_EQ(with_stdin.exit_code, 2) << with_stdin.err;
}

}  // namespace
}  // namespace sspc
