// read_point_cloud and read_point_cloud_chunks: map the file and hand it to the reader its format
// calls for: the one the caller names, else the one the extension names, else the one the first
// bytes look like.
#include <algorithm>
#include <cctype>
#include <string>
#include <utility>

#include "core/mapped_file.hpp"
#include "io/point_chunks.hpp"
#include "io/reader_common.hpp"

namespace sspc {

namespace {

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

// LAS (and LAZ, which the LAS reader refuses by name) opens with "LASF". PLY's magic line is
// mandatory. PCD files open with PCL's "# .PCD" comment or, when a tool
// dropped it, with VERSION or FIELDS. Anything else is given to the XYZ reader, whose first
// error explains what it expected.
PointCloudFormat sniff_format(std::string_view text) {
  if (text.starts_with("LASF")) return PointCloudFormat::kLas;
  if (text.starts_with("ply\n") || text.starts_with("ply\r\n")) return PointCloudFormat::kPly;
  if (text.starts_with("# .PCD") || text.starts_with("VERSION") || text.starts_with("FIELDS")) {
    return PointCloudFormat::kPcd;
  }
  return PointCloudFormat::kXyz;
}

}  // namespace

PointCloudFormat format_from_extension(const std::filesystem::path& path) {
  const std::string ext = lower(path.extension().string());
  if (ext == ".ply") return PointCloudFormat::kPly;
  if (ext == ".pcd") return PointCloudFormat::kPcd;
  if (ext == ".xyz" || ext == ".pts" || ext == ".txt") return PointCloudFormat::kXyz;
  if (ext == ".las" || ext == ".laz") return PointCloudFormat::kLas;
  if (ext == ".xyzrgb") return PointCloudFormat::kXyzRgb;
  if (ext == ".xyzn") return PointCloudFormat::kXyzN;
  return PointCloudFormat::kAuto;
}

namespace {

StatusOr<PointCloud> read_with(PointCloudFormat format, std::span<const std::byte> bytes,
                               const std::string& name, const ReadOptions& options) {
  switch (format) {
    case PointCloudFormat::kPly: return io::read_ply_with_options(bytes, name, options);
    case PointCloudFormat::kPcd: return io::read_pcd_with_options(bytes, name, options);
    case PointCloudFormat::kLas: return io::read_las_with_options(bytes, name, options);
    case PointCloudFormat::kXyzRgb:
      return io::read_xyz_columns(bytes, name, options, io::XyzSixColumns::kColours);
    case PointCloudFormat::kXyzN:
      return io::read_xyz_columns(bytes, name, options, io::XyzSixColumns::kNormals);
    case PointCloudFormat::kXyz:
    case PointCloudFormat::kAuto: break;
  }
  return io::read_xyz_with_options(bytes, name, options);
}

// The caller's format, else the extension's, else the content's.
PointCloudFormat format_of(const std::filesystem::path& path, const MappedFile& file,
                           const ReadOptions& options) {
  PointCloudFormat format = options.format;
  if (format == PointCloudFormat::kAuto) format = format_from_extension(path);
  if (format == PointCloudFormat::kAuto) format = sniff_format(io::as_text(file.bytes()));
  return format;
}

Status read_chunks_with(PointCloudFormat format, const io::ChunkedRead& in) {
  switch (format) {
    case PointCloudFormat::kPly: return io::read_ply_chunks(in);
    case PointCloudFormat::kLas: return io::read_las_chunks(in);
    case PointCloudFormat::kXyzRgb: return io::read_xyz_chunks(in, io::XyzSixColumns::kColours);
    case PointCloudFormat::kXyzN: return io::read_xyz_chunks(in, io::XyzSixColumns::kNormals);
    case PointCloudFormat::kPcd: {
      // Read whole: see sspc/io.hpp.
      progress_begin(in.options.progress, "reading " + in.file.path().filename().string(),
                     in.file.size(), "bytes");
      StatusOr<PointCloud> cloud = io::read_pcd_with_options(in.file.bytes(), in.name, in.options);
      progress_end(in.options.progress);
      if (!cloud.ok()) return cloud.status();
      SSPC_RETURN_IF_ERROR(in.file.check_intact());
      return io::hand_out_in_chunks(std::move(*cloud), in.chunk_points, in.sink);
    }
    case PointCloudFormat::kXyz:
    case PointCloudFormat::kAuto: break;
  }
  return io::read_xyz_chunks(in, io::XyzSixColumns::kGuess);
}

}  // namespace

StatusOr<PointCloud> read_point_cloud(const std::filesystem::path& path,
                                      const ReadOptions& options) {
  SSPC_ASSIGN_OR_RETURN(const MappedFile file, MappedFile::open(path));
  const std::string name = path.string();
  const PointCloudFormat format = format_of(path, file, options);

  progress_begin(options.progress, "reading " + path.filename().string(), file.size(), "bytes");
  StatusOr<PointCloud> cloud = read_with(format, file.bytes(), name, options);
  progress_end(options.progress);
  // A file that shrank under the mapping was read partly as zeros: whatever the parser made of
  // them, the reason is the truncation (core/mapped_file.hpp).
  if (Status intact = file.check_intact(); !intact.ok()) cloud = std::move(intact);
  if (!cloud.ok() && options.positions_f64 != nullptr) options.positions_f64->clear();
  return cloud;
}

StatusOr<PointCloud> read_point_cloud(std::span<const std::byte> data, std::string_view name,
                                      const ReadOptions& options) {
  const std::string label(name);
  PointCloudFormat format = options.format;
  if (format == PointCloudFormat::kAuto) format = sniff_format(io::as_text(data));
  progress_begin(options.progress, "reading " + label, data.size(), "bytes");
  StatusOr<PointCloud> cloud = read_with(format, data, label, options);
  progress_end(options.progress);
  if (!cloud.ok() && options.positions_f64 != nullptr) options.positions_f64->clear();
  return cloud;
}

Status read_point_cloud_chunks(const std::filesystem::path& path, std::size_t chunk_points,
                               const std::function<Status(PointCloud&&)>& sink,
                               const ReadOptions& options) {
  if (chunk_points == 0) {
    return invalid_argument(path.string() + ": chunks must hold at least one point");
  }
  if (options.positions_f64 != nullptr) {
    return invalid_argument(path.string() +
                            ": the positions in double (positions_f64) are not given in chunks");
  }
  SSPC_ASSIGN_OR_RETURN(const MappedFile file, MappedFile::open(path));
  const std::string name = path.string();
  Status status = read_chunks_with(format_of(path, file, options),
                                   io::ChunkedRead{file, name, chunk_points, sink, options});
  // As in read_point_cloud: a file that shrank was read partly as zeros.
  if (Status intact = file.check_intact(); !intact.ok()) status = std::move(intact);
  return status;
}

}  // namespace sspc
