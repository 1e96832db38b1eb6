// The two ways a PLY body is stored: binary (either byte order) and ascii. Both walk every
// element in header order, read the vertex element into the cloud and skip the others, so a
// face list before or after the vertices is checked for truncation but otherwise ignored.
#pragma once

#include <cstddef>
#include <memory>
#include <span>
#include <string_view>

#include "io/ply_header.hpp"
#include "io/ply_vertex_layout.hpp"
#include "io/point_chunks.hpp"
#include "io/wide_positions.hpp"
#include "sspc/point_cloud.hpp"
#include "sspc/progress.hpp"
#include "sspc/status.hpp"

namespace sspc::io {

// Where a body reader reports besides the cloud: progress in bytes, and each position as stored
// when `wide->wanted()`.
struct PlyBodySinks {
  Progress* progress = nullptr;
  WidePositions* wide = nullptr;
};

// Both are PointReaders (io/point_chunks.hpp) over the vertex element: asked for every point at
// once they read the whole body, asked for fewer they stop there and resume on the next call.
// Other elements are walked at most `max_points` items a call. The reader keeps references to
// `header`, `layout`, `name` and the sinks.

// Binary bodies. Errors are kCorrupt with the byte offset. Bytes after the last element are an
// error, as in ascii bodies, since they mean the counts in the header are wrong; the one
// exception is a single "\n" or "\r\n", which many writers end every file with.
std::unique_ptr<PointReader> make_ply_binary_body(std::span<const std::byte> file,
                                                  const PlyHeader& header,
                                                  const PlyVertexLayout& layout,
                                                  std::string_view name, const PlyBodySinks& sinks);

// Ascii bodies: one element item per line, blank lines ignored. Errors are kParseError with the
// line number; anything but whitespace after the last element is an error, since it means the
// counts in the header are wrong.
std::unique_ptr<PointReader> make_ply_ascii_body(std::span<const std::byte> file,
                                                 const PlyHeader& header,
                                                 const PlyVertexLayout& layout,
                                                 std::string_view name, const PlyBodySinks& sinks);

}  // namespace sspc::io
