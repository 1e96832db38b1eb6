// read_pcd: PCL's PCD files with ascii, binary and binary_compressed bodies.
//
// Format: "The PCD (Point Cloud Data) file format", PCL documentation, and PCL's
// io/src/pcd_io.cpp for what the documentation leaves out: binary bodies are records of the
// fields in FIELDS order in the writer's (in practice little-endian) byte order;
// binary_compressed bodies are a little-endian uint32 compressed size, a uint32 uncompressed
// size and an LZF stream whose output holds each field's values for all points one after the
// other (field by field, not record by record). Colour is one 4-byte field `rgb` or `rgba`
// whose bits are 0xAARRGGBB whatever its declared TYPE (PCL declares it F).
#include <algorithm>
#include <bit>
#include <limits>
#include <string>
#include <vector>

#include "core/byte_reader.hpp"
#include "core/parallel.hpp"
#include "io/lzf_decoder.hpp"
#include "io/pcd_header.hpp"
#include "io/reader_common.hpp"
#include "io/strided_fields.hpp"
#include "io/text_scanner.hpp"
#include "io/wide_positions.hpp"

namespace sspc {

namespace io {

namespace {

// Which fields feed the cloud: indices into PcdHeader::fields.
struct PcdLayout {
  std::size_t position[3] = {};
  std::optional<std::size_t> normal[3];
  std::optional<std::size_t> colour;
  bool normals = false;
  bool positions_wider_than_float = false;  // x, y or z is not F 4
};

StatusOr<PcdLayout> make_pcd_layout(const PcdHeader& header, std::string_view name) {
  PcdLayout layout;
  const auto single = [&](std::size_t i) -> Status {
    if (header.fields[i].count != 1) {
      return error_at_line(StatusCode::kUnsupported, name, header.data_line,
                           "field " + quote_token(header.fields[i].name) + " has COUNT " +
                               std::to_string(header.fields[i].count) + " (expected 1)");
    }
    return Status();
  };
  constexpr std::string_view kAxes[3] = {"x", "y", "z"};
  constexpr std::string_view kNormals[3] = {"normal_x", "normal_y", "normal_z"};
  for (int k = 0; k < 3; ++k) {
    const auto p = header.find(kAxes[k]);
    if (!p) {
      return error_at_line(StatusCode::kParseError, name, header.data_line,
                           "FIELDS has no " + quote_token(kAxes[k]));
    }
    SSPC_RETURN_IF_ERROR(single(*p));
    layout.position[k] = *p;
    if (header.fields[*p].type != ScalarType::kFloat32) layout.positions_wider_than_float = true;
    layout.normal[k] = header.find(kNormals[k]);
  }
  layout.normals = layout.normal[0] && layout.normal[1] && layout.normal[2];
  if (layout.normals) {
    for (int k = 0; k < 3; ++k) SSPC_RETURN_IF_ERROR(single(*layout.normal[k]));
  }
  layout.colour = header.find("rgb");
  if (!layout.colour) layout.colour = header.find("rgba");
  if (layout.colour) {
    SSPC_RETURN_IF_ERROR(single(*layout.colour));
    if (header.fields[*layout.colour].bytes() != 4) {
      return error_at_line(StatusCode::kUnsupported, name, header.data_line,
                           "field " + quote_token(header.fields[*layout.colour].name) +
                               " is not 4 bytes (a packed 0xAARRGGBB colour)");
    }
  }
  return layout;
}

class PcdReader {
 public:
  PcdReader(std::span<const std::byte> data, std::string_view name, const ReadOptions& options)
      : data_(data), name_(name), options_(options), progress_(options.progress) {}

  StatusOr<PointCloud> read() {
    SSPC_ASSIGN_OR_RETURN(header_, parse_pcd_header(as_text(data_), name_));
    SSPC_ASSIGN_OR_RETURN(layout_, make_pcd_layout(header_, name_));
    wide_.emplace(options_, layout_.positions_wider_than_float);
    progress_advance(progress_, header_.body_offset);
    PointCloud cloud;
    switch (header_.data) {
      case PcdData::kAscii: SSPC_RETURN_IF_ERROR(read_ascii(cloud)); break;
      case PcdData::kBinary: SSPC_RETURN_IF_ERROR(read_binary(cloud)); break;
      case PcdData::kBinaryCompressed: SSPC_RETURN_IF_ERROR(read_compressed(cloud)); break;
    }
    // The whole body at once: the decode is a small part of the time, and for compressed data
    // the bytes read and the bytes decoded differ.
    progress_advance(progress_, body().size());
    SSPC_RETURN_IF_ERROR(finish_cloud(cloud, name_));
    wide_->finish(cloud);
    return cloud;
  }

 private:
  std::span<const std::byte> body() const {
    return data_.subspan(std::min(header_.body_offset, data_.size()));
  }

  // --- ascii: one point per line, COUNT values per field -------------------------------------

  Status read_ascii(PointCloud& cloud) {
    const std::string_view text = as_text(body());
    LineScanner lines(text, header_.body_first_line);
    // Each value takes at least one character and a separator (the last line may lack its
    // newline): a header claiming more points than that fails before anything is reserved.
    const std::size_t min_line = 2 * header_.values_per_point;
    if (header_.points > (text.size() + 1) / min_line) {
      return error_at_line(StatusCode::kParseError, name_, header_.data_line,
                           "the header declares " + std::to_string(header_.points) +
                               " points, more than the " + std::to_string(text.size()) +
                               " bytes of the body can hold");
    }
    const auto n = static_cast<std::size_t>(header_.points);
    cloud.reserve(n, layout_.normals, layout_.colour.has_value());
    std::vector<int> role(header_.fields.size(), -1);  // 0..2 position, 3..5 normal, 6 colour
    for (int k = 0; k < 3; ++k) {
      role[layout_.position[k]] = k;
      if (layout_.normals) role[*layout_.normal[k]] = 3 + k;
    }
    if (layout_.colour) role[*layout_.colour] = 6;

    std::string_view line;
    for (std::size_t i = 0; i < n; ++i) {
      if (!next_data_line(lines, line)) {
        return error_at_line(StatusCode::kParseError, name_, lines.line_number() + 1,
                             "the file ends after " + std::to_string(i) + " of the " +
                                 std::to_string(n) + " points the header declares");
      }
      const auto error = [&](const std::string& what) {
        return error_at_line(StatusCode::kParseError, name_, lines.line_number(), what);
      };
      Tokenizer tokens(line);
      std::string_view tok;
      float v[6] = {};
      Vec3d stored = Vec3d::Zero();  // the position at the file's precision
      Rgb8 colour;
      for (std::size_t f = 0; f < header_.fields.size(); ++f) {
        const PcdField& field = header_.fields[f];
        for (std::size_t c = 0; c < field.count; ++c) {
          if (!tokens.next(tok)) {
            return error("the line has fewer than the " + std::to_string(header_.values_per_point) +
                         " values the header declares");
          }
          if (role[f] < 0) continue;
          double wide = 0;
          const bool ok = role[f] == 6 ? parse_packed_color(tok, field.type, colour)
                                       : parse_coordinate(tok, field.type, v[role[f]], wide);
          if (role[f] < 3) stored[role[f]] = wide;
          if (!ok) {
            return error("field " + quote_token(field.name) + ": " + quote_token(tok) +
                         " is not a valid " + (role[f] == 6 ? "colour" : "number"));
          }
        }
      }
      if (!tokens.done()) {
        return error("the line has more than the " + std::to_string(header_.values_per_point) +
                     " values the header declares");
      }
      cloud.positions.emplace_back(v[0], v[1], v[2]);
      if (layout_.normals) cloud.normals.emplace_back(v[3], v[4], v[5]);
      if (layout_.colour) cloud.colours.push_back(colour);
      if (!cloud.positions.back().allFinite() ||
          (layout_.normals && !cloud.normals.back().allFinite())) {
        return non_finite_error(name_, cloud, i, "line " + std::to_string(lines.line_number()));
      }
      if (wide_->wanted()) wide_->add(stored, cloud.positions.back());
    }
    if (next_data_line(lines, line)) {
      return error_at_line(StatusCode::kParseError, name_, lines.line_number(),
                           "data after the " + std::to_string(n) + " points the header declares");
    }
    return Status();
  }

  static bool next_data_line(LineScanner& lines, std::string_view& line) {
    while (lines.next(line)) {
      if (!is_blank(line)) return true;
    }
    return false;
  }

  // The value as the cloud holds it (`out`) and as the file stores it (`wide`).
  static bool parse_coordinate(std::string_view tok, ScalarType type, float& out, double& wide) {
    if (type == ScalarType::kFloat32) {  // exact, no double rounding
      if (!parse_number(tok, out)) return false;
      wide = static_cast<double>(out);
      return true;
    }
    if (!parse_number(tok, wide)) return false;
    out = narrow_to_float(wide);
    return true;
  }

  // PCL writes a packed colour as the unsigned integer of its bits whatever its TYPE; older
  // versions printed a float `rgb` as the float with those bits (2.35e-38 and the like). A
  // colour's float is always below 1e-37, so an integer token is never such a float.
  static bool parse_packed_color(std::string_view tok, ScalarType type, Rgb8& out) {
    std::uint32_t bits = 0;
    if (is_plain_unsigned(tok)) {
      if (!parse_number(tok, bits)) return false;
    } else if (type == ScalarType::kFloat32) {
      float f = 0;
      if (!parse_number(tok, f)) return false;
      bits = std::bit_cast<std::uint32_t>(f);
    } else {
      std::int32_t i = 0;
      if (!parse_number(tok, i)) return false;
      bits = static_cast<std::uint32_t>(i);
    }
    out = unpack_pcl_rgb(bits);
    return true;
  }

  // --- binary and binary_compressed: the same fields, two layouts ----------------------------

  // Decodes n points whose field f sits at fields[f] (offset from `block`, stride per point).
  Status decode_block(const std::byte* block, const std::vector<StridedField>& fields,
                      std::size_t n, PointCloud& cloud) {
    const StridedField pos[3] = {fields[layout_.position[0]], fields[layout_.position[1]],
                                 fields[layout_.position[2]]};
    StridedField nrm[3];
    if (layout_.normals) {
      for (int k = 0; k < 3; ++k) nrm[k] = fields[*layout_.normal[k]];
    }
    cloud.positions.resize(n);
    if (layout_.normals) cloud.normals.resize(n);
    if (layout_.colour) cloud.colours.resize(n);
    const std::size_t grain = std::max<std::size_t>(1, (std::size_t{1} << 19) / header_.point_size);
    parallel_for_ranges(0, n, grain, [&](std::size_t b, std::size_t e) {
      decode_vec3(block, pos, Endian::kLittle, b, e, cloud.positions.data());
      if (layout_.normals) decode_vec3(block, nrm, Endian::kLittle, b, e, cloud.normals.data());
      if (layout_.colour) {
        decode_packed_rgb(block, fields[*layout_.colour], Endian::kLittle, b, e,
                          cloud.colours.data());
      }
    });
    if (wide_->wanted()) wide_->add_block(block, pos, Endian::kLittle, cloud.positions);
    return Status();
  }

  // Fails when n points of point_size bytes cannot fit in `available` bytes.
  Status check_points_fit(std::size_t available, std::size_t at) const {
    if (header_.points > available / header_.point_size) {
      return error_at_offset(StatusCode::kCorrupt, name_, at,
                             "the header declares " + std::to_string(header_.points) +
                                 " points of " + std::to_string(header_.point_size) +
                                 " bytes, but only " + std::to_string(available) +
                                 " bytes of data remain (the file is truncated or the count is "
                                 "wrong)");
    }
    return Status();
  }

  // Bytes after the last point are ignored, as PCL does: some writers pad the body to a page.
  Status read_binary(PointCloud& cloud) {
    const std::span<const std::byte> bytes = body();
    SSPC_RETURN_IF_ERROR(check_points_fit(bytes.size(), header_.body_offset));
    const auto n = static_cast<std::size_t>(header_.points);
    std::vector<StridedField> fields(header_.fields.size());
    for (std::size_t f = 0; f < fields.size(); ++f) {
      fields[f] = StridedField{header_.offset_of(f), header_.point_size, header_.fields[f].type};
    }
    SSPC_RETURN_IF_ERROR(decode_block(bytes.data(), fields, n, cloud));
    if (const auto bad = first_non_finite_point(cloud)) {
      return non_finite_error(
          name_, cloud, *bad,
          "byte offset " + std::to_string(header_.body_offset + *bad * header_.point_size));
    }
    return Status();
  }

  Status read_compressed(PointCloud& cloud) {
    ByteReader reader(body(), header_.body_offset);
    std::uint32_t compressed_size = 0, raw_size = 0;
    Status s = reader.read_into(compressed_size);
    if (s.ok()) s = reader.read_into(raw_size);
    if (!s.ok()) return in_file(s, name_);
    const std::size_t stream_offset = reader.offset();
    if (compressed_size > reader.remaining()) {
      return error_at_offset(StatusCode::kCorrupt, name_, header_.body_offset,
                             "the compressed size " + std::to_string(compressed_size) +
                                 " exceeds the " + std::to_string(reader.remaining()) +
                                 " bytes that follow");
    }
    // The uncompressed size must hold exactly the declared points, and LZF cannot expand a
    // byte into more than kLzfMaxExpansion: both are checked before anything is allocated, so
    // a hostile header cannot make the reader allocate more than a multiple of the file size.
    if (raw_size % header_.point_size != 0 || raw_size / header_.point_size != header_.points) {
      return error_at_offset(StatusCode::kCorrupt, name_, header_.body_offset + 4,
                             "the uncompressed size " + std::to_string(raw_size) + " is not the " +
                                 std::to_string(header_.points) + " points x " +
                                 std::to_string(header_.point_size) + " bytes the header declares");
    }
    if (raw_size > std::size_t{compressed_size} * kLzfMaxExpansion) {
      return error_at_offset(StatusCode::kCorrupt, name_, header_.body_offset + 4,
                             "the uncompressed size " + std::to_string(raw_size) +
                                 " is more than LZF can produce from " +
                                 std::to_string(compressed_size) + " bytes");
    }
    const auto n = static_cast<std::size_t>(header_.points);
    std::vector<std::byte> raw(raw_size);
    // Cannot fail: compressed_size <= remaining() was checked above.
    const std::span<const std::byte> stream = reader.rest().first(compressed_size);
    const Status lzf = lzf_decompress(stream, raw, stream_offset);
    if (!lzf.ok()) return in_file(lzf, name_);

    std::vector<StridedField> fields(header_.fields.size());
    for (std::size_t f = 0; f < fields.size(); ++f) {
      fields[f] =
          StridedField{n * header_.offset_of(f), header_.fields[f].bytes(), header_.fields[f].type};
    }
    SSPC_RETURN_IF_ERROR(decode_block(raw.data(), fields, n, cloud));
    if (const auto bad = first_non_finite_point(cloud)) {
      return non_finite_error(name_, cloud, *bad,
                              "compressed data at byte offset " + std::to_string(stream_offset));
    }
    return Status();
  }

  std::span<const std::byte> data_;
  std::string_view name_;
  const ReadOptions& options_;
  Progress* progress_;
  PcdHeader header_;
  PcdLayout layout_;
  std::optional<WidePositions> wide_;  // once the header says how positions are stored
};

}  // namespace

StatusOr<PointCloud> read_pcd_with_options(std::span<const std::byte> data, std::string_view name,
                                           const ReadOptions& options) {
  return PcdReader(data, name, options).read();
}

}  // namespace io

StatusOr<PointCloud> read_pcd(std::span<const std::byte> data, std::string_view name) {
  return io::read_pcd_with_options(data, name, {});
}

}  // namespace sspc
