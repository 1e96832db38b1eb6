// read_ply: the PLY header, the mapping of the vertex element onto the point cloud, then the body
// in whichever encoding the header names.
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

}  // namespace

StatusOr<PointCloud> read_ply_with_options(std::span<const std::byte> data, std::string_view name,
                                           const ReadOptions& options) {
  SSPC_ASSIGN_OR_RETURN(const PlyHeader header, parse_ply_header(as_text(data), name));
  SSPC_ASSIGN_OR_RETURN(const PlyVertexLayout layout, make_ply_vertex_layout(header, name));
  WidePositions wide(options, positions_wider_than_float(header, layout));
  PointCloud cloud;
  const PlyBodySinks sinks{options.progress, &wide};
  if (header.format == PlyFormat::kAscii) {
    SSPC_RETURN_IF_ERROR(read_ply_ascii_body(data, header, layout, name, sinks, cloud));
  } else {
    SSPC_RETURN_IF_ERROR(read_ply_binary_body(data, header, layout, name, sinks, cloud));
  }
  SSPC_RETURN_IF_ERROR(finish_cloud(cloud, name));
  wide.finish(cloud);
  keep_comments(header.comments, cloud.metadata);
  return cloud;
}

}  // namespace io

StatusOr<PointCloud> read_ply(std::span<const std::byte> data, std::string_view name) {
  return io::read_ply_with_options(data, name, {});
}

}  // namespace sspc
