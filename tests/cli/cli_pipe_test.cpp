// "-" as stdin and stdout, --quiet, and --help written for people.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "cli_util.hpp"
#include "test_util.hpp"

namespace sspc {
namespace {

// Runs a shell pipeline in which "SSPC" stands for the executable; stdout and stderr captured.
CliRun pipeline(const test::TempDir& dir, std::string command) {
  for (std::size_t at = command.find("SSPC"); at != std::string::npos;
       at = command.find("SSPC", at)) {
    command.replace(at, 4, SSPC_CLI_PATH);
  }
  const auto out = dir.path() / "stdout.txt";
  const auto err = dir.path() / "stderr.txt";
  const std::string line =
      "set -o pipefail; (" + command + ") >" + out.string() + " 2>" + err.string() + " </dev/null";
  const int status = std::system(("bash -c '" + line + "'").c_str());
  CliRun run;
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  run.out = slurp(out);
  run.err = slurp(err);
  return run;
}

nlohmann::json parse_json(const CliRun& run) {
  return nlohmann::json::parse(run.out, nullptr, false);
}

class Pipes : public ::testing::Test {
 protected:
  void SetUp() override {
    cloud_ = small_bunny(dir_);
    model_ = (dir_.path() / "m.sspc").string();
    ASSERT_EQ(sspc(dir_, "encode " + cloud_ + " " + model_ + " --level 9").exit_code, 0);
  }
  test::TempDir dir_;
  std::string cloud_;
  std::string model_;
};

TEST_F(Pipes, DecodeToStdoutIntoInfoFromStdin) {
  const CliRun decoded =
      sspc(dir_, "decode --json " + model_ + " " + (dir_.path() / "d.ply").string());
  ASSERT_EQ(decoded.exit_code, 0) << decoded.err;
  const CliRun run = pipeline(dir_, "SSPC decode " + model_ + " - | SSPC info --json -");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json info = parse_json(run);
  EXPECT_EQ(info["points"], parse_json(decoded)["points"]) << run.out;
  EXPECT_EQ(info["file"], "-");
  // As text, too: the summary goes to stderr, the cloud alone to stdout.
  const CliRun text = pipeline(dir_, "SSPC decode " + model_ + " - | SSPC info -");
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_NE(text.out.find("points"), std::string::npos) << text.out;
}

TEST_F(Pipes, EncodeFromStdin) {
  const std::string out = (dir_.path() / "piped.sspc").string();
  const CliRun run = pipeline(dir_, "cat " + cloud_ + " | SSPC encode - " + out + " --level 9");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const CliRun info = sspc(dir_, "info --json " + out);
  ASSERT_EQ(info.exit_code, 0) << info.err;
  EXPECT_EQ(parse_json(info)["source_points"], kSmallBunnyPoints);
  // The same bytes as encoding the file (the format is found from them, not the name).
  EXPECT_EQ(slurp(out), slurp(model_));
}

TEST_F(Pipes, ModelsAndLasThroughPipes) {
  const CliRun model = pipeline(dir_, "cat " + model_ + " | SSPC info --json -");
  ASSERT_EQ(model.exit_code, 0) << model.err;
  EXPECT_EQ(parse_json(model)["format"], "sspc");
  const CliRun las =
      pipeline(dir_, "SSPC decode " + model_ + " - --format las | SSPC info --json -");
  ASSERT_EQ(las.exit_code, 0) << las.err;
  EXPECT_TRUE(parse_json(las).contains("las_point_format")) << las.out;
  const CliRun encoded =
      pipeline(dir_, "cat " + cloud_ + " | SSPC encode - - --level 9 | SSPC verify -");
  ASSERT_EQ(encoded.exit_code, 0) << encoded.err;
  EXPECT_EQ(encoded.out, "ok\n");
  const CliRun png =
      pipeline(dir_, "SSPC render " + model_ + " -o - --size 16x16 | head -c 8 | od -c");
  ASSERT_EQ(png.exit_code, 0) << png.err;
  EXPECT_NE(png.out.find("P   N   G"), std::string::npos) << png.out;
}

TEST_F(Pipes, StdinMisuseIsRefused) {
  const CliRun empty = sspc(dir_, "info -");  // stdin is /dev/null
  EXPECT_EQ(empty.exit_code, 1);
  EXPECT_NE(empty.err.find("stdin"), std::string::npos) << empty.err;
  const CliRun twice = sspc(dir_, "eval - -");
  EXPECT_EQ(twice.exit_code, 2) << twice.err;
  const CliRun json = sspc(dir_, "decode --json " + model_ + " -");
  EXPECT_EQ(json.exit_code, 2) << json.err;
  EXPECT_EQ(parse_json(json)["command"], "decode") << json.out;
}

TEST_F(Pipes, QuietSilencesTheSummaryButNotJson) {
  const CliRun quiet =
      sspc(dir_, "--quiet decode " + model_ + " " + (dir_.path() / "q.ply").string());
  ASSERT_EQ(quiet.exit_code, 0) << quiet.err;
  EXPECT_TRUE(quiet.out.empty() && quiet.err.empty()) << quiet.out << quiet.err;
  const CliRun encode =
      sspc(dir_, "-q encode " + cloud_ + " " + (dir_.path() / "q.sspc").string() + " --level 9");
  ASSERT_EQ(encode.exit_code, 0) << encode.err;
  EXPECT_TRUE(encode.out.empty()) << encode.out;
  const CliRun json = sspc(dir_, "-q verify --json " + model_);
  EXPECT_TRUE(parse_json(json).value("ok", false)) << json.out;
}

TEST(CliHelp, ChoicesByNameAndAnExamplePerSubcommand) {
  test::TempDir dir;
  for (const char* command :
       {"info", "normals", "eval", "encode", "decode", "verify", "render", "convert"}) {
    const CliRun help = sspc(dir, std::string(command) + " --help");
    ASSERT_EQ(help.exit_code, 0) << command;
    EXPECT_EQ(help.out.find("ENUM"), std::string::npos) << help.out;
    EXPECT_EQ(help.out.find("BOOLEAN"), std::string::npos) << help.out;
    EXPECT_EQ(help.out.find("{false}"), std::string::npos) << help.out;
    EXPECT_EQ(help.out.find("TEXT"), std::string::npos) << help.out;
    EXPECT_EQ(help.out.find(" in ["), std::string::npos) << help.out;
    EXPECT_EQ(help.out.find("->"), std::string::npos) << help.out;
    EXPECT_NE(help.out.find("Example: sspc " + std::string(command)), std::string::npos)
        << help.out;
  }
  const CliRun render = sspc(dir, "render --help");
  EXPECT_NE(render.out.find("lambert|normal|depth|codeword"), std::string::npos) << render.out;
}

}  // namespace
}  // namespace sspc
