#include "command.hpp"

#include <cerrno>
#include <charconv>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

namespace sspc::cli {

int report_failure(const Status& status) {
  std::fprintf(stderr, "sspc: error: %s\n", status.message().c_str());
  return kExitFailure;
}

StatusOr<PointCloud> read_cloud(const std::string& path, ReadOptions options) {
  std::vector<std::string> warnings;
  options.warnings = &warnings;
  StatusOr<PointCloud> cloud = read_point_cloud(path, options);
  for (const std::string& warning : warnings) {
    std::fprintf(stderr, "sspc: warning: %s\n", warning.c_str());
  }
  return cloud;
}

std::unique_ptr<TerminalProgress> make_progress(const GlobalOptions& global) {
  if (global.quiet) return std::make_unique<TerminalProgress>(stderr, false);
  return std::make_unique<TerminalProgress>(stderr);
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

Status check_outputs(const std::vector<std::string>& inputs, const std::vector<std::string>& outputs, bool force) {
  namespace fs = std::filesystem;
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    const std::string& out = outputs[i];
    const fs::path path(out);
    if (out.empty()) return invalid_argument("an output file name is empty");
    if (path.filename().empty()) return invalid_argument(out + ": names a directory, not a file");
    if (path.filename().native().size() > NAME_MAX) {
      return invalid_argument(out + ": the file name is longer than " + std::to_string(NAME_MAX) + " bytes");
    }
    std::error_code ec;
    const fs::file_status status = fs::status(path, ec);
    const bool exists = fs::exists(status);
    if (exists) {
      for (const std::string& in : inputs) {
        std::error_code same_ec;
        if (fs::equivalent(in, path, same_ec)) return invalid_argument(out + ": is the input; refusing to overwrite it");
      }
      if (!fs::is_regular_file(status)) {
        return invalid_argument(out + ": is " + node_kind(status) + "; sspc writes only regular files");
      }
      if (!force) return invalid_argument(out + ": exists; pass -f/--force to overwrite it");
    }
    const fs::path dir = path.parent_path().empty() ? fs::path(".") : path.parent_path();
    const fs::file_status dir_status = fs::status(dir, ec);
    if (!fs::is_directory(dir_status)) {
      return invalid_argument(out + ": the folder " + dir.string() + (fs::exists(dir_status) ? " is not a folder" : " does not exist"));
    }
    if (::access(dir.c_str(), W_OK | X_OK) != 0) {
      return io_error(out + ": cannot write in " + dir.string() + ": " + std::strerror(errno));
    }
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
        if (end == begin || *end != '\0' || !std::isfinite(v)) return "'" + text + "' is not a finite number";
        if (v < lo || v > hi || (open_low && v == lo)) return "'" + text + "' is outside " + name;
        return std::string();
      },
      "NUMBER in " + name);
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
    "X,Y,Z");

}  // namespace sspc::cli
