// The LAS public header block and its variable-length records (ASPRS LAS specification R15,
// §2.4, §2.5 and §2.7), parsed and checked against the size of the file.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "sspc/point_cloud.hpp"
#include "sspc/status.hpp"

namespace sspc::io {

struct LasHeader {
  LasSource source;  // version, point format, scale, offset, identifiers
  std::size_t header_size = 0;
  std::uint64_t point_data_offset = 0;
  std::size_t record_length = 0;
  std::uint64_t point_count = 0;  // the 64-bit count in 1.4, else the legacy one
  std::vector<LasRecord> vlrs;    // VLRs, then EVLRs, in file order
};

// Parses the header and the (E)VLRs of the LAS file `data` and checks that every record and the
// point records lie inside the file. Errors name `name` and the byte offset: kParseError for a
// malformed or truncated file, kUnsupported for LAZ, COPC and point formats above 10 (with
// the commands that turn a LAZ file into LAS).
StatusOr<LasHeader> parse_las_header(std::span<const std::byte> data, std::string_view name);

}  // namespace sspc::io
