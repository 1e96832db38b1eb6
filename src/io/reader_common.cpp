#include "io/reader_common.hpp"

#include <algorithm>
#include <atomic>
#include <charconv>
#include <limits>

#include "core/parallel.hpp"

namespace sspc::io {

// Every message goes through Status::with_context, so a reader given no name (bytes from
// memory) says "line 12: what", not ": line 12: what".
Status error_at_line(StatusCode code, std::string_view name, std::size_t line,
                     std::string_view what) {
  return error_in(code, name, "line " + std::to_string(line) + ": " + std::string(what));
}

Status error_at_offset(StatusCode code, std::string_view name, std::size_t offset,
                       std::string_view what) {
  return error_in(code, name, "byte offset " + std::to_string(offset) + ": " + std::string(what));
}

Status error_in(StatusCode code, std::string_view name, std::string_view what) {
  return Status(code, std::string(what)).with_context(std::string(name));
}

Status in_file(const Status& status, std::string_view name) {
  return status.with_context(std::string(name));
}

std::optional<std::size_t> first_non_finite_point(const PointCloud& cloud, std::size_t begin) {
  constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();
  std::atomic<std::size_t> first{kNone};
  const bool normals = cloud.normals.size() == cloud.positions.size();
  const std::size_t from = std::min(begin, cloud.size());
  parallel_for_ranges(from, cloud.size(), 1 << 16, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e && i < first.load(std::memory_order_relaxed); ++i) {
      if (!cloud.positions[i].allFinite() || (normals && !cloud.normals[i].allFinite())) {
        // Keep the smallest index whichever range finds one first.
        std::size_t seen = first.load();
        while (i < seen && !first.compare_exchange_weak(seen, i)) {
        }
        return;
      }
    }
  });
  const std::size_t found = first.load();
  if (found == kNone) return std::nullopt;
  return found;
}

namespace {
std::string format_vec(const Vec3f& v) {
  std::string out = "(";
  for (int k = 0; k < 3; ++k) {
    char buf[32];
    const auto res = std::to_chars(buf, buf + sizeof buf, v[k]);
    out.append(buf, res.ptr);
    out += k < 2 ? ", " : ")";
  }
  return out;
}
}  // namespace

Status non_finite_error(std::string_view name, const PointCloud& cloud, std::size_t index,
                        std::string_view where, std::size_t first) {
  const bool position_bad = !cloud.positions[index].allFinite();
  const std::string what = "point " + std::to_string(first + index) + " has a non-finite " +
                           (position_bad ? "coordinate " + format_vec(cloud.positions[index])
                                         : "normal " + format_vec(cloud.normals[index]));
  return invalid_argument(what).with_context(std::string(where)).with_context(std::string(name));
}

Status finish_cloud(const PointCloud& cloud, std::string_view name) {
  if (cloud.empty())
    return error_in(StatusCode::kInvalidArgument, name, "the file holds no points");
  if ((cloud.has_normals() && cloud.normals.size() != cloud.size()) ||
      (cloud.has_colours() && cloud.colours.size() != cloud.size())) {
    return error_in(StatusCode::kInternal, name,
                    "reader produced attribute arrays of the wrong length");
  }
  return Status();
}

}  // namespace sspc::io
