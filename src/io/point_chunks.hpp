// Reading a file's points a chunk at a time (read_point_cloud_chunks in sspc/io.hpp): the
// interface that the body parsers share with the whole-file readers, and the loop that cuts what
// they read into chunks and hands the file's pages back to the kernel behind it.
//
// Where the whole-file reader decides something from every point before it can give any (an
// origin for georeferenced coordinates, which LAS fields to keep, what six XYZ columns hold), the
// chunked reader makes a first pass over the file with the same parser, keeping only what that
// decision needs, then a second pass that hands the points on.
#pragma once

#include <cstddef>
#include <functional>
#include <string_view>

#include "core/mapped_file.hpp"
#include "io/reader_common.hpp"
#include "sspc/io.hpp"
#include "sspc/point_cloud.hpp"
#include "sspc/status.hpp"

namespace sspc::io {

// A body parser that resumes where it stopped: the whole-file reader asks it for every point at
// once, the chunked reader for a chunk's worth at a time, and both get the same points and the
// same errors, numbered (points, lines, byte offsets) as in the whole file.
class PointReader {
 public:
  virtual ~PointReader() = default;

  // Appends the next points, at most `max_points` (at least 1), to `out`. It may append fewer,
  // or none, when it stops after a bounded stretch of data that holds no points (a PLY face
  // list), so that the pages behind it can be released. Once the points run out it checks what
  // follows them (trailing bytes, a declared count) and becomes done().
  virtual Status read(std::size_t max_points, PointCloud& out) = 0;
  virtual bool done() const = 0;
  // The offset in the file before which nothing will be looked at again.
  virtual std::size_t consumed() const = 0;
};

// What every format's chunked reader is given.
struct ChunkedRead {
  const MappedFile& file;
  std::string_view name;
  std::size_t chunk_points = 0;
  const std::function<Status(PointCloud&&)>& sink;
  const ReadOptions& options;
};

// Receives a chunk and the number in the file of its first point; may move from the chunk.
using ChunkHandler = std::function<Status(PointCloud& chunk, std::size_t first)>;

// Reads `reader` to its end in chunks of `chunk_points` points (the last one shorter; none when
// the file has no points), each handed to `handle`, and releases the pages of `file` behind the
// reader as it goes: after each chunk is handled, so that the handler may read the chunk's bytes
// without bringing them back. A chunk the handler leaves in place is emptied and its memory
// reused for the next one: a first pass, or a sink that only looks, then faults in no new pages
// for each chunk, which costs more than decoding it. Stops at the first error, the handler's
// included. Returns the number of points read.
StatusOr<std::size_t> read_in_chunks(PointReader& reader, const MappedFile& file,
                                     std::size_t chunk_points, const ChunkHandler& handle);

// The passes of a chunked read, each a progress stage over the file's bytes: "scanning NAME" for
// a first pass, which gathers what the points depend on, "reading NAME" for the pass whose chunks
// go to the sink.
enum class Pass { kScan, kRead };
StatusOr<std::size_t> run_pass(const ChunkedRead& in, Pass pass, PointReader& reader,
                               const ChunkHandler& handle);

// Each format's chunked reader; the chunks concatenated are what its whole-file reader gives.
// The PLY reader makes a first pass when positions are stored wider than float32; the LAS reader
// always makes one (the origin, the fields kept and the colour scale depend on every record), and
// so does the XYZ reader (the origin, what six columns hold, a PTS count).
Status read_ply_chunks(const ChunkedRead& in);
Status read_las_chunks(const ChunkedRead& in);
Status read_xyz_chunks(const ChunkedRead& in, XyzSixColumns six);

// For formats read whole (PCD): hands `cloud` to `sink` in chunks of `chunk_points` points, each
// with the cloud's origin and metadata.
Status hand_out_in_chunks(PointCloud cloud, std::size_t chunk_points,
                          const std::function<Status(PointCloud&&)>& sink);

}  // namespace sspc::io
