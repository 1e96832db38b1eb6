// Runs the sspc executable the way a user does: shared by the CLI test files.
#pragma once

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "test_util.hpp"

namespace sspc {

struct CliRun {
  int exit_code = -1;
  std::string out;
  std::string err;
};

inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

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

}  // namespace sspc
