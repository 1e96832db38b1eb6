// Runs the sspc executable the way a user does: shared by the CLI test files.
#pragma once

#include <sys/wait.h>

#include <cstddef>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "sspc/io.hpp"
#include "test_util.hpp"

namespace sspc {

struct CliRun {
  int exit_code = -1;
  std::string out;
  std::string err;
};

inline std::string slurp(const std::filesystem::path& p) { return test::read_file(p); }

// Runs `sspc ARGS` with stdout and stderr captured to files in `dir`; `shell_prefix` goes in
// front of the command line (a `ulimit`, a `timeout`).
inline CliRun sspc(const test::TempDir& dir, const std::string& args, const std::string& shell_prefix = "") {
  const auto out = dir.path() / "stdout.txt";
  const auto err = dir.path() / "stderr.txt";
  const std::string command = shell_prefix + std::string(SSPC_CLI_PATH) + " " + args + " >" + out.string() +
                              " 2>" + err.string() + " </dev/null";
  const int status = std::system(command.c_str());
  CliRun run;
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  run.out = slurp(out);
  run.err = slurp(err);
  return run;
}

inline std::string bunny() { return std::string(SSPC_SOURCE_DIR) + "/data/bunny.ply"; }

// Every 8th point of the bunny (4,355 points, with their normals), written into `dir`: a real
// scan for the tests of the CLI's plumbing (pipes, --json keys), which assert nothing about the
// bunny's size and would otherwise spend most of their time encoding 34,834 points under ASan.
inline constexpr std::size_t kSmallBunnyPoints = 4355;
inline std::string small_bunny(const test::TempDir& dir) {
  auto cloud = read_point_cloud(bunny());
  if (!cloud.ok()) std::abort();
  PointCloud small;
  small.metadata = cloud->metadata;
  for (std::size_t i = 0; i < cloud->size(); i += 8) {
    small.positions.push_back(cloud->positions[i]);
    small.normals.push_back(cloud->normals[i]);
  }
  const std::string path = (dir.path() / "small_bunny.ply").string();
  if (small.size() != kSmallBunnyPoints || !write_ply(small, path).ok()) std::abort();
  return path;
}

}  // namespace sspc
