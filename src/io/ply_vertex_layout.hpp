// Which properties of a PLY `vertex` element feed the point cloud's positions, normals and
// colours, under the names common writers use.
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <string_view>
#include <vector>

#include "io/ply_header.hpp"
#include "sspc/status.hpp"

namespace sspc::io {

// The point cloud channels a vertex property can feed.
enum PlySlot : std::size_t { kX, kY, kZ, kNx, kNy, kNz, kRed, kGreen, kBlue, kSlotCount };

inline constexpr int kSkipProperty = -1;

struct PlyVertexLayout {
  std::size_t element = 0;  // index of `vertex` in the header's elements
  // For each slot, the vertex property that feeds it.
  std::array<std::optional<std::size_t>, kSlotCount> property{};
  // For each vertex property, the slot it feeds or kSkipProperty.
  std::vector<int> slot;
  bool normals = false;
  bool colours = false;
};

// Finds the `vertex` element and maps its properties: x y z are required; nx ny nz (or
// normal_x normal_y normal_z) are read when all three exist; red green blue (or diffuse_red
// diffuse_green diffuse_blue) likewise. Every other property is skipped. kParseError when there
// is no vertex element or no x, y or z; kUnsupported when x, y or z is a list.
StatusOr<PlyVertexLayout> make_ply_vertex_layout(const PlyHeader& header, std::string_view name);

}  // namespace sspc::io
