// The PLY header: format, elements and their properties.
//
// Format: Greg Turk, "The PLY Polygon File Format" (1994), as also documented by Paul Bourke.
// A header is text lines up to `end_header`: `ply`, one `format <ascii | binary_little_endian |
// binary_big_endian> 1.0`, any number of `comment` and `obj_info` lines, and `element <name>
// <count>` lines each followed by its `property <type> <name>` or `property list <count type>
// <item type> <name>` lines. The body stores the elements in header order.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "io/scalar_type.hpp"
#include "sspc/status.hpp"

namespace sspc::io {

enum class PlyFormat { kAscii, kBinaryLittleEndian, kBinaryBigEndian };

struct PlyProperty {
  std::string name;
  ScalarType type = ScalarType::kFloat32;  // the item type for a list
  bool is_list = false;
  ScalarType count_type = ScalarType::kUint8;  // lists only; always an integer type
  std::size_t line = 0;                        // header line, for messages
};

struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  std::vector<PlyProperty> properties;
  std::size_t line = 0;

  // Bytes per item in a binary body when no property is a list.
  std::optional<std::size_t> fixed_stride() const;
  // Index of the property called `name`, if any.
  std::optional<std::size_t> find(std::string_view property_name) const;
};

struct PlyHeader {
  PlyFormat format = PlyFormat::kAscii;
  std::vector<PlyElement> elements;
  std::vector<std::string> comments;  // `comment` and `obj_info` lines, without the keyword
  std::size_t body_offset = 0;        // first byte after the newline that ends `end_header`
  std::size_t body_first_line = 0;    // line number of the body's first line (ascii bodies)
};

// Parses the header at the start of `text` (the whole file: the body is not read). Errors name
// `name` and the line: kParseError for malformed lines and a missing `ply` or `end_header`,
// kUnsupported for a well-formed header using an unknown type, format or version.
StatusOr<PlyHeader> parse_ply_header(std::string_view text, std::string_view name);

}  // namespace sspc::io
