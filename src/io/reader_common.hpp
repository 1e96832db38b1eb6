// What the point cloud readers share: how errors name the file and the place in it, the final
// checks every cloud passes before a reader returns it, and the reader entry points that take
// ReadOptions (progress, warnings, positions in double; the public ones in sspc/io.hpp pass the
// defaults).
#pragma once

#include <cstddef>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "sspc/io.hpp"
#include "sspc/point_cloud.hpp"
#include "sspc/progress.hpp"
#include "sspc/status.hpp"

namespace sspc::io {

// "bunny.ply: line 12: what"
Status error_at_line(StatusCode code, std::string_view name, std::size_t line,
                     std::string_view what);
// "bunny.ply: byte offset 1234: what"
Status error_at_offset(StatusCode code, std::string_view name, std::size_t offset,
                       std::string_view what);
// "bunny.ply: what"
Status error_in(StatusCode code, std::string_view name, std::string_view what);
// Prefixes a status from a lower layer (the byte reader, the LZF decoder) with the file name.
Status in_file(const Status& status, std::string_view name);

// The index of the first point from `begin` on whose position or normal has a NaN or infinite
// component. Runs in parallel; the answer does not depend on the thread count.
std::optional<std::size_t> first_non_finite_point(const PointCloud& cloud, std::size_t begin = 0);

// kInvalidArgument naming the file, the point, its values and, when not empty, `where` ("line 7",
// "byte offset 96") so that the user can find it. `first` is the number in the file of the
// cloud's point 0 when the cloud holds a chunk of it (read_point_cloud_chunks), so that the
// message numbers points as the whole file does.
Status non_finite_error(std::string_view name, const PointCloud& cloud, std::size_t index,
                        std::string_view where, std::size_t first = 0);

// The checks that end every reader: at least one point (kInvalidArgument otherwise), attribute
// arrays as long as the positions. Finite values are checked by each reader, which knows where
// each point came from.
Status finish_cloud(const PointCloud& cloud, std::string_view name);

// Reader entry points: progress in bytes consumed (stage opened by the caller), warnings and
// the positions in double as ReadOptions describes them. `options.format` is not looked at.
StatusOr<PointCloud> read_ply_with_options(std::span<const std::byte> data, std::string_view name,
                                           const ReadOptions& options);
StatusOr<PointCloud> read_xyz_with_options(std::span<const std::byte> data, std::string_view name,
                                           const ReadOptions& options);
StatusOr<PointCloud> read_pcd_with_options(std::span<const std::byte> data, std::string_view name,
                                           const ReadOptions& options);
StatusOr<PointCloud> read_las_with_options(std::span<const std::byte> data, std::string_view name,
                                           const ReadOptions& options);

// What the six columns of an XYZ file hold: guessed from the values (.xyz), or named by the
// extension (.xyzrgb, .xyzn).
enum class XyzSixColumns { kGuess, kColours, kNormals };
StatusOr<PointCloud> read_xyz_columns(std::span<const std::byte> data, std::string_view name,
                                      const ReadOptions& options, XyzSixColumns six);

// Views bytes as text without copying.
inline std::string_view as_text(std::span<const std::byte> data) {
  return {reinterpret_cast<const char*>(data.data()), data.size()};
}

}  // namespace sspc::io
