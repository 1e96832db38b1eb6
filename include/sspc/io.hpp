// Reading and writing point clouds: PLY (ascii, binary little and big endian), XYZ/PTS text,
// PCL's PCD (ascii, binary, binary_compressed) and LAS 1.0-1.4 (point formats 0-10; LAZ and
// COPC are refused with the command that decompresses them).
//
// Coordinates far from zero (georeferenced scans) get an origin: the cloud holds float32 local
// positions and a double origin (sspc/point_cloud.hpp), and writers write origin + position.
//
// Safe on untrusted input: every reader bounds-checks what it reads, never trusts a count in a
// header beyond what the file's size can hold, rejects NaN and infinite coordinates, and reports
// the file name with the line (text) or byte offset (binary) of the first problem. Writers go
// through a temporary file and a rename, so a failed write leaves no partial output.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "sspc/point_cloud.hpp"
#include "sspc/progress.hpp"
#include "sspc/status.hpp"

namespace sspc {

// kXyzRgb and kXyzN are XYZ text whose six columns the extension names (Open3D's .xyzrgb, with
// colours as 0..1 floats or 0..255 integers, and .xyzn); plain kXyz guesses (xyz_reader.cpp).
enum class PointCloudFormat { kAuto, kPly, kXyz, kPcd, kLas, kXyzRgb, kXyzN };

// "ply", "xyz", "pcd", "las" and "laz" (and "pts", "txt" for xyz, "xyzrgb", "xyzn"); kAuto for
// anything else.
PointCloudFormat format_from_extension(const std::filesystem::path& path);

struct ReadOptions {
  PointCloudFormat format = PointCloudFormat::kAuto;  // kAuto: by extension, else by content
  Progress* progress = nullptr;
  // Where to append warnings about a file that reads but loses something on the way, one line
  // each, starting with the file name (the CLI prints them as "sspc: warning: ..."). nullptr:
  // none are looked for. Today there is one: coordinates that float32, the precision of
  // PointCloud::positions, cannot hold to the cloud's own detail, as when a georeferenced scan
  // keeps its offset ("bunny.ply: coordinates reach 4000000.1 on y but the cloud spans only
  // 0.15: float32 keeps steps of 0.25 there, ..."). The rule is in src/io/wide_positions.hpp.
  std::vector<std::string>* warnings = nullptr;
  // When not null, replaced by the positions as the file stores them, in double, index for
  // index with the cloud's: exact for every stored type but 64-bit integers beyond 2^53; text
  // is rounded once, to the nearest double. For work that needs more than float32 far from the
  // origin (sspc eval).
  std::vector<Vec3d>* positions_f64 = nullptr;
};

// Reads a point cloud file. An empty cloud is an error (kInvalidArgument): no sspc command
// has anything to do with one.
StatusOr<PointCloud> read_point_cloud(const std::filesystem::path& path,
                                      const ReadOptions& options = {});

// The same over bytes in memory (a pipe read whole): the reader options.format names, else the
// one the first bytes look like (extensions play no part); `name` ("stdin") heads messages.
StatusOr<PointCloud> read_point_cloud(std::span<const std::byte> data, std::string_view name,
                                      const ReadOptions& options = {});

// Reads `path` in file order as chunks of at most `chunk_points` points, handing each to `sink`
// (which may keep or move it); stops at the first error, the sink's included. The chunks
// concatenated are exactly read_point_cloud(path, options)'s cloud: same positions (bit for bit),
// normals, colours, LAS attributes, and every chunk carries the same origin and metadata. Memory
// stays O(chunk_points) whatever the file's size (pages of the file already consumed are released).
//
// A chunk the sink does not move from is emptied and its memory reused for the next one.
//
// Errors are the whole reader's, with the same file name, line or byte offset and point number;
// chunks handed on before an error are the cloud's first points. Where the whole reader decides
// from every point (an origin for georeferenced coordinates, which LAS fields to keep and how its
// colours scale, what six XYZ columns hold), a first pass over the file with the same parser
// gathers what the decision needs, and reports any parse error before a chunk is handed on: LAS
// and XYZ files are always read twice, PLY files when positions are stored wider than float32.
// Progress then shows two stages, "scanning NAME" and "reading NAME", each over the file's bytes.
// PCD files are read whole and then handed on in chunks: their memory is the whole cloud's.
// kInvalidArgument for chunk_points == 0 and for options.positions_f64, which is not given in
// chunks.
Status read_point_cloud_chunks(const std::filesystem::path& path, std::size_t chunk_points,
                               const std::function<Status(PointCloud&&)>& sink,
                               const ReadOptions& options = {});

// --- Several files as one cloud (a survey's tiles) -----------------------------------------------

// The files named by command-line arguments: a file as it is; a folder's point-cloud files (by
// extension), sorted by name; a pattern with * ? or [ that names no file, expanded by glob(3),
// sorted. kInvalidArgument for a folder or pattern with no file, and for a file named twice.
StatusOr<std::vector<std::filesystem::path>> input_files(std::span<const std::string> args);

// The one origin of a set of files, from each file's own origin, local bounds and metadata (given
// in order): the files' origin when they share one (their positions then stay bit for bit),
// else the centre of their union rounded as a single file's reader rounds it (the largest power
// of ten not above the union's extent), so that the set keeps a single file's precision.
// origin() is kInvalidArgument, naming the file, when the files' CRSs differ.
class FileSetOrigin {
 public:
  void add(const std::filesystem::path& file, const Vec3d& origin, const Box3f& local, const CloudMetadata& metadata);
  StatusOr<Vec3d> origin() const;

 private:
  std::size_t files_ = 0;
  bool same_origin_ = true;
  Vec3d first_origin_ = Vec3d::Zero();
  std::string first_file_, crs_differs_, crs_wkt_;
  std::vector<LasRecord> crs_records_;
  Vec3d world_min_ = Vec3d::Constant(std::numeric_limits<double>::infinity());
  Vec3d world_max_ = Vec3d::Constant(-std::numeric_limits<double>::infinity());
};

// Re-expresses `cloud`'s positions about `origin` (in double, narrowed once to float32).
void move_to_origin(PointCloud& cloud, const Vec3d& origin);

// The files' points one file after another, in the order given, about the set's origin
// (FileSetOrigin), with the metadata of the first and the per-point arrays every file has. One
// file: read_point_cloud.
StatusOr<PointCloud> read_point_clouds(std::span<const std::filesystem::path> paths, const ReadOptions& options = {});

// The readers over bytes in memory; `name` is used in error messages.
StatusOr<PointCloud> read_ply(std::span<const std::byte> data, std::string_view name);
StatusOr<PointCloud> read_xyz(std::span<const std::byte> data, std::string_view name);
StatusOr<PointCloud> read_pcd(std::span<const std::byte> data, std::string_view name);
StatusOr<PointCloud> read_las(std::span<const std::byte> data, std::string_view name);

enum class PlyEncoding { kBinaryLittleEndian, kBinaryBigEndian, kAscii };

struct PlyWriteOptions {
  PlyEncoding encoding = PlyEncoding::kBinaryLittleEndian;
  bool write_normals = true;  // when the cloud has them
  bool write_colours = true;   // when the cloud has them
  std::vector<std::string> comments;
};

// Writes PLY atomically (temporary file, then rename).
Status write_ply(const PointCloud& cloud, const std::filesystem::path& path,
                 const PlyWriteOptions& options = {});
// The PLY bytes, for tests and in-memory use.
std::string encode_ply(const PointCloud& cloud, const PlyWriteOptions& options = {});

// A PLY file written chunk by chunk, for a cloud that is never whole in memory (a large model's
// decode: CompressedModel::decode_chunks). The chunks' points in order make the file that
// write_ply() writes of them joined, byte for byte: the header (comments, CRS, origin) is the
// first chunk's, the fields (normals, colours) the first non-empty chunk's, and every chunk must
// have the same origin and fields. A header names its point count, so the body waits: in memory up
// to `memory_bytes`, then in a hidden file beside `path`, copied after the header by finish()
// (one more pass over the body's bytes on disk, not more memory). The file appears only when
// finish() succeeds (a temporary file renamed over it); a writer dropped before then leaves
// nothing behind.
class PlyStreamWriter {
 public:
  static StatusOr<PlyStreamWriter> open(const std::filesystem::path& path, const PlyWriteOptions& options = {},
                                        std::size_t memory_bytes = std::size_t{256} << 20);
  PlyStreamWriter(PlyStreamWriter&&) noexcept;
  PlyStreamWriter& operator=(PlyStreamWriter&&) noexcept;
  ~PlyStreamWriter();

  // kInvalidArgument for a chunk that fails validate() or whose origin or fields differ.
  Status write(const PointCloud& chunk);
  // Writes the file; kInvalidArgument when no chunk was written (there is no header to write).
  Status finish();
  std::uint64_t points() const;

 private:
  struct Impl;
  explicit PlyStreamWriter(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

struct LasWriteOptions {
  // 0-3 or 6-8. Unset: the source LAS's format (its waveform packets dropped: 4 → 1, 5 → 3,
  // 9 → 6, 10 → 8), widened when the cloud has fields that format lacks, else the smallest
  // format that holds the cloud's fields. LAS 1.2, or 1.4 for formats 6-8, a WKT CRS, more
  // than 2^32 − 1 points or a 1.3/1.4 source.
  std::optional<int> point_format;
  // Unset: the source LAS's scale and offset (so that its integers come back exactly), else per
  // axis a power of ten at the detail float32 holds of the cloud's extent.
  std::optional<Vec3d> scale;
};

// Writes LAS atomically. kInvalidArgument when the cloud's coordinates cannot be stored in LAS's
// 32-bit integers at the scale.
Status write_las(const PointCloud& cloud, const std::filesystem::path& path,
                 const LasWriteOptions& options = {});
StatusOr<std::string> encode_las(const PointCloud& cloud, const LasWriteOptions& options = {});

// Writes PLY or LAS as the extension says (".ply", ".las"), the cloud's comments and CRS with
// it; kUnsupported for other extensions, naming the ones it writes. `ply` applies to PLY.
Status write_point_cloud(const PointCloud& cloud, const std::filesystem::path& path,
                         const PlyWriteOptions& ply = {});

}  // namespace sspc
