// sspc: compress scanned point clouds by self-similarity, decode any part, ray-trace them.
//
// Each subcommand lives in its own cmd_*.cpp; this file wires them together, applies the global
// options (--threads, --quiet) and maps outcomes to exit codes: 0 success, 1 failure, 2 usage.
#include <tbb/global_control.h>
#include <CLI/CLI.hpp>

#include <csignal>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "command.hpp"
#include "core/atomic_file.hpp"
#include "sspc/allocator.hpp"

namespace {

// The files a subcommand's command line names: its positional arguments and the options that
// take a file, for the "file" of a JSON error.
std::vector<std::string> files_named(const CLI::App& app) {
  std::vector<std::string> files;
  for (const CLI::Option* option : app.get_options()) {
    const bool file = option->get_positional() || option->check_lname("output") ||
                      option->check_lname("compressed") || option->check_lname("camera-path") ||
                      option->check_lname("compare") || option->check_lname("times");
    if (!file) continue;
    for (const std::string& value : option->results()) files.push_back(value);
  }
  return files;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace sspc::cli;
  // Ctrl-C or a full disk leaves the old output and no temporary file (core/atomic_file.hpp).
  sspc::remove_temporary_files_on_signals();
  // A reader that closes the pipe early makes writes to stdout fail with EPIPE, which is
  // reported and cleans up, instead of killing the process with a temporary file left behind.
  std::signal(SIGPIPE, SIG_IGN);
  CLI::App app("sspc: self-similarity compression and ray tracing of scanned point clouds");
  app.set_version_flag("--version", std::string("sspc ") + SSPC_VERSION);
  app.require_subcommand(1);
  app.fallthrough();  // global options are accepted after the subcommand too
  app.get_formatter()->column_width(34);

  GlobalOptions global;
  app.add_option("--threads", global.threads, "Worker threads (0: all cores)")
      ->check(CLI::Range(0, 1024).description(""))
      ->type_name("0..1024")
      ->capture_default_str();
  app.add_flag(
      "-q,--quiet", global.quiet,
      "No progress display, even on a terminal, and no summary line (--json still prints)");

  std::vector<Command> commands;
  commands.push_back(add_info_command(app, global));
  commands.push_back(add_normals_command(app, global));
  commands.push_back(add_eval_command(app, global));
  commands.push_back(add_encode_command(app, global));
  commands.push_back(add_decode_command(app, global));
  commands.push_back(add_verify_command(app, global));
  commands.push_back(add_render_command(app, global));
  commands.push_back(add_convert_command(app, global));

  // Positional arguments are files ("input FILE", not CLI11's "input TEXT").
  for (const Command& command : commands) {
    for (CLI::Option* option : command.app->get_options()) {
      if (option->get_positional()) option->type_name("FILE");
    }
  }

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);  // prints help, version, or the error
    if (code == 0) return kExitOk;
    // With --json the usage error is an error object too (docs/CLI.md).
    bool json = false;
    std::string command;
    for (int i = 1; i < argc; ++i) {
      json = json || std::strcmp(argv[i], "--json") == 0;
      for (const Command& c : commands) {
        if (command.empty() && c.app->get_name() == argv[i]) command = argv[i];
      }
    }
    if (json) print_json(json_error(command, e.what(), {}));
    return kExitUsage;
  }

  std::unique_ptr<tbb::global_control> threads;
  if (global.threads > 0) {
    threads = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                    static_cast<std::size_t>(global.threads));
  }
  for (const Command& command : commands) {
    if (command.app->parsed()) {
      // Freed blocks reused, not faulted in again (sspc/allocator.hpp); under --memory-limit the
      // tiles are sized with what that keeps (tile_points_for_memory). Not for render, whose
      // --memory-budget is what the process holds: kept, the frame's buffers and every brick's
      // build stayed resident (autzen level 5, 1024², 64 MiB: 137 MB against 69 MB of scene).
      if (command.app->get_name() != "render") sspc::keep_freed_memory();
      const CLI::Option* json = command.app->get_option_no_throw("--json");
      if (json != nullptr && json->count() > 0)
        report_errors_as_json(command.app->get_name(), files_named(*command.app));
      const int code = command.run();
      std::fflush(stdout);
      return code;
    }
  }
  return kExitUsage;
}
