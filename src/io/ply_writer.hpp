// The PLY writer: a header from the cloud's attributes and a body in any of the three
// encodings, produced in chunks so that write_ply can stream a large cloud to disk without
// holding the whole file in memory.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

#include "sspc/io.hpp"
#include "sspc/point_cloud.hpp"

namespace sspc::io {

// The comment that carries a cloud's CRS as WKT on one line: "comment crs PROJCRS[...]".
inline constexpr std::string_view kPlyCrsComment = "crs ";

class PlyEncoder {
 public:
  // Precondition: `cloud` passes validate() (write_ply checks it; encode_ply writes normals or
  // colours only when their arrays are exactly as long as the positions).
  PlyEncoder(const PointCloud& cloud, const PlyWriteOptions& options);

  std::string header() const { return header(cloud_.size()); }
  // The header of a file of `count` points with this cloud's fields (PlyStreamWriter).
  std::string header(std::size_t count) const;
  bool writes_normals() const { return normals_; }
  bool writes_colours() const { return colours_; }
  // Appends the body for points [begin, end) to `out`.
  void append_body(std::size_t begin, std::size_t end, std::string& out) const;

 private:
  void append_binary(std::size_t begin, std::size_t end, std::string& out) const;
  void append_ascii(std::size_t begin, std::size_t end, std::string& out) const;

  const PointCloud& cloud_;
  const PlyWriteOptions& options_;
  bool normals_ = false;
  bool colours_ = false;
  bool doubles_ = false;  // positions as double world coordinates (the cloud has an origin)
  std::size_t stride_ = 0;  // bytes per binary record
};

}  // namespace sspc::io
