// What every sspc subcommand shares: global options, exit codes, error printing, progress.
#pragma once

#include <CLI/CLI.hpp>

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sspc/io.hpp"
#include "sspc/point_cloud.hpp"
#include "sspc/progress.hpp"
#include "sspc/status.hpp"

namespace sspc::cli {

enum ExitCode : int { kExitOk = 0, kExitFailure = 1, kExitUsage = 2 };

struct GlobalOptions {
  int threads = 0;     // 0: all cores
  bool quiet = false;  // no progress even on a terminal
};

// A registered subcommand: its CLI11 node and what runs when it was chosen.
struct Command {
  CLI::App* app = nullptr;
  std::function<int()> run;
};

Command add_info_command(CLI::App& root, const GlobalOptions& global);
Command add_normals_command(CLI::App& root, const GlobalOptions& global);
Command add_eval_command(CLI::App& root, const GlobalOptions& global);
Command add_encode_command(CLI::App& root, const GlobalOptions& global);
Command add_decode_command(CLI::App& root, const GlobalOptions& global);
Command add_verify_command(CLI::App& root, const GlobalOptions& global);
Command add_render_command(CLI::App& root, const GlobalOptions& global);
Command add_convert_command(CLI::App& root, const GlobalOptions& global);

// The .sspc branch of `sspc info` (cmd_info_sspc.cpp): files that start with the .sspc magic.
bool is_sspc_file(const std::string& path);
int run_info_sspc(const std::string& path, bool as_json);

// Prints "sspc: error: ..." on stderr and returns kExitFailure.
int report_failure(const Status& status);

// read_point_cloud for a command: the reader's warnings (options.warnings is set here) are
// printed as "sspc: warning: ..." on stderr, after the progress line and before any error.
StatusOr<PointCloud> read_cloud(const std::string& path, ReadOptions options);

// A progress reporter that draws on stderr only when it is a terminal and --quiet is off.
std::unique_ptr<TerminalProgress> make_progress(const GlobalOptions& global);

// Prints `text` and a newline to stdout.
void print_line(const std::string& text);

// Checks, before anything is read or written, that each of `outputs` may be written: not one of
// the `inputs` (refused even with --force), not a directory, device, FIFO or socket (refused even
// with --force: the rename that commits an output would replace the node itself), a file name of
// at most NAME_MAX bytes in an existing, writable directory, no two outputs the same file, and
// no existing file unless `force`.
Status check_outputs(const std::vector<std::string>& inputs, const std::vector<std::string>& outputs, bool force);

// A CLI11 validator for numbers in [lo, hi] (or (lo, hi] with `open_low`): NaN, infinities and
// text that is not wholly a number are usage errors, like any value out of range.
CLI::Validator number_in(double lo, double hi, bool open_low = false);

// A CLI11 validator for "x,y,z" triples and its parser.
std::optional<Vec3f> parse_vec3(const std::string& text);
extern const CLI::Validator kVec3Validator;

}  // namespace sspc::cli
