// Block payloads of docs/FORMAT.md. Values are split into byte planes (low bytes, then high
// bytes) so that zstd's literal coder sees each plane's own small alphabet; patch fields are
// delta-coded zig-zag varints because patches arrive in spatial order; rotations are bit-packed
// because their bits are close to random and padding them to bytes would cost ~20 %.
#include "format/block_codec.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <string>

#include "core/byte_reader.hpp"
#include "core/check.hpp"
#include "core/varint.hpp"
#include "format/block_codec_v1.hpp"
#include "format/column_coder.hpp"
#include "format/quantise.hpp"
#include "format/range_coder.hpp"

namespace sspc::codec {
namespace {

// LSB-first bit packing.
class BitWriter {
 public:
  explicit BitWriter(std::string& out) : out_(out) {}
  void put(std::uint64_t value, int width) {
    for (int i = 0; i < width; ++i) {
      if (used_ == 0) out_.push_back('\0');
      if ((value >> i) & 1u) {
        out_.back() = static_cast<char>(static_cast<unsigned char>(out_.back()) | (1u << used_));
      }
      used_ = (used_ + 1) & 7;
    }
  }

 private:
  std::string& out_;
  int used_ = 0;
};

// Reads `width` ≤ 32 bits at bit position `pos` of `bytes`, which the caller has sized so that
// pos + width bits exist.
std::uint32_t get_bits(std::span<const std::byte> bytes, std::size_t pos, int width) {
  std::uint64_t word = 0;
  const std::size_t first = pos / 8;
  const std::size_t n = std::min<std::size_t>(8, bytes.size() - first);
  for (std::size_t i = 0; i < n; ++i) {
    word |= static_cast<std::uint64_t>(static_cast<std::uint8_t>(bytes[first + i])) << (8 * i);
  }
  word >>= (pos % 8);
  return static_cast<std::uint32_t>(word & ((std::uint64_t{1} << width) - 1));
}

Status payload_error(std::size_t offset, const std::string& what) {
  return corrupt("payload byte " + std::to_string(offset) + ": " + what);
}

std::uint8_t byte_at(std::span<const std::byte> s, std::size_t i) {
  return static_cast<std::uint8_t>(s[i]);
}

}  // namespace

std::size_t bytes_per_codeword_point(const ContainerHeader& header) {
  return std::size_t{6} + (header.has_normals() ? 4u : 0u) + (header.has_colours() ? 3u : 0u);
}

namespace {

// Puts 16-bit values as a plane of low bytes, then a plane of high bytes.
void put_planes(std::string& out, const std::vector<std::uint32_t>& v) {
  for (std::uint32_t x : v) out.push_back(static_cast<char>(x & 0xFF));
  for (std::uint32_t x : v) out.push_back(static_cast<char>((x >> 8) & 0xFF));
}

// The order version 2 stores a code word's points in: rows of the tangent plane (y, then x,
// then height z on the code word's grid), so that consecutive points are neighbours.
// Sorted as (key, index) pairs, each key the three coordinates packed into 21 bits apiece (grid
// values are below 2^16): the same order as comparing the coordinates through the indices, with
// no load through an index in the comparisons.
std::vector<std::uint32_t> raster_order(const std::vector<std::array<std::uint32_t, 3>>& v) {
  std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(v.size());
  for (std::uint32_t i = 0; i < keyed.size(); ++i) {
    const auto& p = v[i];
    SSPC_DCHECK(p[0] < (1u << 21) && p[1] < (1u << 21) && p[2] < (1u << 21));
    keyed[i] = {std::uint64_t{p[1]} << 42 | std::uint64_t{p[0]} << 21 | p[2], i};
  }
  std::sort(keyed.begin(), keyed.end());
  std::vector<std::uint32_t> order(v.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = keyed[i].second;
  return order;
}

// The height residual (v − prediction) on the ring of 2^bits values, as a signed value in
// [−2^(bits−1), 2^(bits−1)) and zig-zagged into [0, 2^bits): small either way, never wider than
// the grid, and every stored value below 2^bits decodes to a point on the grid.
std::uint32_t zigzag_residual(std::uint32_t v, std::uint32_t prediction, int bits) {
  const std::uint32_t size = 1u << bits;
  const std::uint32_t r = (v - prediction) & (size - 1);
  return r < size / 2 ? 2 * r : 2 * (size - r) - 1;
}

std::uint32_t apply_residual(std::uint32_t zigzag, std::uint32_t prediction, int bits) {
  const std::uint32_t size = 1u << bits;
  const std::uint32_t r = (zigzag & 1u) ? size - (zigzag + 1) / 2 : zigzag / 2;
  return (prediction + r) & (size - 1);
}

// Version 2's height prediction: the previous point's height within a row; the height of the
// previous row's point nearest in x (the first on a tie) at the start of a row; the grid's
// middle (height 0) for a code word's first point.
std::uint32_t predict_height(std::span<const std::array<std::uint32_t, 3>> row_above,
                             const std::array<std::uint32_t, 3>& previous, bool same_row,
                             std::uint32_t x, int bits) {
  if (same_row) return previous[2];
  if (row_above.empty()) return 1u << (bits - 1);
  // The previous row's point nearest in x (the first on a tie): rows are sorted by x.
  std::uint32_t best = row_above[0][2];
  std::uint32_t best_dx = x > row_above[0][0] ? x - row_above[0][0] : row_above[0][0] - x;
  for (const auto& p : row_above) {
    const std::uint32_t dx = x > p[0] ? x - p[0] : p[0] - x;
    if (dx < best_dx) {
      best_dx = dx;
      best = p[2];
    }
  }
  return best;
}

}  // namespace

namespace {

// The adaptive models of one code-book block's positions (reset per block, so that blocks
// decode independently), by context: see walk_codeword.
struct PositionModels {
  std::array<ValueModel, 4> dy;  // 0..2: min(previous dy, 2); 3: a code word's first row
  std::array<ValueModel, 3> x;   // 0: step within a row; 1: a new row's start; 2: first point
  std::array<ValueModel, 5> z;   // 0..3: min(bit width of the previous residual, 3); 4: first
};

struct Encoding {
  RangeEncoder& rc;
  std::uint32_t code(ValueModel& m, std::uint32_t value) {
    m.encode(rc, value);
    return value;
  }
};
struct Decoding {
  RangeDecoder& rc;
  std::uint32_t code(ValueModel& m, std::uint32_t /*value*/) { return m.decode(rc); }
};

// Codes one code word's grid points in raster order, the same walk for both directions: the
// encoder passes the sorted points and gets them back, the decoder passes zeros and gets the
// decoded points. Per point: the row step dy; within a row the x step, at a row's start x
// against the previous row's first x; the height against predict_height. Returns false when a
// decoded value leaves the grid of 2^bits.
template <typename Io>
bool walk_codeword(Io& io, PositionModels& m, std::span<std::array<std::uint32_t, 3>> points, int bits) {
  const std::uint32_t size = 1u << bits;
  std::size_t row_start = 0, previous_row_start = 0;
  std::uint32_t previous_dy = 0, previous_z = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    std::array<std::uint32_t, 3>& v = points[i];
    const bool first = i == 0;
    const std::array<std::uint32_t, 3> before = first ? v : points[i - 1];
    const std::uint32_t dy = io.code(m.dy[first ? 3 : std::min<std::uint32_t>(previous_dy, 2)], v[1] - before[1] * !first);
    const std::uint32_t y = first ? dy : before[1] + dy;
    if (dy >= size || y >= size) return false;
    const bool same_row = !first && dy == 0;
    if (!first && !same_row) {
      previous_row_start = row_start;
      row_start = i;
    }
    std::uint32_t x = 0;
    if (first) {
      x = io.code(m.x[2], v[0]);
    } else if (same_row) {
      const std::uint32_t dx = io.code(m.x[0], v[0] - before[0]);
      if (dx >= size) return false;
      x = before[0] + dx;
    } else {
      const std::uint32_t pred = points[previous_row_start][0];
      const std::uint32_t r = io.code(m.x[1], zigzag_residual(v[0], pred, bits));
      if (r >= size) return false;
      x = apply_residual(r, pred, bits);
    }
    if (x >= size) return false;
    const std::span<const std::array<std::uint32_t, 3>> above =
        first || row_start == 0 ? std::span<const std::array<std::uint32_t, 3>>()
                                : std::span<const std::array<std::uint32_t, 3>>(points).subspan(
                                      previous_row_start, row_start - previous_row_start);
    const std::uint32_t pred = predict_height(above, before, same_row, x, bits);
    const auto zctx = first ? 4u : std::min<std::uint32_t>(static_cast<std::uint32_t>(std::bit_width(previous_z)), 3);
    const std::uint32_t r = io.code(m.z[zctx], zigzag_residual(v[2], pred, bits));
    if (r >= size) return false;
    v = {x, y, apply_residual(r, pred, bits)};
    previous_dy = dy;
    previous_z = r;
  }
  return true;
}

}  // namespace

bool codeword_points_fit(const ContainerHeader& header, std::uint64_t points, std::uint64_t raw_size) {
  // Every point needs per_point bytes (positions, in version 1, normals and colours), and in
  // version 2 its range-coded position at least 1/kMaxPointsPerByte of a byte, in version 3
  // 1/kMaxColumnPointsPerByte.
  const std::size_t per_point = bytes_per_codeword_point(header) - (header.version == 1 ? 0 : 6);
  if (per_point > 0 && points > raw_size / per_point) return false;
  if (header.version == 1) return true;
  return points <= (header.version == 2 ? kMaxPointsPerByte : kMaxColumnPointsPerByte) * raw_size;
}

namespace {

// The normals' and colours' parts of a code-book payload, in the order of the points.
struct AttributeWriter {
  const ContainerHeader& header;
  std::vector<std::uint32_t> normals;
  std::string colours[3];

  void add(const Codeword& c, std::size_t i) {
    if (header.has_normals()) {
      const Vec3f n = i < c.normals.size() ? c.normals[i] : Vec3f::UnitZ();
      const auto uv = encode_normal(n, header.normal_bits);
      normals.push_back(uv[0]);
      normals.push_back(uv[1]);
    }
    if (header.has_colours()) {
      const Rgb8 rgb = i < c.colours.size() ? c.colours[i] : Rgb8{};
      colours[0].push_back(static_cast<char>(rgb.r));
      colours[1].push_back(static_cast<char>(rgb.g));
      colours[2].push_back(static_cast<char>(rgb.b));
    }
  }
  void append_to(std::string& out) const {
    if (header.has_normals()) put_planes(out, normals);
    if (header.has_colours()) out += colours[0] + colours[1] + colours[2];
  }
};

// See encode_codeword_block_v3.
constexpr float kPricedShiftStep = 0.75f;

// Version 5's writer codes a lowest height one step nearer its prediction where that saves more
// than 1/λ steps² of squared error a bit (column_coder.hpp, HeightChoice), choosing on each code
// word alone before the code words are trimmed and put in blocks (choose_codeword_heights). λ = 0.05: the levels'
// own trade is about 0.1 steps² a bit (0.4-0.6 bits a point a dB at 0.25 steps² a point), and
// 0.05 measured better than 0.1 and 0.2 on bunny and igea (docs/FORMAT_NOTES.md, "Heights
// at the point").
constexpr double kHeightLambda = 0.05;

// Where x lies in its grid step (quantise_coordinate's cell), in steps from the cell's centre.
float step_fraction(float x, float step) {
  const double v = static_cast<double>(x) / static_cast<double>(step);
  return static_cast<float>(std::clamp(v - std::floor(v) - 0.5, -0.5, 0.5));
}

// A code word's grid points (`grid`, in its order), and those the columns code (`sorted`, in
// raster order, one per grid point without the duplicates flag) with their indices (`kept`).
void grid_points(const Codeword& c, float step, int bits, bool duplicates, std::vector<std::array<std::uint32_t, 3>>& grid,
                 std::vector<std::array<std::uint32_t, 3>>& sorted, std::vector<std::uint32_t>& kept) {
  grid.clear();
  for (const Vec3f& p : c.points) {
    grid.push_back({quantise_coordinate(p.x(), step, bits), quantise_coordinate(p.y(), step, bits),
                    quantise_coordinate(p.z(), step, bits)});
  }
  kept.clear();
  sorted.clear();
  for (const std::uint32_t i : raster_order(grid)) {
    if (!duplicates && !sorted.empty() && sorted.back() == grid[i]) continue;
    sorted.push_back(grid[i]);
    kept.push_back(i);
  }
}

// Version 3: each code word's points by the columns (format/column_coder.hpp), in their order.
// Without the duplicates flag a grid point keeps its first point's attributes (the writer has
// merged them already, encoder/codeword_trim.hpp).
std::string encode_codeword_block_v3(std::span<const Codeword> codewords, const ContainerHeader& header) {
  const float step = position_step(header.patch_radius, header.position_bits);
  const int bits = header.position_bits;
  std::string stream;
  RangeEncoder rc(stream);
  ColumnModels models(header.version);
  AttributeWriter attributes{header, {}, {}};
  std::vector<std::array<std::uint32_t, 3>> grid, sorted, coded;
  // The cell sizes are priced on grids finer than kPricedShiftStep spacings only (levels 0-4):
  // at autzen's level 5 pricing ran on 8.2M of its 10M code-word points, took 1.4-3 s of a 40 s
  // encode, and the file came out 439 bytes larger (a cell size that codes one code word
  // cheaper can train the block's models worse for the next); on the range scans it gained
  // 0.0-0.2% at levels 5-9.
  const bool price_shifts = header.spacing > 0 && step < kPricedShiftStep * header.spacing;
  std::vector<std::uint32_t> kept;
  for (const Codeword& c : codewords) {
    grid_points(c, step, bits, header.has_duplicates(), grid, sorted, kept);
    const int shift = price_shifts ? cheapest_shift(models, sorted, bits, header.has_duplicates())
                                   : column_shift(sorted, bits);
    coded.clear();
    for (const std::uint32_t k : column_order(sorted, shift)) {
      coded.push_back(sorted[k]);
      attributes.add(c, kept[k]);
    }
    encode_columns(rc, models, coded, bits, shift, header.has_duplicates());
  }
  rc.finish();
  std::string out;
  append_varint(out, stream.size());
  out += stream;
  attributes.append_to(out);
  return out;
}

}  // namespace

void choose_codeword_heights(Codeword& c, const ContainerHeader& header) {
  if (header.version < 5 || c.points.empty()) return;
  const float step = position_step(header.patch_radius, header.position_bits);
  const int bits = header.position_bits;
  std::vector<std::array<std::uint32_t, 3>> grid, sorted, coded, chosen;
  std::vector<std::uint32_t> kept, order;
  grid_points(c, step, bits, header.has_duplicates(), grid, sorted, kept);
  const int shift = column_shift(sorted, bits);
  std::vector<float> fraction;
  for (const std::uint32_t k : column_order(sorted, shift)) {
    coded.push_back(sorted[k]);
    order.push_back(kept[k]);
    fraction.push_back(step_fraction(c.points[kept[k]].z(), step));
  }
  ColumnModels models(header.version);
  std::string scratch;
  RangeEncoder rc(scratch);
  encode_columns(rc, models, coded, bits, shift, header.has_duplicates(), {fraction, kHeightLambda}, &chosen);
  SSPC_DCHECK(chosen.size() == coded.size());
  for (std::size_t k = 0; k < chosen.size(); ++k) {
    if (chosen[k][2] != coded[k][2]) c.points[order[k]].z() = dequantise_coordinate(chosen[k][2], step, bits);
  }
}

std::string encode_codeword_block(std::span<const Codeword> codewords,
                                  const ContainerHeader& header) {
  if (header.version >= 3) return encode_codeword_block_v3(codewords, header);
  std::string out;
  for (const Codeword& c : codewords) append_varint(out, c.points.size());
  const float step = position_step(header.patch_radius, header.position_bits);
  const int bits = header.position_bits;
  std::string stream;
  RangeEncoder rc(stream);
  Encoding io{rc};
  PositionModels models;
  AttributeWriter attributes{header, {}, {}};
  std::vector<std::array<std::uint32_t, 3>> grid, sorted;
  for (const Codeword& c : codewords) {
    grid.clear();
    for (const Vec3f& p : c.points) {
      grid.push_back({quantise_coordinate(p.x(), step, bits), quantise_coordinate(p.y(), step, bits),
                      quantise_coordinate(p.z(), step, bits)});
    }
    const std::vector<std::uint32_t> order = raster_order(grid);
    sorted.clear();
    for (std::uint32_t i : order) sorted.push_back(grid[i]);
    // The writer's own grid values lie within 2^bits (quantise_coordinate clamps), so its walk
    // cannot leave the grid.
    const bool walked = walk_codeword(io, models, sorted, bits);
    SSPC_DCHECK(walked);
    for (std::uint32_t i : order) attributes.add(c, i);
  }
  rc.finish();
  append_varint(out, stream.size());
  out += stream;
  attributes.append_to(out);
  return out;
}

StatusOr<std::string> encode_patch_block(std::span<const PatchInstance> patches,
                                         const ContainerHeader& header) {
  std::string out;
  std::int64_t previous_codeword = 0;
  for (const PatchInstance& p : patches) {
    append_varint(out, zigzag_encode(static_cast<std::int64_t>(p.codeword) - previous_codeword));
    previous_codeword = p.codeword;
  }
  // Version 2: per axis, the zig-zagged deltas as four byte planes (least significant first).
  std::array<std::int64_t, 3> previous{0, 0, 0};
  std::array<std::vector<std::uint32_t>, 3> deltas;
  for (const PatchInstance& p : patches) {
    std::array<std::int32_t, 3> v{};
    if (!quantise_translation(p.world_from_codeword.translation, header.bounds_min,
                              header.translation_step, v)) {
      return invalid_argument(
          "a patch translation lies more than 2^24 translation steps from "
          "the bounds' minimum; use a larger translation_step");
    }
    for (std::size_t a = 0; a < 3; ++a) {
      deltas[a].push_back(static_cast<std::uint32_t>(zigzag_encode(v[a] - previous[a])));
      previous[a] = v[a];
    }
  }
  for (const auto& axis : deltas) {
    for (int plane = 0; plane < 4; ++plane) {
      for (std::uint32_t d : axis) out.push_back(static_cast<char>((d >> (8 * plane)) & 0xFF));
    }
  }
  BitWriter bits(out);
  for (const PatchInstance& p : patches) {
    const PackedRotation r = encode_rotation(p.world_from_codeword.rotation, header.rotation_bits);
    bits.put(r.index, 2);
    for (std::uint32_t c : r.c) bits.put(c, header.rotation_bits);
  }
  return out;
}

Status decode_codeword_block(std::span<const std::byte> raw, const BlockEntry& entry,
                             const ContainerHeader& header, DecodedCodewords& out) {
  ByteReader reader(raw);
  const bool version1 = header.version == 1;
  if (!codeword_points_fit(header, entry.point_count, raw.size())) {
    return payload_error(0, "point count " + std::to_string(entry.point_count) + " cannot fit in " +
                                std::to_string(raw.size()) + " bytes");
  }
  const std::size_t n = entry.point_count;
  const bool version3 = header.version >= 3;
  out.first = entry.first;
  out.offsets.assign(1, 0);
  out.offsets.reserve(std::size_t{entry.count} + 1);
  std::uint64_t sum = 0;
  // Versions 1 and 2 store the code words' point counts; version 3's columns imply them.
  for (std::uint32_t c = 0; c < entry.count && !version3; ++c) {
    std::uint64_t count = 0;
    const std::size_t at = reader.position();
    if (!reader.read_varint(count).ok()) return payload_error(at, "bad or truncated point count");
    sum += count;
    if (count > n || sum > n) {
      return payload_error(
          at, "code words hold more points than the seek table's " + std::to_string(n));
    }
    out.offsets.push_back(static_cast<std::uint32_t>(sum));
  }
  SSPC_DCHECK(version3 || out.offsets.size() == std::size_t{entry.count} + 1);
  if (!version3 && sum != n) {
    return payload_error(reader.position(), "code words hold " + std::to_string(sum) +
                                                " points, the seek table says " +
                                                std::to_string(n));
  }
  std::span<const std::byte> pos_bytes, normal_bytes, colour_bytes;
  const auto take = [&reader](std::size_t bytes, std::span<const std::byte>& taken) {
    auto span = reader.read_bytes(bytes);
    if (!span.ok()) return false;
    taken = *span;
    return true;
  };
  std::uint64_t stream_size = v1::position_bytes(n);
  if (!version1 && !reader.read_varint(stream_size).ok()) {
    return payload_error(reader.position(), "bad or truncated position stream size");
  }
  if (stream_size > raw.size() || !take(static_cast<std::size_t>(stream_size), pos_bytes) ||
      (header.has_normals() && !take(4 * n, normal_bytes)) ||
      (header.has_colours() && !take(3 * n, colour_bytes))) {
    return payload_error(reader.position(), "payload ends inside the point data");
  }
  if (!reader.at_end()) {
    return payload_error(reader.position(),
                         std::to_string(reader.remaining()) + " bytes after the point data");
  }

  const float step = position_step(header.patch_radius, header.position_bits);
  const int pbits = header.position_bits;
  std::uint32_t overflow = 0;
  out.points.resize(n);
  out.norm2.resize(n);
  const auto set_point = [&](std::size_t i, const std::array<std::uint32_t, 3>& v) {
    float xyz[3];
    for (std::size_t a = 0; a < 3; ++a) xyz[a] = dequantise_coordinate(v[a], step, pbits);
    out.points[i] = Vec3f(xyz[0], xyz[1], xyz[2]);
    out.norm2[i] = xyz[0] * xyz[0] + xyz[1] * xyz[1] + xyz[2] * xyz[2];
  };
  std::vector<std::array<std::uint32_t, 3>> grid(n, {0, 0, 0});
  if (version1) {
    if (!v1::decode_positions(pos_bytes, pbits, grid)) overflow = 1;
  } else if (version3) {
    RangeDecoder rc(pos_bytes);
    ColumnModels models(header.version);
    std::vector<std::array<std::uint32_t, 3>> points;
    points.reserve(n);
    for (std::uint32_t c = 0; c < entry.count; ++c) {
      if (!decode_columns(rc, models, pbits, n - points.size(), header.has_duplicates(), points)) {
        return payload_error(0, "code word " + std::to_string(entry.first + c) +
                                    ": positions off the grid, more points than the seek table's " +
                                    std::to_string(n) + ", or the stream ends early");
      }
      out.offsets.push_back(static_cast<std::uint32_t>(points.size()));
    }
    if (points.size() != n) {
      return payload_error(0, "code words hold " + std::to_string(points.size()) + " points, the seek table says " +
                                  std::to_string(n));
    }
    std::copy(points.begin(), points.end(), grid.begin());
    if (!rc.finish()) return payload_error(0, "the position stream does not end where its size says");
  } else {
    RangeDecoder rc(pos_bytes);
    Decoding io{rc};
    PositionModels models;
    for (std::uint32_t c = 0; c < entry.count && overflow == 0; ++c) {
      const std::span<std::array<std::uint32_t, 3>> points(grid.data() + out.offsets[c],
                                                            out.offsets[c + 1] - out.offsets[c]);
      if (!walk_codeword(io, models, points, pbits)) overflow = 1;
    }
    if (overflow == 0 && !rc.finish()) {
      return payload_error(0, "the position stream does not end where its size says");
    }
  }
  if (overflow != 0) return payload_error(0, "a position value exceeds position_bits");
  for (std::size_t i = 0; i < n; ++i) set_point(i, grid[i]);
  if (header.has_normals()) {
    out.normals.resize(n);
    const int nbits = header.normal_bits;
    for (std::size_t i = 0; i < n; ++i) {
      std::uint32_t uv[2];
      for (std::size_t a = 0; a < 2; ++a) {
        const std::size_t j = 2 * i + a;
        uv[a] = byte_at(normal_bytes, j) |
                (static_cast<std::uint32_t>(byte_at(normal_bytes, 2 * n + j)) << 8);
        overflow |= uv[a] >> nbits;
      }
      out.normals[i] = decode_normal(uv[0], uv[1], nbits);
    }
    if (overflow != 0) return payload_error(6 * n, "a normal value exceeds normal_bits");
  } else {
    out.normals.clear();
  }
  if (header.has_colours()) {
    out.colours.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      out.colours[i] = Rgb8{byte_at(colour_bytes, i), byte_at(colour_bytes, n + i),
                           byte_at(colour_bytes, 2 * n + i)};
    }
  } else {
    out.colours.clear();
  }
  out.radius.resize(entry.count);
  for (std::uint32_t c = 0; c < entry.count; ++c) {
    float max_norm2 = 0;
    for (std::uint32_t i = out.offsets[c]; i < out.offsets[c + 1]; ++i) {
      max_norm2 = std::max(max_norm2, out.norm2[i]);
    }
    out.radius[c] = std::sqrt(max_norm2);
  }
  return Status();
}

Status decode_patch_block(std::span<const std::byte> raw, const BlockEntry& entry,
                          const ContainerHeader& header, bool check_box, DecodedPatches& out) {
  const std::size_t m = entry.count;
  // Each patch takes at least 4 varint bytes plus its rotation bits.
  const std::size_t rotation_bits = 2 + 3 * static_cast<std::size_t>(header.rotation_bits);
  if (m > raw.size() / 4) return payload_error(0, "patch count cannot fit in the block");
  const std::size_t rotation_bytes = (m * rotation_bits + 7) / 8;
  ByteReader reader(raw);
  out.first = entry.first;
  out.codeword.resize(m);
  out.rotation.resize(m);
  out.centre.resize(m);
  std::int64_t codeword = 0;
  for (std::size_t k = 0; k < m; ++k) {
    std::uint64_t z = 0;
    const std::size_t at = reader.position();
    if (!reader.read_varint(z).ok()) return payload_error(at, "bad or truncated code-word index");
    const std::int64_t delta = zigzag_decode(z);
    if (delta > std::int64_t{UINT32_MAX} || delta < -std::int64_t{UINT32_MAX}) {
      return payload_error(at, "code-word delta out of range");
    }
    codeword += delta;
    if (codeword < 0 || codeword >= std::int64_t{header.codeword_count}) {
      return payload_error(at, "code-word index " + std::to_string(codeword) +
                                   " outside the code book of " +
                                   std::to_string(header.codeword_count));
    }
    out.codeword[k] = static_cast<std::uint32_t>(codeword);
  }
  std::array<std::int64_t, 3> v{0, 0, 0};
  // Version 1: 3 varints per patch; version 2: per axis, four byte planes of m values.
  std::span<const std::byte> planes;
  if (header.version >= 2) {
    const std::size_t at = reader.position();
    auto bytes = reader.read_bytes(12 * m);
    if (!bytes.ok()) return payload_error(at, "payload ends inside the translations");
    planes = *bytes;
  }
  for (std::size_t k = 0; k < m; ++k) {
    std::array<std::int32_t, 3> grid{};
    for (std::size_t a = 0; a < 3; ++a) {
      std::uint64_t z = 0;
      const std::size_t at = reader.position();
      if (header.version >= 2) {
        for (std::size_t plane = 0; plane < 4; ++plane) {
          z |= std::uint64_t{byte_at(planes, (4 * a + plane) * m + k)} << (8 * plane);
        }
      } else if (!v1::read_translation_delta(reader, z)) {
        return payload_error(at, "bad or truncated translation");
      }
      const std::int64_t delta = zigzag_decode(z);
      if (delta > 2 * kMaxTranslationGrid || delta < -2 * kMaxTranslationGrid) {
        return payload_error(at, "translation delta out of range");
      }
      v[a] += delta;
      if (v[a] > kMaxTranslationGrid || v[a] < -kMaxTranslationGrid) {
        return payload_error(at, "translation outside the grid's |v| < 2^24");
      }
      grid[a] = static_cast<std::int32_t>(v[a]);
    }
    out.centre[k] = dequantise_translation(grid, header.bounds_min, header.translation_step);
    if (check_box && !entry.box.contains(out.centre[k])) {
      return payload_error(reader.position(),
                           "patch " + std::to_string(entry.first + k) +
                               " has its centre outside the block's box in the seek table");
    }
  }
  const auto rotations = reader.read_bytes(rotation_bytes);
  if (!rotations.ok()) {
    return payload_error(reader.position(), "payload ends inside the rotations");
  }
  const std::span<const std::byte> rot = *rotations;
  if (!reader.at_end()) {
    return payload_error(reader.position(),
                         std::to_string(reader.remaining()) + " bytes after the rotations");
  }
  const int b = header.rotation_bits;
  std::size_t bit = 0;
  for (std::size_t k = 0; k < m; ++k) {
    PackedRotation r;
    r.index = get_bits(rot, bit, 2);
    bit += 2;
    for (std::uint32_t& c : r.c) {
      c = get_bits(rot, bit, b);
      bit += static_cast<std::size_t>(b);
    }
    out.rotation[k] = decode_rotation(r, b);
  }
  const std::size_t pad = rotation_bytes * 8 - bit;
  if (pad > 0 && get_bits(rot, bit, static_cast<int>(pad)) != 0) {
    return payload_error(raw.size() - 1, "non-zero padding bits after the rotations");
  }
  return Status();
}

}  // namespace sspc::codec
