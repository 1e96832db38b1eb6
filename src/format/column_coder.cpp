// The column coder (docs/FORMAT.md, "The columns"). One walk serves both directions: the encoder
// passes the true points and gets the same decisions coded, the decoder gets them from the
// stream; both keep the same four rows of state from which the contexts come.
#include "format/column_coder.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <tuple>

#include "core/check.hpp"

namespace sspc::codec {

namespace {

using Point = std::array<std::uint32_t, 3>;

// The occupancy template (docs/FORMAT.md, "The columns"): context bit k is the cell at (row
// offset, column offset) (0,−1), (0,−2), (−1,−1), (−1,0), (−1,1), (−2,0), (−1,−2), (−1,2), (−2,−1),
// (−2,1) for k = 0 … 9; rows above are negative.

// The window of columns a lowest height is predicted from: rows −3..0, columns −3..3, those
// coded before it.
constexpr int kWindowRows = 3;
constexpr int kWindowColumns = 3;

// floor(a / b) for b > 0.
std::int64_t floor_div(std::int64_t a, std::int64_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

std::int64_t det3(std::int64_t a, std::int64_t b, std::int64_t c, std::int64_t d, std::int64_t e, std::int64_t f,
                  std::int64_t g, std::int64_t h, std::int64_t i) {
  return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g);
}

// A column's occupied cells in the window's rows above the current one (dy = −3..−1): their
// count, Σdy, Σdy², Σz, Σdy·z and the least and greatest z (lo > hi when none).
struct ColumnSums {
  std::int64_t n = 0, sy = 0, syy = 0, sz = 0, syz = 0;
  std::uint32_t lo = 0xFFFFFFFFu, hi = 0;
};

// The last four rows of the rectangle: occupancy, lowest height, and whether a column holds more
// than one point. Row r lives in slot r mod 4; columns are padded by 2 on each side. When a row
// starts, each column's sums over the window's rows above it are taken once (padded by the
// window's width on each side, zero there), so that a prediction adds seven columns' sums
// instead of visiting up to 21 cells: the decoder spent 30% of a whole decode in the prediction.
class Rows {
 public:
  explicit Rows(std::uint32_t width) : width_(width), zeros_(width + 4, 0), sums_(width + 2 * kWindowColumns) {
    for (auto& row : occupied_) row.assign(width + 4, 0);
    for (auto& row : lowest_) row.assign(width, 0);
    for (auto& row : stacked_) row.assign(width, 0);
  }
  void start(std::int64_t row) {
    const std::size_t s = slot(row);
    std::fill(occupied_[s].begin(), occupied_[s].end(), 0);
    std::fill(stacked_[s].begin(), stacked_[s].end(), 0);
    std::fill(sums_.begin(), sums_.end(), ColumnSums{});
    for (std::int64_t dy = -kWindowRows; dy < 0; ++dy) {
      if (row + dy < 0) continue;
      const std::uint8_t* occupied = occupied_row(row + dy) + 2;
      const std::uint32_t* lowest = lowest_row(row + dy);
      for (std::size_t c = 0; c < width_; ++c) {
        if (occupied[c] == 0) continue;
        ColumnSums& sum = sums_[c + kWindowColumns];
        const std::uint32_t z = lowest[c];
        const auto zi = static_cast<std::int64_t>(z);
        ++sum.n;
        sum.sy += dy;
        sum.syy += dy * dy;
        sum.sz += zi;
        sum.syz += dy * zi;
        sum.lo = std::min(sum.lo, z);
        sum.hi = std::max(sum.hi, z);
      }
    }
  }
  // Column c's sums (c may lie up to the window's width outside the row).
  const ColumnSums& sums(std::int64_t c) const { return sums_[static_cast<std::size_t>(c + kWindowColumns)]; }
  bool stacked(std::int64_t row, std::int64_t column) const {
    if (row < 0 || column < 0) return false;
    return stacked_[slot(row)][static_cast<std::size_t>(column)] != 0;
  }
  void set(std::int64_t row, std::int64_t column, std::uint32_t z) {
    occupied_[slot(row)][static_cast<std::size_t>(column + 2)] = 1;
    lowest_[slot(row)][static_cast<std::size_t>(column)] = z;
  }
  void set_stacked(std::int64_t row, std::int64_t column) { stacked_[slot(row)][static_cast<std::size_t>(column)] = 1; }
  std::int64_t width() const { return width_; }
  // Row `row`'s occupancy from column −2 (all empty for a row before the first).
  const std::uint8_t* occupied_row(std::int64_t row) const {
    return row < 0 ? zeros_.data() : occupied_[slot(row)].data();
  }
  const std::uint32_t* lowest_row(std::int64_t row) const { return lowest_[slot(row)].data(); }

 private:
  static std::size_t slot(std::int64_t row) { return static_cast<std::size_t>(row & 3); }
  std::uint32_t width_;
  std::vector<std::uint8_t> zeros_;
  std::array<std::vector<std::uint8_t>, 4> occupied_;
  std::array<std::vector<std::uint32_t>, 4> lowest_;
  std::array<std::vector<std::uint8_t>, 4> stacked_;
  std::vector<ColumnSums> sums_;
};

// Bit k of the context is the template's cell k, read from the padded rows without bounds
// checks (the decoder spends most of its time here and in predict_lowest).
std::size_t occupancy_context(const Rows& rows, std::int64_t r, std::int64_t c) {
  const std::uint8_t* r0 = rows.occupied_row(r) + 2 + c;
  const std::uint8_t* r1 = rows.occupied_row(r - 1) + 2 + c;
  const std::uint8_t* r2 = rows.occupied_row(r - 2) + 2 + c;
  return std::size_t{r0[-1]} | std::size_t{r0[-2]} << 1 | std::size_t{r1[-1]} << 2 | std::size_t{r1[0]} << 3 |
         std::size_t{r1[1]} << 4 | std::size_t{r2[0]} << 5 | std::size_t{r1[-2]} << 6 | std::size_t{r1[2]} << 7 |
         std::size_t{r2[-1]} << 8 | std::size_t{r2[1]} << 9;
}

struct Prediction {
  std::uint32_t value = 0;
  std::size_t context = 0;   // kind × 5 + spread
  std::size_t fraction = 1;  // where the unrounded prediction fell in [value − ½, value + ½), in quarters
  std::size_t slope = 0;     // the plane's |gradient| in cells a cell: < ½, < 1, < 2, more
};

// The quarter of [q − ½, q + ½) that the unrounded prediction num / den fell in, given
// t = num + den/2·... : t = (2·num + den) − 2·den·q ∈ [0, 2·den).
std::size_t quarter(std::int64_t t, std::int64_t den) { return static_cast<std::size_t>((2 * t) / den); }

// The lowest height of column (r, c) predicted from the columns behind it in the window: none,
// the raster-previous column's; one to three, their mean; four or more, the least-squares plane
// z = a + b·dx + c·dy through them evaluated at (0, 0), in exact integer arithmetic (the mean
// when they are collinear). The context is the kind (0, 1, 2) × min(bit width of the heights'
// spread, 4).
Prediction predict_lowest(const Rows& rows, std::int64_t r, std::int64_t c, std::uint32_t previous, int bits) {
  std::int64_t n = 0, sx = 0, sy = 0, sz = 0, sxx = 0, sxy = 0, syy = 0, sxz = 0, syz = 0;
  std::uint32_t lo = 0xFFFFFFFFu, hi = 0;
  // The rows above: each column's sums, its offset dx = k applied here.
  for (std::int64_t k = -kWindowColumns; k <= kWindowColumns; ++k) {
    const ColumnSums& s = rows.sums(c + k);
    n += s.n;
    sx += k * s.n;
    sxx += k * k * s.n;
    sy += s.sy;
    syy += s.syy;
    sxy += k * s.sy;
    sz += s.sz;
    sxz += k * s.sz;
    syz += s.syz;
    lo = std::min(lo, s.lo);
    hi = std::max(hi, s.hi);
  }
  // The current row (dy = 0): the columns before this one.
  const std::uint8_t* occupied = rows.occupied_row(r) + 2;
  const std::uint32_t* lowest = rows.lowest_row(r);
  for (std::int64_t cc = std::max<std::int64_t>(0, c - kWindowColumns); cc < c; ++cc) {
    if (occupied[cc] == 0) continue;
    const std::int64_t dx = cc - c;
    const std::uint32_t z = lowest[cc];
    const auto zi = static_cast<std::int64_t>(z);
    ++n;
    sx += dx;
    sxx += dx * dx;
    sz += zi;
    sxz += dx * zi;
    lo = std::min(lo, z);
    hi = std::max(hi, z);
  }
  if (n == 0) return {previous, 0, 1, 0};
  const std::size_t spread = std::min<std::size_t>(static_cast<std::size_t>(std::bit_width(hi - lo)), 4);
  const std::int64_t mean = floor_div(2 * sz + n, 2 * n);
  const Prediction by_mean{static_cast<std::uint32_t>(mean), (n < 4 ? 5 : 10) + spread,
                           quarter(2 * sz + n - 2 * n * mean, n), std::min<std::size_t>(spread, 3)};
  if (n < 4) return by_mean;
  std::int64_t det = det3(n, sx, sy, sx, sxx, sxy, sy, sxy, syy);
  std::int64_t det_a = det3(sz, sx, sy, sxz, sxx, sxy, syz, sxy, syy);
  if (det == 0) return by_mean;
  const std::int64_t det_e = det3(n, sz, sy, sx, sxz, sxy, sy, syz, syy);
  const std::int64_t det_f = det3(n, sx, sz, sx, sxx, sxz, sy, sxy, syz);
  if (det < 0) {
    det = -det;
    det_a = -det_a;
  }
  const std::int64_t plane = floor_div(2 * det_a + det, 2 * det);
  const std::int64_t top = (std::int64_t{1} << bits) - 1;
  const std::int64_t gradient = (det_e < 0 ? -det_e : det_e) + (det_f < 0 ? -det_f : det_f);
  const std::size_t slope = 2 * gradient < det ? 0 : gradient < det ? 1 : gradient < 2 * det ? 2 : 3;
  return {static_cast<std::uint32_t>(std::clamp<std::int64_t>(plane, 0, top)), 10 + spread,
          quarter(2 * det_a + det - 2 * det * plane, det), slope};
}

struct ColumnEncoding {
  RangeEncoder& rc;
  unsigned bit(std::uint16_t& p, unsigned value) {
    rc.encode(p, value);
    return value;
  }
  std::uint32_t value(ValueModel& m, std::uint32_t v) {
    m.encode(rc, v);
    return v;
  }
  std::uint32_t direct(std::uint32_t v, int n) {
    rc.encode_direct(v, n);
    return v;
  }
  bool exhausted() const { return false; }
};

struct ColumnDecoding {
  RangeDecoder& rc;
  unsigned bit(std::uint16_t& p, unsigned /*value*/) { return rc.decode(p); }
  std::uint32_t value(ValueModel& m, std::uint32_t /*v*/) { return m.decode(rc); }
  std::uint32_t direct(std::uint32_t /*v*/, int n) { return rc.decode_direct(n); }
  bool exhausted() const { return rc.overrun(); }
};

// Codes a signed residual with the zero / sign / magnitude models of one context.
template <typename Io>
std::int64_t code_residual(Io& io, std::uint16_t& zero, std::uint16_t& sign, ValueModel& magnitude,
                           std::int64_t truth) {
  if (io.bit(zero, truth == 0 ? 1u : 0u) != 0) return 0;
  const unsigned negative = io.bit(sign, truth < 0 ? 1u : 0u);
  const auto m = static_cast<std::int64_t>(
                     io.value(magnitude, static_cast<std::uint32_t>((truth < 0 ? -truth : truth) - 1))) +
                 1;
  return negative != 0 ? -m : m;
}

// The walk; `truth` is empty when decoding, and otherwise in cell order for `shift`. Returns false
// on a decoded value off the grid, more than max_points points, or an exhausted stream.
template <typename Io>
bool walk_columns(Io& io, ColumnModels& m, int bits, int shift, bool duplicates, std::size_t max_points,
                  std::span<const Point> truth, std::vector<Point>& out) {
  const std::uint32_t size = 1u << bits;
  const std::uint32_t cells = size >> shift;  // per axis
  const std::uint32_t mask = (1u << shift) - 1;
  const bool encoding = !truth.empty();
  std::uint32_t x_min = cells, x_max = 0;
  for (const Point& p : truth) {
    x_min = std::min(x_min, p[0] >> shift);
    x_max = std::max(x_max, p[0] >> shift);
  }
  const std::uint32_t x0 = io.value(m.rectangle[0], x_min);
  const std::uint32_t y0 = io.value(m.rectangle[1], encoding ? truth.front()[1] >> shift : 0);
  const std::uint32_t width = io.value(m.rectangle[2], x_max - x_min) + 1;
  const std::uint32_t height =
      io.value(m.rectangle[3], encoding ? (truth.back()[1] >> shift) - (truth.front()[1] >> shift) : 0) + 1;
  if (x0 >= cells || y0 >= cells || width > cells - x0 || height > cells - y0) return false;
  Rows rows(width);
  std::size_t cursor = 0, produced = 0;
  std::uint32_t previous = 1u << (bits - 1);
  const std::uint32_t min_gap = duplicates ? 0 : 1;
  const auto in_cell = [&](std::size_t i, std::uint32_t cx, std::uint32_t cy) {
    return encoding && i < truth.size() && truth[i][1] >> shift == cy && truth[i][0] >> shift == cx;
  };
  for (std::int64_t r = 0; r < height; ++r) {
    if (io.exhausted()) return false;
    rows.start(r);
    const std::uint32_t cy = y0 + static_cast<std::uint32_t>(r);
    for (std::int64_t c = 0; c < width; ++c) {
      const std::uint32_t cx = x0 + static_cast<std::uint32_t>(c);
      const bool here = in_cell(cursor, cx, cy);
      if (io.bit(m.occupied[occupancy_context(rows, r, c)], here ? 1u : 0u) == 0) continue;
      if (++produced > max_points) return false;
      // The first point: where in the cell (shift > 0), and its height against the prediction.
      std::uint32_t ox = 0, oy = 0;
      if (shift > 0) {
        ox = io.direct(here ? truth[cursor][0] & mask : 0, shift);
        oy = io.direct(here ? truth[cursor][1] & mask : 0, shift);
      }
      const Prediction pred = predict_lowest(rows, r, c, previous, bits);
      const std::size_t near = pred.context * 4 + pred.fraction;
      const std::int64_t z = static_cast<std::int64_t>(pred.value) +
                             code_residual(io, m.zero[near], m.sign[near], m.magnitude[pred.context],
                                           here ? static_cast<std::int64_t>(truth[cursor][2]) -
                                                      static_cast<std::int64_t>(pred.value)
                                                : 0);
      if (z < 0 || z >= static_cast<std::int64_t>(size)) return false;
      auto z_here = static_cast<std::uint32_t>(z);
      out.push_back({cx << shift | ox, cy << shift | oy, z_here});
      rows.set(r, c, z_here);
      previous = z_here;
      // Further points of the cell: up the column (shift 0), or anywhere in it.
      const std::size_t stack_context = rows.stacked(r, c - 1) || rows.stacked(r - 1, c) ? 1 : 0;
      std::size_t k = 1;
      for (;; ++k) {
        const bool more = in_cell(cursor + k, cx, cy);
        const std::size_t ctx = (std::min<std::size_t>(k - 1, 2) * 2 + stack_context) * 4 + pred.slope;
        if (io.bit(m.another[ctx], more ? 1u : 0u) == 0) break;
        if (++produced > max_points) return false;
        rows.set_stacked(r, c);
        const Point* t = more ? &truth[cursor + k] : nullptr;
        if (shift == 0) {
          const std::uint32_t gap = io.value(m.gap[k == 1 ? 0 : 1], t != nullptr ? (*t)[2] - z_here - min_gap : 0);
          if (z_here + min_gap + gap >= size) return false;  // each term is below 2^16
          z_here += min_gap + gap;
          out.push_back({cx, cy, z_here});
          continue;
        }
        ox = io.direct(t != nullptr ? (*t)[0] & mask : 0, shift);
        oy = io.direct(t != nullptr ? (*t)[1] & mask : 0, shift);
        const std::int64_t zz =
            static_cast<std::int64_t>(z_here) +
            code_residual(io, m.other_zero, m.other_sign, m.other_magnitude,
                          t != nullptr ? static_cast<std::int64_t>((*t)[2]) - static_cast<std::int64_t>(z_here) : 0);
        if (zz < 0 || zz >= static_cast<std::int64_t>(size)) return false;
        z_here = static_cast<std::uint32_t>(zz);
        out.push_back({cx << shift | ox, cy << shift | oy, z_here});
      }
      if (here) cursor += k;
    }
  }
  SSPC_DCHECK(!encoding || cursor == truth.size());
  return true;
}

}  // namespace

ColumnModels::ColumnModels() : empty(kProbabilityHalf), other_zero(kProbabilityHalf), other_sign(kProbabilityHalf) {
  occupied.fill(kProbabilityHalf);
  zero.fill(kProbabilityHalf);
  sign.fill(kProbabilityHalf);
  another.fill(kProbabilityHalf);
}

int column_shift(std::span<const Point> points, int bits) {
  if (points.empty()) return 0;
  std::uint32_t x_min = points.front()[0], x_max = x_min, y_min = points.front()[1], y_max = y_min;
  for (const Point& p : points) {
    x_min = std::min(x_min, p[0]);
    x_max = std::max(x_max, p[0]);
    y_min = std::min(y_min, p[1]);
    y_max = std::max(y_max, p[1]);
  }
  const double per_point = static_cast<double>(x_max - x_min + 1) * static_cast<double>(y_max - y_min + 1) /
                           static_cast<double>(points.size());
  int shift = 0;
  while (shift + 1 < bits && shift < kMaxColumnShift && 2 * std::ldexp(1.0, 2 * (shift + 1)) <= per_point) ++shift;
  return shift;
}

std::vector<std::uint32_t> column_order(std::span<const Point> points, int shift) {
  std::vector<std::uint32_t> order(points.size());
  for (std::uint32_t k = 0; k < order.size(); ++k) order[k] = k;
  // The index as the last key keeps the points' own order within a cell (std::stable_sort would
  // too, but its buffer comes from a nothrow operator new, which AllocationLimit's replacement
  // of the allocator does not cover).
  std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    const Point& p = points[a];
    const Point& q = points[b];
    return std::tuple(p[1] >> shift, p[0] >> shift, a) < std::tuple(q[1] >> shift, q[0] >> shift, b);
  });
  return order;
}

void encode_columns(RangeEncoder& rc, ColumnModels& m, std::span<const Point> points, int bits, int shift,
                    bool duplicates) {
  SSPC_DCHECK(bits >= 1 && bits <= 16 && shift >= 0 && shift < bits && shift <= kMaxColumnShift);
  ColumnEncoding io{rc};
  if (io.bit(m.empty, points.empty() ? 1u : 0u) != 0) return;
  io.value(m.shift, static_cast<std::uint32_t>(shift));
  std::vector<Point> out;
  out.reserve(points.size());
  const bool walked = walk_columns(io, m, bits, shift, duplicates, points.size(), points, out);
  SSPC_DCHECK(walked && out.size() == points.size());
}

bool decode_columns(RangeDecoder& rc, ColumnModels& m, int bits, std::size_t max_points, bool duplicates,
                    std::vector<Point>& out) {
  ColumnDecoding io{rc};
  if (io.bit(m.empty, 0) != 0) return true;
  const std::uint32_t shift = io.value(m.shift, 0);
  if (shift >= static_cast<std::uint32_t>(bits) || shift > kMaxColumnShift) return false;
  return walk_columns(io, m, bits, static_cast<int>(shift), duplicates, max_points, {}, out);
}

}  // namespace sspc::codec
