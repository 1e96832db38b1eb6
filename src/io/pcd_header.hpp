// The header of PCL's PCD format (versions 0.6 and 0.7).
//
// Format: "The PCD (Point Cloud Data) file format", PCL documentation
// (pointclouds.org/documentation/tutorials/pcd_file_format.html). The header is text lines, with
// '#' comments, in this order: VERSION, FIELDS, SIZE, TYPE, COUNT, WIDTH, HEIGHT, VIEWPOINT,
// POINTS, DATA. sspc accepts them in any order before DATA (which must be last, since the body
// starts on the next line) and lets COUNT (all 1), HEIGHT (1), VIEWPOINT and VERSION be absent,
// as PCL's own reader does.
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

enum class PcdData { kAscii, kBinary, kBinaryCompressed };

struct PcdField {
  std::string name;  // "_" marks padding, which may repeat
  ScalarType type = ScalarType::kFloat32;
  std::size_t count = 1;  // values per point (a histogram field has many)
  std::size_t bytes() const { return scalar_size(type) * count; }
};

struct PcdHeader {
  std::vector<PcdField> fields;
  std::uint64_t width = 0;
  std::uint64_t height = 1;
  std::uint64_t points = 0;  // width * height, checked against POINTS when given
  PcdData data = PcdData::kAscii;
  std::size_t point_size = 0;        // bytes per point: the sum of the fields' bytes()
  std::size_t values_per_point = 0;  // tokens per ascii line: the sum of the counts
  std::size_t body_offset = 0;       // first byte after the DATA line
  std::size_t body_first_line = 0;   // line number of the first body line (ascii)
  std::size_t data_line = 0;         // line of DATA, for messages about the point count

  std::optional<std::size_t> find(std::string_view field_name) const;
  // Offset of field `index` inside one interleaved record.
  std::size_t offset_of(std::size_t index) const;
};

// Parses the header at the start of `text` (the whole file). kParseError for malformed or
// unknown lines and missing keywords, kUnsupported for well-formed features sspc lacks (a type
// and size PCL does not define, an unknown DATA encoding). Errors name `name` and the line.
StatusOr<PcdHeader> parse_pcd_header(std::string_view text, std::string_view name);

}  // namespace sspc::io
