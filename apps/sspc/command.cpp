#include "command.hpp"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <optional>
#include <span>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "core/atomic_file.hpp"

namespace sspc::cli {

namespace {

// Set by report_errors_as_json.
struct JsonErrors {
  bool on = false;
  std::string command;
  std::vector<std::string> files;
};
JsonErrors& json_errors() {
  static JsonErrors errors;
  return errors;
}

// Which of `files` a message is about: the longest that heads it ("x.ply: ..."; "-" is named
// "stdin"), else the first it mentions.
const std::string* file_of(const std::string& message, const std::vector<std::string>& files) {
  const std::string* best = nullptr;
  std::size_t best_size = 0;
  for (const std::string& f : files) {
    const std::string name = is_stdio(f) ? kStdinName : f;
    if (!name.empty() && message.starts_with(name + ":") && name.size() > best_size) {
      best = &f;
      best_size = name.size();
    }
  }
  if (best != nullptr) return best;
  for (const std::string& f : files) {
    if (!f.empty() && !is_stdio(f) && message.find(f) != std::string::npos) return &f;
  }
  return nullptr;
}

int report(const Status& status, int code) {
  std::fprintf(stderr, "sspc: error: %s\n", status.message().c_str());
  const JsonErrors& errors = json_errors();
  if (errors.on) print_json(json_error(errors.command, status.message(), errors.files));
  return code;
}

}  // namespace

int report_failure(const Status& status) {
  return report(status, kExitFailure);
}
int report_usage_error(const Status& status) {
  return report(status, kExitUsage);
}

Json json_report(std::string_view command) {
  Json json;
  json["schema"] = kJsonSchema;
  json["command"] = std::string(command);
  return json;
}

Json json_vec3(const Vec3d& v) {
  return Json::array({v.x(), v.y(), v.z()});
}
Json json_vec3(const Vec3f& v) {
  return json_vec3(Vec3d(v.cast<double>()));
}

void print_json(const Json& json) {
  print_line(json.dump(-1, ' ', false, Json::error_handler_t::replace));
}

void report_errors_as_json(std::string command, std::vector<std::string> files) {
  json_errors() = JsonErrors{true, std::move(command), std::move(files)};
}

Json json_error(std::string_view command, const std::string& message,
                const std::vector<std::string>& files) {
  Json json = json_report(command);
  json["error"] = message;
  const std::string* file = file_of(message, files);
  json["file"] = file != nullptr ? Json(*file) : Json(nullptr);
  return json;
}

StatusOr<std::span<const std::byte>> stdin_bytes() {
  static std::optional<std::string> bytes;
  if (!bytes) {
    if (::isatty(STDIN_FILENO) != 0) {
      return invalid_argument(
          "stdin: is a terminal; pipe a file in, or name the file instead of '-'");
    }
    std::string data;
    char buffer[1 << 16];
    for (;;) {
      const ssize_t n = ::read(STDIN_FILENO, buffer, sizeof buffer);
      if (n == 0) break;
      if (n < 0) {
        if (errno == EINTR) continue;
        return io_error(std::string("stdin: ") + std::strerror(errno));
      }
      data.append(buffer, static_cast<std::size_t>(n));
    }
    bytes = std::move(data);
  }
  return std::as_bytes(std::span(bytes->data(), bytes->size()));
}

StatusOr<CompressedModel> open_model(const std::string& path) {
  if (!is_stdio(path)) return CompressedModel::open(path);
  SSPC_ASSIGN_OR_RETURN(const std::span<const std::byte> bytes, stdin_bytes());
  auto model = CompressedModel::from_bytes(
      std::string(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
  if (!model.ok()) return model.status().with_context(kStdinName);
  return model;
}

namespace {

// Copies `path`'s bytes to stdout; every short write and error is checked (a closed pipe is
// EPIPE here: main ignores SIGPIPE so that the temporary file is still removed).
Status copy_to_stdout(const std::filesystem::path& path) {
  std::FILE* in = std::fopen(path.c_str(), "rb");
  if (in == nullptr) return io_error(path.string() + ": " + std::strerror(errno));
  std::fflush(stdout);
  char buffer[1 << 16];
  Status status;
  for (;;) {
    const std::size_t n = std::fread(buffer, 1, sizeof buffer, in);
    if (n > 0 && std::fwrite(buffer, 1, n, stdout) != n) {
      status = io_error(std::string("stdout: ") + std::strerror(errno));
      break;
    }
    if (n < sizeof buffer) {
      if (std::ferror(in)) status = io_error(path.string() + ": read failed");
      break;
    }
  }
  std::fclose(in);
  if (status.ok() && std::fflush(stdout) != 0)
    status = io_error(std::string("stdout: ") + std::strerror(errno));
  return status;
}

}  // namespace

Status write_output(const std::string& output, const std::string& extension,
                    const std::function<Status(const std::filesystem::path&)>& write) {
  if (!is_stdio(output)) return write(output);
  std::error_code ec;
  const std::filesystem::path dir = std::filesystem::temp_directory_path(ec);
  if (ec) return io_error("stdout: no temporary folder: " + ec.message());
  // Removed when done, and by the signal handlers if the command is interrupted.
  auto scratch = TemporaryFile::create(dir, "sspc-stdout-", extension);
  if (!scratch.ok()) return scratch.status().with_context("stdout");
  Status status = write(scratch->path());
  if (status.ok()) status = copy_to_stdout(scratch->path());
  return status;
}

std::string cloud_extension(const std::string& output, const std::string& format) {
  if (is_stdio(output)) return "." + format;
  return std::filesystem::path(output).extension().string();
}

void add_format_option(CLI::App* app, std::string& format) {
  app->add_option("--format", format, "Format of an output written to stdout ('-')")
      ->check(CLI::IsMember({"ply", "las"}).description(""))
      ->type_name("ply|las")
      ->capture_default_str();
}

Status check_json_and_stdout(bool json, const std::vector<std::string>& outputs) {
  if (!json) return Status();
  for (const std::string& out : outputs) {
    if (is_stdio(out))
      return invalid_argument("--json and an output on stdout ('-') cannot share it; choose one");
  }
  return Status();
}

std::FILE* summary_stream(const std::vector<std::string>& outputs) {
  for (const std::string& out : outputs) {
    if (is_stdio(out)) return stderr;
  }
  return stdout;
}

StatusOr<PointCloud> read_cloud(const std::string& path, ReadOptions options) {
  std::vector<std::string> warnings;
  options.warnings = &warnings;
  StatusOr<PointCloud> cloud = invalid_argument("nothing read");
  if (is_stdio(path)) {
    auto bytes = stdin_bytes();
    cloud = bytes.ok() ? read_point_cloud(*bytes, kStdinName, options)
                       : StatusOr<PointCloud>(bytes.status());
  } else {
    cloud = read_point_cloud(path, options);
  }
  for (const std::string& warning : warnings) {
    std::fprintf(stderr, "sspc: warning: %s\n", warning.c_str());
  }
  return cloud;
}

StatusOr<PointCloud> read_clouds(const std::vector<std::filesystem::path>& paths, ReadOptions options) {
  if (paths.size() == 1) return read_cloud(paths.front().string(), options);
  std::vector<std::string> warnings;
  options.warnings = &warnings;
  StatusOr<PointCloud> cloud = read_point_clouds(paths, options);
  for (const std::string& warning : warnings) std::fprintf(stderr, "sspc: warning: %s\n", warning.c_str());
  return cloud;
}

std::unique_ptr<TerminalProgress> make_progress(const GlobalOptions& global) {
  if (global.quiet) return std::make_unique<TerminalProgress>(stderr, false);
  return std::make_unique<TerminalProgress>(stderr);
}

void warn_dropped(const std::string& output, const std::string& kept, const std::string& dropped) {
  if (dropped.empty()) return;
  std::fprintf(stderr, "sspc: warning: %s: %s; dropped %s\n", is_stdio(output) ? "stdout" : output.c_str(),
               kept.c_str(), dropped.c_str());
}

void print_line(const std::string& text) {
  std::fwrite(text.data(), 1, text.size(), stdout);
  std::fputc('\n', stdout);
}

namespace {

// What kind of file system node `status` describes, for messages.
const char* node_kind(const std::filesystem::file_status& status) {
  switch (status.type()) {
    case std::filesystem::file_type::directory: return "a directory";
    case std::filesystem::file_type::character: return "a character device";
    case std::filesystem::file_type::block: return "a block device";
    case std::filesystem::file_type::fifo: return "a FIFO";
    case std::filesystem::file_type::socket: return "a socket";
    default: return "not a regular file";
  }
}

}  // namespace

namespace {

// What runs killed beyond a handler's reach (SIGKILL) left beside an output: removed when their
// owner is gone, named when sspc cannot tell.
void report_stale_temporaries(const std::filesystem::path& dir) {
  const StaleTemporaries stale = remove_stale_temporaries(dir);
  for (const auto& path : stale.removed) {
    std::fprintf(stderr, "sspc: note: removed %s, left by an interrupted run\n", path.c_str());
  }
  for (const auto& path : stale.unknown) {
    std::fprintf(stderr, "sspc: warning: %s looks left by an interrupted run of an older sspc; remove it if no sspc is "
                 "running\n", path.c_str());
  }
}

}  // namespace

Status check_outputs(const std::vector<std::string>& inputs,
                     const std::vector<std::string>& outputs, bool force) {
  namespace fs = std::filesystem;
  if (std::count_if(inputs.begin(), inputs.end(), is_stdio) > 1) {
    return invalid_argument("'-' (stdin) names more than one input; stdin can be read only once");
  }
  if (std::count_if(outputs.begin(), outputs.end(), is_stdio) > 1) {
    return invalid_argument("'-' (stdout) names more than one output");
  }
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    const std::string& out = outputs[i];
    if (is_stdio(out)) {
      // As zstd does: binary data on a terminal helps no one.
      if (::isatty(STDOUT_FILENO) != 0) {
        return invalid_argument(
            "'-': stdout is a terminal; redirect it to a file or a pipe, or name the output");
      }
      continue;  // a pipe or a file the shell opened, never renamed over
    }
    const fs::path path(out);
    if (out.empty()) return invalid_argument("an output file name is empty");
    if (path.filename().empty()) return invalid_argument(out + ": names a directory, not a file");
    if (path.filename().native().size() > NAME_MAX) {
      return invalid_argument(out + ": the file name is longer than " + std::to_string(NAME_MAX) +
                              " bytes");
    }
    std::error_code ec;
    const fs::file_status status = fs::status(path, ec);
    const bool exists = fs::exists(status);
    if (exists) {
      for (const std::string& in : inputs) {
        if (is_stdio(in)) continue;
        std::error_code same_ec;
        if (fs::equivalent(in, path, same_ec))
          return invalid_argument(out + ": is the input; refusing to overwrite it");
      }
      if (!fs::is_regular_file(status)) {
        return invalid_argument(out + ": is " + node_kind(status) +
                                "; sspc writes only regular files");
      }
      if (!force) return invalid_argument(out + ": exists; pass -f/--force to overwrite it");
    }
    const fs::path dir = path.parent_path().empty() ? fs::path(".") : path.parent_path();
    const fs::file_status dir_status = fs::status(dir, ec);
    if (!fs::is_directory(dir_status)) {
      return invalid_argument(out + ": the folder " + dir.string() +
                              (fs::exists(dir_status) ? " is not a folder" : " does not exist"));
    }
    if (::access(dir.c_str(), W_OK | X_OK) != 0) {
      return io_error(out + ": cannot write in " + dir.string() + ": " + std::strerror(errno));
    }
    report_stale_temporaries(dir);
    for (std::size_t j = 0; j < i; ++j) {
      std::error_code a, b;
      if (fs::weakly_canonical(outputs[j], a) == fs::weakly_canonical(path, b)) {
        return invalid_argument(out + ": named twice as an output");
      }
    }
  }
  return Status();
}

CLI::Validator number_in(double lo, double hi, bool open_low) {
  char range[96];
  std::snprintf(range, sizeof range, "%s%g, %g]", open_low ? "(" : "[", lo, hi);
  const std::string name = range;
  return CLI::Validator(
      [lo, hi, open_low, name](std::string& text) -> std::string {
        const char* begin = text.c_str();
        char* end = nullptr;
        errno = 0;
        const double v = std::strtod(begin, &end);
        if (end == begin || *end != '\0' || !std::isfinite(v))
          return "'" + text + "' is not a finite number";
        if (v < lo || v > hi || (open_low && v == lo)) return "'" + text + "' is outside " + name;
        return std::string();
      },
      "");  // the option's type name shows the range in --help
}

std::optional<Vec3f> parse_vec3(const std::string& text) {
  Vec3f v;
  const char* p = text.data();
  const char* end = text.data() + text.size();
  for (int i = 0; i < 3; ++i) {
    while (p < end && *p == ' ') ++p;
    float x = 0;
    const auto r = std::from_chars(p, end, x);
    if (r.ec != std::errc() || !std::isfinite(x)) return std::nullopt;
    v[i] = x;
    p = r.ptr;
    while (p < end && *p == ' ') ++p;
    if (i < 2) {
      if (p == end || *p != ',') return std::nullopt;
      ++p;
    }
  }
  if (p != end) return std::nullopt;
  return v;
}

const CLI::Validator kVec3Validator(
    [](std::string& text) -> std::string {
      return parse_vec3(text) ? std::string() : "expected three finite numbers x,y,z";
    },
    "");  // the options name their type X,Y,Z

}  // namespace sspc::cli
