// Binary PLY bodies (binary_little_endian and binary_big_endian; Turk's PLY description).
//
// The common layout, a vertex element without list properties, has a fixed stride: its whole
// block is bounds-checked once and then decoded in parallel, with a memcpy per point where the
// file's floats already have the host's byte order. Elements with list properties (faces) are
// walked item by item through the ByteReader. The reader resumes where it stopped, so that a file
// can be read a chunk of vertices at a time (io/point_chunks.hpp).
#include <algorithm>
#include <cstring>
#include <memory>
#include <string>

#include "core/byte_reader.hpp"
#include "core/parallel.hpp"
#include "io/ply_body.hpp"
#include "io/reader_common.hpp"
#include "io/strided_fields.hpp"
#include "io/text_scanner.hpp"

namespace sspc::io {

namespace {

class BinaryBodyReader final : public PointReader {
 public:
  BinaryBodyReader(std::span<const std::byte> file, const PlyHeader& header,
                   const PlyVertexLayout& layout, std::string_view name, const PlyBodySinks& sinks)
      : header_(header),
        layout_(layout),
        name_(name),
        progress_(sinks.progress),
        wide_(*sinks.wide),
        endian_(header.format == PlyFormat::kBinaryBigEndian ? Endian::kBig : Endian::kLittle),
        reader_(file.subspan(std::min(header.body_offset, file.size())), header.body_offset) {}

  Status read(std::size_t max_points, PointCloud& out) override {
    if (!started_) {
      progress_advance(progress_, header_.body_offset);
      started_ = true;
    }
    for (; element_ < header_.elements.size(); ++element_, item_ = 0) {
      const PlyElement& element = header_.elements[element_];
      const std::size_t before = reader_.offset();
      if (element_ == layout_.element) {
        SSPC_RETURN_IF_ERROR(read_vertices(element, max_points, out));
      } else {
        SSPC_RETURN_IF_ERROR(skip_element(element, max_points));
        progress_advance(progress_, reader_.offset() - before);
      }
      if (item_ < element.count) return Status();  // `max_points` reached: resume here
    }
    SSPC_RETURN_IF_ERROR(check_end());
    done_ = true;
    return Status();
  }

  bool done() const override { return done_; }
  std::size_t consumed() const override { return reader_.offset(); }

 private:
  Status item_error(const PlyElement& element, std::uint64_t item, const Status& s) const {
    return in_file(
        s.with_context("element " + quote_token(element.name) + " item " + std::to_string(item)),
        name_);
  }

  // An item of an element with list properties: its size is only known by reading the counts.
  Status skip_variable_item(const PlyElement& element) {
    for (const PlyProperty& p : element.properties) {
      if (!p.is_list) {
        SSPC_RETURN_IF_ERROR(reader_.skip(scalar_size(p.type)));
        continue;
      }
      SSPC_ASSIGN_OR_RETURN(const std::uint64_t n, read_list_count(p));
      SSPC_RETURN_IF_ERROR(reader_.skip_items(n, scalar_size(p.type)));
    }
    return Status();
  }

  StatusOr<std::uint64_t> read_list_count(const PlyProperty& p) {
    const std::size_t at = reader_.offset();
    if (!reader_.can_read(scalar_size(p.count_type))) {
      return reader_.overrun(scalar_size(p.count_type));
    }
    const std::optional<std::uint64_t> n = load_count(reader_.current(), p.count_type, endian_);
    if (!n) {
      return corrupt("byte offset " + std::to_string(at) + ": list " + quote_token(p.name) +
                     " has a negative length");
    }
    SSPC_RETURN_IF_ERROR(reader_.skip(scalar_size(p.count_type)));
    return *n;
  }

  // Up to `budget` items of an element that is not the vertex element, from item_ on.
  Status skip_element(const PlyElement& element, std::size_t budget) {
    if (const auto stride = element.fixed_stride()) {
      // All at once: skipping touches none of its bytes.
      const Status s = reader_.skip_items(element.count, *stride);
      if (!s.ok()) {
        return in_file(s.with_context("element " + quote_token(element.name) + " (" +
                                      std::to_string(element.count) + " items of " +
                                      std::to_string(*stride) + " bytes)"),
                       name_);
      }
      item_ = element.count;
      return Status();
    }
    // Each item holds at least one list count, so a hostile count runs out of bytes within
    // remaining() iterations.
    for (std::size_t n = 0; item_ < element.count && n < budget; ++item_, ++n) {
      const Status s = skip_variable_item(element);
      if (!s.ok()) return item_error(element, item_, s);
    }
    return Status();
  }

  // The header's counts say where the data ends. Bytes after that mean the counts are wrong (a
  // vertex count lower than the data would drop points without a word), except for one "\n" or
  // "\r\n": writers that end every file with a newline are common, and such an ending cannot
  // hold an item of any element.
  Status check_end() {
    const std::string_view rest = as_text(reader_.rest());
    if (rest.empty() || rest == "\n" || rest == "\r\n") {
      progress_advance(progress_, rest.size());
      return Status();
    }
    return error_at_offset(StatusCode::kCorrupt, name_, reader_.offset(),
                           std::to_string(rest.size()) +
                               " bytes after the last element (the header's counts say the data "
                               "ends here)");
  }

  // Smallest number of bytes an item can occupy (lists of length 0).
  static std::size_t min_item_size(const PlyElement& element) {
    std::size_t n = 0;
    for (const PlyProperty& p : element.properties) {
      n += scalar_size(p.is_list ? p.count_type : p.type);
    }
    return n;
  }

  Status check_count_fits(const PlyElement& element, std::size_t item_size) const {
    // x, y and z exist, so item_size > 0.
    if (element.count > reader_.remaining() / item_size) {
      return error_at_offset(StatusCode::kCorrupt, name_, reader_.offset(),
                             "element 'vertex' declares " + std::to_string(element.count) +
                                 " items of at least " + std::to_string(item_size) +
                                 " bytes, but only " + std::to_string(reader_.remaining()) +
                                 " bytes remain (the file is truncated or the count is wrong)");
    }
    return Status();
  }

  // Up to `budget` vertices from item_ on, appended to `out`.
  Status read_vertices(const PlyElement& vertex, std::size_t budget, PointCloud& out) {
    if (const auto stride = vertex.fixed_stride()) {
      return read_fixed_vertices(vertex, *stride, budget, out);
    }
    return read_variable_vertices(vertex, budget, out);
  }

  // The three properties feeding slots first..first+2 as fields of a record of `stride` bytes.
  void fields(PlySlot first, const std::vector<std::size_t>& offsets, std::size_t stride,
              StridedField (&out)[3]) const {
    const PlyElement& vertex = header_.elements[layout_.element];
    for (std::size_t k = 0; k < 3; ++k) {
      const std::size_t p = *layout_.property[first + k];
      out[k] = StridedField{offsets[p], stride, vertex.properties[p].type};
    }
  }

  Status read_fixed_vertices(const PlyElement& vertex, std::size_t stride, std::size_t budget,
                             PointCloud& out) {
    if (item_ == 0) SSPC_RETURN_IF_ERROR(check_count_fits(vertex, stride));
    // Fits: the vertices left lie in the file, n * stride <= remaining().
    const auto n = static_cast<std::size_t>(std::min<std::uint64_t>(vertex.count - item_, budget));
    std::vector<std::size_t> offsets(vertex.properties.size());
    for (std::size_t p = 0, off = 0; p < vertex.properties.size(); ++p) {
      offsets[p] = off;
      off += scalar_size(vertex.properties[p].type);
    }
    StridedField pos[3], nrm[3], col[3];
    fields(kX, offsets, stride, pos);
    if (layout_.normals) fields(kNx, offsets, stride, nrm);
    if (layout_.colours) fields(kRed, offsets, stride, col);

    const std::size_t first = out.size();
    out.positions.resize(first + n);
    if (layout_.normals) out.normals.resize(first + n);
    if (layout_.colours) out.colours.resize(first + n);
    Vec3f* positions = out.positions.data() + first;
    Vec3f* normals = layout_.normals ? out.normals.data() + first : nullptr;
    Rgb8* colours = layout_.colours ? out.colours.data() + first : nullptr;
    const std::byte* block = reader_.current();
    const std::size_t block_offset = reader_.offset();
    // Chunks of a few hundred kilobytes: large enough to amortise scheduling, small enough for
    // the progress line to move and for both cores to get work on small files.
    const std::size_t grain = std::max<std::size_t>(1, (std::size_t{1} << 19) / stride);
    parallel_for_ranges(0, n, grain, [&](std::size_t b, std::size_t e) {
      decode_vec3(block, pos, endian_, b, e, positions);
      if (layout_.normals) decode_vec3(block, nrm, endian_, b, e, normals);
      if (layout_.colours) decode_rgb_channels(block, col, endian_, b, e, colours);
      progress_advance(progress_, (e - b) * stride);
    });
    SSPC_RETURN_IF_ERROR(reader_.skip(n * stride));
    item_ += n;

    if (const auto bad = first_non_finite_point(out, first)) {
      return non_finite_error(
          name_, out, *bad, "byte offset " + std::to_string(block_offset + (*bad - first) * stride),
          points_ - first);
    }
    if (wide_.wanted()) wide_.add_block(block, pos, endian_, std::span(positions, n));
    points_ += n;
    return Status();
  }

  // Vertices with a list property (rare: some tools attach texture coordinates or neighbour
  // lists to vertices). Sequential; each item is bounds-checked as it is read.
  Status read_variable_vertices(const PlyElement& vertex, std::size_t budget, PointCloud& out) {
    if (item_ == 0) SSPC_RETURN_IF_ERROR(check_count_fits(vertex, min_item_size(vertex)));
    const auto n = static_cast<std::size_t>(std::min<std::uint64_t>(vertex.count - item_, budget));
    out.reserve(out.size() + n, layout_.normals, layout_.colours);
    const std::size_t start = reader_.offset();
    for (std::size_t k = 0; k < n; ++k, ++item_) {
      const std::size_t item_offset = reader_.offset();
      double v[kSlotCount] = {};
      for (std::size_t p = 0; p < vertex.properties.size(); ++p) {
        const PlyProperty& prop = vertex.properties[p];
        Status s;
        if (prop.is_list) {
          StatusOr<std::uint64_t> len = read_list_count(prop);
          s = len.ok() ? reader_.skip_items(*len, scalar_size(prop.type)) : len.status();
        } else if (!reader_.can_read(scalar_size(prop.type))) {
          s = reader_.overrun(scalar_size(prop.type));
        } else {
          if (layout_.slot[p] != kSkipProperty) {
            v[layout_.slot[p]] = load_as_double(reader_.current(), prop.type, endian_);
          }
          s = reader_.skip(scalar_size(prop.type));
        }
        if (!s.ok()) return item_error(vertex, item_, s);
      }
      out.positions.emplace_back(narrow_to_float(v[kX]), narrow_to_float(v[kY]),
                                 narrow_to_float(v[kZ]));
      if (layout_.normals) {
        out.normals.emplace_back(narrow_to_float(v[kNx]), narrow_to_float(v[kNy]),
                                 narrow_to_float(v[kNz]));
      }
      if (layout_.colours) {
        const auto channel = [&](PlySlot s) {
          return colour_channel(v[s], vertex.properties[*layout_.property[s]].type);
        };
        out.colours.push_back(Rgb8{channel(kRed), channel(kGreen), channel(kBlue)});
      }
      const std::size_t idx = out.size() - 1;
      if (!out.positions[idx].allFinite() || (layout_.normals && !out.normals[idx].allFinite())) {
        return non_finite_error(name_, out, idx, "byte offset " + std::to_string(item_offset),
                                points_ - idx);
      }
      if (wide_.wanted()) wide_.add(Vec3d(v[kX], v[kY], v[kZ]), out.positions[idx]);
      ++points_;
    }
    progress_advance(progress_, reader_.offset() - start);
    return Status();
  }

  const PlyHeader& header_;
  const PlyVertexLayout& layout_;
  std::string_view name_;
  Progress* progress_;
  WidePositions& wide_;
  Endian endian_;
  ByteReader reader_;
  std::size_t element_ = 0;  // the element being read
  std::uint64_t item_ = 0;   // its next item
  std::size_t points_ = 0;   // vertices read so far, for messages that number them
  bool started_ = false;
  bool done_ = false;
};

}  // namespace

std::unique_ptr<PointReader> make_ply_binary_body(std::span<const std::byte> file,
                                                  const PlyHeader& header,
                                                  const PlyVertexLayout& layout,
                                                  std::string_view name,
                                                  const PlyBodySinks& sinks) {
  return std::make_unique<BinaryBodyReader>(file, header, layout, name, sinks);
}

}  // namespace sspc::io
