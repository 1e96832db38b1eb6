#include "io/ply_vertex_layout.hpp"

#include <initializer_list>

#include "io/reader_common.hpp"
#include "io/text_scanner.hpp"

namespace sspc::io {

namespace {

// Names per slot, preferred first: the short names Turk's examples and most scanners use, then
// the aliases of PCL's exporter (normal_x) and older modelling tools (diffuse_red).
const std::array<std::initializer_list<std::string_view>, kSlotCount> kSlotNames = {{
    {"x"},
    {"y"},
    {"z"},
    {"nx", "normal_x"},
    {"ny", "normal_y"},
    {"nz", "normal_z"},
    {"red", "diffuse_red"},
    {"green", "diffuse_green"},
    {"blue", "diffuse_blue"},
}};

}  // namespace

StatusOr<PlyVertexLayout> make_ply_vertex_layout(const PlyHeader& header, std::string_view name) {
  PlyVertexLayout layout;
  bool found = false;
  for (std::size_t i = 0; i < header.elements.size(); ++i) {
    if (header.elements[i].name == "vertex") {
      layout.element = i;
      found = true;
      break;
    }
  }
  if (!found) {
    return error_in(StatusCode::kParseError, name, "the header declares no 'vertex' element");
  }
  const PlyElement& vertex = header.elements[layout.element];

  for (std::size_t s = 0; s < kSlotCount; ++s) {
    for (std::string_view candidate : kSlotNames[s]) {
      if (const auto p = vertex.find(candidate); p && !vertex.properties[*p].is_list) {
        layout.property[s] = p;
        break;
      }
    }
  }
  for (std::size_t s = kX; s <= kZ; ++s) {
    const std::string_view axis = *kSlotNames[s].begin();
    if (const auto p = vertex.find(axis); p && vertex.properties[*p].is_list) {
      return error_at_line(StatusCode::kUnsupported, name, vertex.properties[*p].line,
                           "vertex property " + quote_token(axis) + " is a list");
    }
    if (!layout.property[s]) {
      return error_at_line(StatusCode::kParseError, name, vertex.line,
                           "element 'vertex' has no property " + quote_token(axis));
    }
  }
  layout.normals = layout.property[kNx] && layout.property[kNy] && layout.property[kNz];
  layout.colours = layout.property[kRed] && layout.property[kGreen] && layout.property[kBlue];
  if (!layout.normals) layout.property[kNx] = layout.property[kNy] = layout.property[kNz] = {};
  if (!layout.colours) layout.property[kRed] = layout.property[kGreen] = layout.property[kBlue] = {};

  layout.slot.assign(vertex.properties.size(), kSkipProperty);
  for (std::size_t s = 0; s < kSlotCount; ++s) {
    if (layout.property[s]) layout.slot[*layout.property[s]] = static_cast<int>(s);
  }
  return layout;
}

}  // namespace sspc::io
