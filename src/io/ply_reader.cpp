// read_ply: the PLY header, the mapping of the vertex element onto the point cloud, then the body
// in whichever encoding the header names, whole or in chunks.
#include <limits>
#include <memory>
#include <optional>
#include <utility>

#include "core/check.hpp"
#include "io/ply_body.hpp"
#include "io/ply_header.hpp"
#include "io/ply_vertex_layout.hpp"
#include "io/ply_writer.hpp"
#include "io/reader_common.hpp"
#include "io/wide_positions.hpp"

namespace sspc {

namespace io {

namespace {

bool positions_wider_than_float(const PlyHeader& header, const PlyVertexLayout& layout) {
  const PlyElement& vertex = header.elements[layout.element];
  for (const PlySlot s : {kX, kY, kZ}) {
    if (vertex.properties[*layout.property[s]].type != ScalarType::kFloat32) return true;
  }
  return false;
}

// Comments travel with the cloud; one that starts "crs " holds its coordinate reference system
// (how the PLY writer stores it, PLY having no field of its own for it).
void keep_comments(const std::vector<std::string>& comments, CloudMetadata& metadata) {
  for (const std::string& c : comments) {
    if (c.starts_with(kPlyCrsComment)) {
      metadata.crs_wkt = c.substr(kPlyCrsComment.size());
    } else {
      metadata.comments.push_back(c);
    }
  }
}

std::unique_ptr<PointReader> make_body(std::span<const std::byte> data, const PlyHeader& header,
                                       const PlyVertexLayout& layout, std::string_view name,
                                       const PlyBodySinks& sinks) {
  if (header.format == PlyFormat::kAscii) {
    return make_ply_ascii_body(data, header, layout, name, sinks);
  }
  return make_ply_binary_body(data, header, layout, name, sinks);
}

}  // namespace

StatusOr<PointCloud> read_ply_with_options(std::span<const std::byte> data, std::string_view name,
                                           const ReadOptions& options) {
  SSPC_ASSIGN_OR_RETURN(const PlyHeader header, parse_ply_header(as_text(data), name));
  SSPC_ASSIGN_OR_RETURN(const PlyVertexLayout layout, make_ply_vertex_layout(header, name));
  WidePositions wide(options, positions_wider_than_float(header, layout));
  PointCloud cloud;
  const std::unique_ptr<PointReader> body =
      make_body(data, header, layout, name, {options.progress, &wide});
  SSPC_RETURN_IF_ERROR(body->read(std::numeric_limits<std::size_t>::max(), cloud));
  SSPC_DCHECK(body->done());
  SSPC_RETURN_IF_ERROR(finish_cloud(cloud, name));
  wide.finish(cloud);
  keep_comments(header.comments, cloud.metadata);
  return cloud;
}

Status read_ply_chunks(const ChunkedRead& in) {
  const std::span<const std::byte> data = in.file.bytes();
  SSPC_ASSIGN_OR_RETURN(const PlyHeader header, parse_ply_header(as_text(data), in.name));
  SSPC_ASSIGN_OR_RETURN(const PlyVertexLayout layout, make_ply_vertex_layout(header, in.name));
  std::optional<Vec3d> origin;
  if (positions_wider_than_float(header, layout)) {
    // The origin depends on every position: a first pass gathers their range.
    WidePositions stats(ReadOptions{}, /*stored_wider=*/true);
    const std::unique_ptr<PointReader> scan =
        make_body(data, header, layout, in.name, {in.options.progress, &stats});
    SSPC_ASSIGN_OR_RETURN(const std::size_t n,
                          run_pass(in, Pass::kScan, *scan, [&](PointCloud&, std::size_t) {
                            stats.forget_added();
                            return Status();
                          }));
    if (n == 0) return finish_cloud(PointCloud(), in.name);
    origin = stats.origin();
  }
  CloudMetadata metadata;
  keep_comments(header.comments, metadata);
  WidePositions wide(ReadOptions{}, /*stored_wider=*/origin.has_value());
  const std::unique_ptr<PointReader> body =
      make_body(data, header, layout, in.name, {in.options.progress, &wide});
  SSPC_ASSIGN_OR_RETURN(const std::size_t n,
                        run_pass(in, Pass::kRead, *body, [&](PointCloud& chunk, std::size_t) {
                          if (origin) {
                            wide.narrow_added(*origin, chunk.positions);
                            chunk.origin = *origin;
                          }
                          chunk.metadata = metadata;
                          return in.sink(std::move(chunk));
                        }));
  if (n == 0) return finish_cloud(PointCloud(), in.name);
  return Status();
}

}  // namespace io

StatusOr<PointCloud> read_ply(std::span<const std::byte> data, std::string_view name) {
  return io::read_ply_with_options(data, name, {});
}

}  // namespace sspc
