// sspc: compress scanned point clouds by self-similarity, decode any part, ray-trace them.
//
// Each subcommand lives in its own cmd_*.cpp; this file wires them together, applies the global
// options (--threads, --quiet) and maps outcomes to exit codes: 0 success, 1 failure, 2 usage.
#include <tbb/global_control.h>
#include <CLI/CLI.hpp>

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#if defined(__linux__)
#include <unistd.h>
#endif

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

// Runs the program again with glibc's malloc asking for transparent huge pages
// (GLIBC_TUNABLES=glibc.malloc.hugetlb=1), where the kernel gives them only on request
// (transparent_hugepage "madvise", Debian's default). Large arrays then take a 2 MiB page where
// they took 512 small ones: fewer page faults, and far fewer TLB misses in the neighbour searches
// over the whole cloud. Encoding autzen at level 5 on 2 cores: 47.7 s -> 43.6 s (user 74.4 ->
// 70.4 s, system 4.0 -> 3.3 s), the same peak resident size (1.40 GB). glibc reads its tunables
// only when a process starts, hence the second start; the variable, once set (here or by the
// user), stops a third. Returns only where that is not done (the exec failed, or not needed).
void restart_with_huge_pages(char** argv) {
#if defined(__linux__) && defined(__GLIBC__) && !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  if (tunables != nullptr && std::strstr(tunables, "glibc.malloc.hugetlb") != nullptr) return;
  std::ifstream policy("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string line;
  if (!std::getline(policy, line) || line.find("[madvise]") == std::string::npos) return;
  const std::string value = tunables != nullptr && *tunables != '\0'
                                ? std::string(tunables) + ":glibc.malloc.hugetlb=1"
                                : std::string("glibc.malloc.hugetlb=1");
  if (::setenv("GLIBC_TUNABLES", value.c_str(), 1) != 0) return;
  ::execv("/proc/self/exe", argv);  // returns only on failure: carry on as we are
#else
  (void)argv;
#endif
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
      // The same commands run on transparent huge pages (restart_with_huge_pages).
      if (command.app->get_name() != "render") {
        restart_with_huge_pages(argv);
        sspc::keep_freed_memory();
      } else {
        sspc::use_one_arena();  // the budget held, not one in each thread's arena
      }
      const CLI::Option* json = command.app->get_option_no_throw("--json");
      if (json != nullptr && json->count() > 0)
        report_errors_as_json(command.app->get_name(), files_named(*command.app));
      const int code = command.run();
      // What a command printed (a report, --json) is its output: a stdout that cannot take it
      // (a full disk, /dev/full, a closed file) fails the command, as a file output would.
      errno = 0;
      if (std::fflush(stdout) != 0 || std::ferror(stdout) != 0) {
        const int error = errno;
        std::fprintf(stderr, "sspc: error: stdout: %s; the output was not written whole\n",
                     error != 0 ? std::strerror(error) : "write error");
        return code == kExitOk ? kExitFailure : code;
      }
      return code;
    }
  }
  return kExitUsage;
}
