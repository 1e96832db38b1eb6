// read_ply: the PLY header, the mapping of the vertex element onto the point cloud, then the body
// in whichever encoding the header names.
#include "io/ply_body.hpp"
#include "io/ply_header.hpp"
#include "io/ply_vertex_layout.hpp"
#include "io/reader_common.hpp"

namespace sspc {

namespace io {

StatusOr<PointCloud> read_ply_with_progress(std::span<const std::byte> data, std::string_view name,
                                            Progress* progress) {
  SSPC_ASSIGN_OR_RETURN(const PlyHeader header, parse_ply_header(as_text(data), name));
  SSPC_ASSIGN_OR_RETURN(const PlyVertexLayout layout, make_ply_vertex_layout(header, name));
  PointCloud cloud;
  if (header.format == PlyFormat::kAscii) {
    SSPC_RETURN_IF_ERROR(read_ply_ascii_body(data, header, layout, name, progress, cloud));
  } else {
    SSPC_RETURN_IF_ERROR(read_ply_binary_body(data, header, layout, name, progress, cloud));
  }
  SSPC_RETURN_IF_ERROR(finish_cloud(cloud, name));
  return cloud;
}

}  // namespace io

StatusOr<PointCloud> read_ply(std::span<const std::byte> data, std::string_view name) {
  return io::read_ply_with_progress(data, name, nullptr);
}

}  // namespace sspc
