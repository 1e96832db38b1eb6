// What every sspc subcommand shares: global options, exit codes, error printing, progress.
#pragma once

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sspc/compressed_model.hpp"
#include "sspc/io.hpp"
#include "sspc/point_cloud.hpp"
#include "sspc/progress.hpp"
#include "sspc/status.hpp"

namespace sspc::cli {

enum ExitCode : int { kExitOk = 0, kExitFailure = 1, kExitUsage = 2 };

struct GlobalOptions {
  int threads = 0;     // 0: all cores
  bool quiet = false;  // no progress even on a terminal, and no summary line (--json still prints)
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

// Prints "sspc: error: ..." on stderr and returns kExitFailure; after report_errors_as_json,
// also the error object of docs/CLI.md on stdout.
int report_failure(const Status& status);
// The same for a usage error found after parsing (exit code kExitUsage).
int report_usage_error(const Status& status);

// --- JSON output (docs/CLI.md) -----------------------------------------------------------------

// Objects keep their keys in the order written.
using Json = nlohmann::ordered_json;
// The version of the keys every --json object carries as "schema"; raised when a key changes
// meaning or goes away (new keys do not raise it).
inline constexpr int kJsonSchema = 1;

// {"schema": kJsonSchema, "command": command}, to which a subcommand adds its keys.
Json json_report(std::string_view command);
Json json_vec3(const Vec3d& v);
Json json_vec3(const Vec3f& v);
// One line on stdout; non-finite numbers as null, invalid UTF-8 in names replaced.
void print_json(const Json& json);
// From now on failures also print {"schema", "command", "error", "file"} on stdout; "file" is
// the one of `files` the message is about (null when none is).
void report_errors_as_json(std::string command, std::vector<std::string> files);
// The error object itself (tests and usage errors).
Json json_error(std::string_view command, const std::string& message,
                const std::vector<std::string>& files);

// --- "-": stdin and stdout ---------------------------------------------------------------------

inline bool is_stdio(const std::string& path) {
  return path == "-";
}
// What messages call stdin.
inline constexpr const char* kStdinName = "stdin";

// All of stdin, read once and kept for the process. Refuses a terminal (nothing was piped in).
StatusOr<std::span<const std::byte>> stdin_bytes();

// Opens a compressed model from a file, or from stdin for "-".
StatusOr<CompressedModel> open_model(const std::string& path);

// Where an output goes: the file `output` through `write` (which writes the path it is given
// atomically), or for "-" stdout: `write` writes a temporary file named with `extension` (the
// writers choose the format by it), whose bytes are then copied to stdout and which is removed.
Status write_output(const std::string& output, const std::string& extension,
                    const std::function<Status(const std::filesystem::path&)>& write);

// A point-cloud output format: by extension for a file, `format` ("ply" or "las") for stdout.
std::string cloud_extension(const std::string& output, const std::string& format);
// CLI11 option for --format (ply|las) on the commands that write point clouds.
void add_format_option(CLI::App* app, std::string& format);
// "--json" with an output on stdout: the two would share it. kInvalidArgument then.
Status check_json_and_stdout(bool json, const std::vector<std::string>& outputs);

// Where summary lines go: stdout, or stderr when stdout carries the output data.
std::FILE* summary_stream(const std::vector<std::string>& outputs);

// read_point_cloud for a command: the reader's warnings (options.warnings is set here) are
// printed as "sspc: warning: ..." on stderr, after the progress line and before any error. "-"
// reads stdin, its format found from its first bytes.
StatusOr<PointCloud> read_cloud(const std::string& path, ReadOptions options);
// Several files read as one cloud (read_point_clouds), their warnings printed the same way; one
// file (or "-"): read_cloud.
StatusOr<PointCloud> read_clouds(const std::vector<std::filesystem::path>& paths, ReadOptions options);

// A progress reporter that draws on stderr only when it is a terminal and --quiet is off.
std::unique_ptr<TerminalProgress> make_progress(const GlobalOptions& global);

// "sspc: warning: OUT: <kept>; dropped <dropped>" on stderr ("stdout" for "-"), unless
// `dropped` is empty: what an output cannot hold is never lost silently.
void warn_dropped(const std::string& output, const std::string& kept, const std::string& dropped);

// Prints `text` and a newline to stdout.
void print_line(const std::string& text);

// Checks, before anything is read or written, that each of `outputs` may be written: "-" (stdout,
// at most once) may unless stdout is a terminal; any other output must be not one of
// the `inputs` (refused even with --force), not a directory, device, FIFO or socket (refused even
// with --force: the rename that commits an output would replace the node itself), a file name of
// at most NAME_MAX bytes in an existing, writable directory, no two outputs the same file, and
// no existing file unless `force`. At most one input may be "-" (stdin).
Status check_outputs(const std::vector<std::string>& inputs,
                     const std::vector<std::string>& outputs, bool force);

// A CLI11 validator for numbers in [lo, hi] (or (lo, hi] with `open_low`): NaN, infinities and
// text that is not wholly a number are usage errors, like any value out of range.
CLI::Validator number_in(double lo, double hi, bool open_low = false);

// A CLI11 validator for "x,y,z" triples and its parser.
std::optional<Vec3f> parse_vec3(const std::string& text);
extern const CLI::Validator kVec3Validator;

}  // namespace sspc::cli
