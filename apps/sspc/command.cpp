#include "command.hpp"

#include <charconv>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

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
