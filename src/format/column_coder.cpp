// The column coder (docs/FORMAT.md, "The columns"). One walk serves both directions: the encoder
// passes the true points and gets the same decisions coded, the decoder gets them from the
// stream; both keep the same four rows of state from which the contexts come.
#include "format/column_coder.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <limits>
#include <string>
#include <tuple>

#include "core/check.hpp"

namespace sspc::codec {

namespace {

using Point = std::array<std::uint32_t, 3>;

// The occupancy template (docs/FORMAT.md, "The columns"): context bit k is the cell at (row
// offset, column offset) (0,−1), (0,−2), (−1,−1), (−1,0), (−1,1), (−2,0), (−1,−2), (−1,2), (−2,−1),
// (−2,1) for k = 0 … 9; rows above are negative. The walk keeps the same ten cells in three shift
// registers instead (OccupancyWindow) and numbers the contexts by them: a different numbering of
// the same 1024 contexts, which codes every bit with the same probability.

// The window of columns a lowest height is predicted from: rows −3..0, columns −3..3, those
// coded before it.
constexpr int kWindowRows = 3;
constexpr int kWindowColumns = 3;
// Columns of padding on each side of a row's occupancy and lowest heights (at least the window's).
constexpr std::int64_t kPad = 4;

// floor(a / b) and the remainder a − b·floor(a / b) ∈ [0, b), for b > 0 and |a|, b < 2^56: the
// quotient of the doubles (each within a relative 2^−53 of its integer), truncated, is within
// |a / b|·2^−51 + 2 ≤ 34 of the true one (within two when |a| < 2^53), and the remainder corrects it (std::floor would be a call without SSE4.1). A prediction's 64-bit integer
// divisions were a third of its time (perf, decode_bench).
struct FloorDivision {
  std::int64_t quotient, remainder;
};
FloorDivision floor_divide(std::int64_t a, std::int64_t b) {
  auto q = static_cast<std::int64_t>(static_cast<double>(a) / static_cast<double>(b));
  std::int64_t r = a - q * b;
  while (r < 0) {
    --q;
    r += b;
  }
  while (r >= b) {
    ++q;
    r -= b;
  }
  return {q, r};
}

// Version 5 measures a window on cells of 2^t columns in units of 2^unit_shift(t) columns, so
// that an offset spans at most 32 units whatever t (docs/FORMAT.md, "The columns").
constexpr int unit_shift(int t) { return t > 3 ? t - 3 : 0; }

// The last four rows of the rectangle: occupancy, lowest height (0 where a column is empty), and
// whether a column holds more than one point; row r lives in slot r mod 4, padded by kPad
// columns on each side. When a row starts, each column's sums over the window's three rows above
// it (count, Σdy, Σdy², Σz, Σdy·z, least and greatest z) are taken once, branch-free over
// structure-of-arrays rows that the compiler vectorises, so that a prediction adds seven columns'
// sums instead of visiting up to 21 cells. Every sum fits 32 bits: z < 2^16 and 21 cells at most.
// On dragon_scans the old per-column structs with a branch per cell were a third of the walk.
class Rows {
 public:
  explicit Rows(std::uint32_t width)
      : padded_(static_cast<std::size_t>(width) + 2 * kPad), zero_occupied_(padded_, 0),
        zero_lowest_(padded_, 0), zero_least_(padded_, kNone) {
    for (auto& row : occupied_) row.assign(padded_, 0);
    for (auto& row : lowest_) row.assign(padded_, 0);
    for (auto& row : least_) row.assign(padded_, kNone);
    for (auto& row : fine_x_) row.assign(padded_, 0);
    for (auto& row : fine_y_) row.assign(padded_, 0);
    for (auto& row : stacked_) row.assign(width, 0);
    for (auto* sums : {&n_, &sy_, &syy_, &sz_, &syz_, &hi_}) sums->assign(padded_, 0);
    szz_.assign(padded_, 0);
    lo_.assign(padded_, kNone);
  }
  // `sums`: whether the window's column sums are needed (not for version 5's cells of several
  // columns, whose window point_window sums itself).
  void start(std::int64_t row, bool sums = true) {
    // Only the columns the slot's last row set are cleared: every other one is clean already.
    const std::size_t s = slot(row);
    Span& set = set_[s];
    if (set.first <= set.last) {
      const auto first = static_cast<std::ptrdiff_t>(set.first), end = static_cast<std::ptrdiff_t>(set.last) + 1;
      std::fill(occupied_[s].begin() + first + kPad, occupied_[s].begin() + end + kPad, 0);
      std::fill(lowest_[s].begin() + first + kPad, lowest_[s].begin() + end + kPad, 0);
      std::fill(least_[s].begin() + first + kPad, least_[s].begin() + end + kPad, kNone);
      std::fill(stacked_[s].begin() + first, stacked_[s].begin() + end, 0);
    }
    set = Span{};
    if (!sums) return;
    // The window's column sums are 0 (lo kNone) wherever the three rows above are empty, so they
    // are computed over the columns those rows set, and the rest of the last row's span cleared:
    // about 58% of the padded width on dragon_scans' and autzen's level 5 (a code word's region
    // is no rectangle), where the sums over every column were 10% of a decode.
    Span need;
    for (std::int64_t above = row - kWindowRows; above < row; ++above) {
      if (above < 0) continue;
      need.first = std::min(need.first, set_[slot(above)].first);
      need.last = std::max(need.last, set_[slot(above)].last);
    }
    const auto clear = [&](std::int64_t first, std::int64_t last) {
      for (std::int64_t c = first; c <= last; ++c) {
        const auto j = static_cast<std::size_t>(c + kPad);
        n_[j] = sy_[j] = syy_[j] = sz_[j] = syz_[j] = hi_[j] = 0;
        szz_[j] = 0;
        lo_[j] = kNone;
      }
    };
    if (need.first > need.last) {
      clear(summed_.first, summed_.last);
    } else {
      clear(summed_.first, std::min(summed_.last, need.first - 1));
      clear(std::max(summed_.first, need.last + 1), summed_.last);
      const auto offset = static_cast<std::size_t>(need.first + kPad);
      column_sums(offset, static_cast<std::size_t>(need.last - need.first + 1), occupied_row(row - 1) - kPad,
                  occupied_row(row - 2) - kPad, occupied_row(row - 3) - kPad, lowest_row(row - 1) - kPad,
                  lowest_row(row - 2) - kPad, lowest_row(row - 3) - kPad, least_row(row - 1), least_row(row - 2),
                  least_row(row - 3));
    }
    summed_ = need;
  }
  bool stacked(std::int64_t row, std::int64_t column) const {
    if (row < 0 || column < 0) return false;
    return stacked_[slot(row)][static_cast<std::size_t>(column)] != 0;
  }
  // (fine_x, fine_y): version 5's column of the cell's first point in units of 2^u columns from
  // the rectangle's corner (point_window).
  void set(std::int64_t row, std::int64_t column, std::uint32_t z, std::int32_t fine_x = 0, std::int32_t fine_y = 0) {
    fine_x_[slot(row)][static_cast<std::size_t>(column + kPad)] = fine_x;
    fine_y_[slot(row)][static_cast<std::size_t>(column + kPad)] = fine_y;
    occupied_[slot(row)][static_cast<std::size_t>(column + kPad)] = 1;
    lowest_[slot(row)][static_cast<std::size_t>(column + kPad)] = static_cast<std::int32_t>(z);
    least_[slot(row)][static_cast<std::size_t>(column + kPad)] = static_cast<std::int32_t>(z);
    Span& set = set_[slot(row)];
    set.first = std::min(set.first, column);
    set.last = std::max(set.last, column);
  }
  void set_stacked(std::int64_t row, std::int64_t column) { stacked_[slot(row)][static_cast<std::size_t>(column)] = 1; }
  // Row `row`'s occupancy and lowest heights from column 0, readable from −kPad to width + kPad
  // (all empty for a row before the first).
  const std::uint8_t* occupied_row(std::int64_t row) const {
    return (row < 0 ? zero_occupied_.data() : occupied_[slot(row)].data()) + kPad;
  }
  const std::int32_t* lowest_row(std::int64_t row) const {
    return (row < 0 ? zero_lowest_.data() : lowest_[slot(row)].data()) + kPad;
  }

  // The window's sums for column c: the rows above from the column sums, then the current row's
  // columns c − 3 … c − 1 (empty ones add nothing, their lowest height being 0).
  struct Window {
    std::int64_t n = 0, sx = 0, sy = 0, sz = 0, sxx = 0, sxy = 0, syy = 0, sxz = 0, syz = 0, szz = 0;
    std::uint32_t lo = 0, hi = 0;  // lo > hi when n = 0
  };
  Window window(std::int64_t row, std::int64_t c) const {
    std::int32_t n = 0, sx = 0, sy = 0, sz = 0, sxx = 0, sxy = 0, syy = 0, sxz = 0, syz = 0;
    std::int64_t szz = 0;
    std::int32_t lo = kNone, hi = 0;
    const auto base = static_cast<std::size_t>(c + kPad - kWindowColumns);
    for (std::int32_t i = 0; i <= 2 * kWindowColumns; ++i) {
      const std::int32_t k = i - kWindowColumns;
      const std::size_t j = base + static_cast<std::size_t>(i);
      n += n_[j];
      sx += k * n_[j];
      sxx += k * k * n_[j];
      sy += sy_[j];
      syy += syy_[j];
      sxy += k * sy_[j];
      sz += sz_[j];
      sxz += k * sz_[j];
      syz += syz_[j];
      szz += szz_[j];
      lo = std::min(lo, lo_[j]);
      hi = std::max(hi, hi_[j]);
    }
    const std::size_t here = static_cast<std::size_t>(c + kPad);
    const std::uint8_t* occupied = occupied_[slot(row)].data() + here;
    const std::int32_t* lowest = lowest_[slot(row)].data() + here;
    const std::int32_t* least = least_[slot(row)].data() + here;
    for (std::int32_t k = -kWindowColumns; k < 0; ++k) {
      const std::int32_t o = occupied[k];
      n += o;
      sx += k * o;
      sxx += k * k * o;
      sz += lowest[k];
      sxz += k * lowest[k];
      szz += std::int64_t{lowest[k]} * lowest[k];
      lo = std::min(lo, least[k]);
      hi = std::max(hi, lowest[k]);
    }
    return {n, sx, sy, sz, sxx, sxy, syy, sxz, syz, szz, static_cast<std::uint32_t>(lo), static_cast<std::uint32_t>(hi)};
  }

  // Version 5's window for cells of 2^t × 2^t columns, t > 0: the same cells, each at its first
  // point's column, in units of 2^u columns (u = max(0, t − 3)) relative to the column (px, py)
  // of the point being predicted (its place in the cell). |dx|, |dy| ≤ 32, so every sum and
  // determinant keeps the bounds of predict_lowest. Each row's seven cells are summed branch-free
  // (an empty cell's offsets multiplied by 0 and its height 0): with a branch per cell, level 1
  // of dragon_scans decoded 1.6 times slower than version 4, the same walk.
  Window point_window(std::int64_t row, std::int64_t c, int t, std::uint32_t px, std::uint32_t py) const {
    const int u = unit_shift(t);
    const std::int32_t x0 = static_cast<std::int32_t>((c << (t - u)) + (px >> u));
    const std::int32_t y0 = static_cast<std::int32_t>((row << (t - u)) + (py >> u));
    // 32 bits hold every sum but Σz² (|dx| ≤ 32, z < 2^16, 24 cells: |Σdx·z| < 2^26).
    std::int32_t n = 0, sx = 0, sy = 0, sxx = 0, sxy = 0, syy = 0, sz = 0, sxz = 0, syz = 0;
    std::uint64_t szz = 0;
    std::int32_t lo = kNone, hi = 0;
    const auto add_row = [&](std::int64_t r, std::int64_t first, std::int64_t last) {
      const std::size_t s = slot(r);
      const std::uint8_t* occupied = occupied_[s].data() + kPad;
      const std::int32_t* lowest = lowest_[s].data() + kPad;
      const std::int32_t* least = least_[s].data() + kPad;
      const std::int32_t* fx = fine_x_[s].data() + kPad;
      const std::int32_t* fy = fine_y_[s].data() + kPad;
      for (std::int64_t j = first; j < last; ++j) {
        const std::int32_t o = occupied[j], z = lowest[j];
        const std::int32_t dx = (fx[j] - x0) * o, dy = (fy[j] - y0) * o;
        n += o;
        sx += dx;
        sy += dy;
        sxx += dx * dx;
        sxy += dx * dy;
        syy += dy * dy;
        sz += z;
        sxz += dx * z;
        syz += dy * z;
        const auto uz = static_cast<std::uint32_t>(z);
        szz += uz * uz;  // < 2^32
        lo = std::min(lo, least[j]);
        hi = std::max(hi, z);
      }
    };
    for (std::int64_t dr = kWindowRows; dr > 0; --dr) {
      if (row - dr >= 0) add_row(row - dr, c - kWindowColumns, c + kWindowColumns + 1);
    }
    add_row(row, c - kWindowColumns, c);
    return {n, sx, sy, sz, sxx, sxy, syy, sxz, syz, static_cast<std::int64_t>(szz), static_cast<std::uint32_t>(lo),
            static_cast<std::uint32_t>(hi)};
  }

 private:
  static constexpr std::int32_t kNone = 0x7FFFFFFF;
  // The window's rows and the current one, in a ring of kWindowRows + 1 = 4 slots.
  static_assert(kWindowRows + 1 == 4, "slot() masks the row with 3");
  static std::size_t slot(std::int64_t row) { return static_cast<std::size_t>(row & 3); }
  // Row `row`'s lowest heights from column −kPad, kNone where a column is empty.
  const std::int32_t* least_row(std::int64_t row) const {
    return row < 0 ? zero_least_.data() : least_[slot(row)].data();
  }
  // Out of line: inlined into the walk, the loop lost its pointers' restrict and ran scalar.
  // Columns [offset, offset + size) of the padded rows.
  [[gnu::noinline]] void column_sums(std::size_t offset, std::size_t size, const std::uint8_t* __restrict o1,
                   const std::uint8_t* __restrict o2,
                   const std::uint8_t* __restrict o3, const std::int32_t* __restrict z1,
                   const std::int32_t* __restrict z2, const std::int32_t* __restrict z3,
                   const std::int32_t* __restrict l1, const std::int32_t* __restrict l2,
                   const std::int32_t* __restrict l3) {
    std::int32_t* __restrict n = n_.data();
    std::int32_t* __restrict sy = sy_.data();
    std::int32_t* __restrict syy = syy_.data();
    std::int32_t* __restrict sz = sz_.data();
    std::int32_t* __restrict syz = syz_.data();
    std::int32_t* __restrict lo = lo_.data();
    std::int32_t* __restrict hi = hi_.data();
    std::int64_t* __restrict szz = szz_.data();
    for (std::size_t c = offset; c < offset + size; ++c) {
      const std::int32_t a = o1[c], b = o2[c], d = o3[c];
      n[c] = a + b + d;
      sy[c] = -(a + 2 * b + 3 * d);
      syy[c] = a + 4 * b + 9 * d;
      sz[c] = z1[c] + z2[c] + z3[c];
      syz[c] = -(z1[c] + 2 * z2[c] + 3 * z3[c]);
      szz[c] = std::int64_t{z1[c]} * z1[c] + std::int64_t{z2[c]} * z2[c] + std::int64_t{z3[c]} * z3[c];
      // By value: std::min's references become loads through selected pointers, which stop
      // the loop vectorising.
      const std::int32_t l12 = l1[c] < l2[c] ? l1[c] : l2[c], z12 = z1[c] > z2[c] ? z1[c] : z2[c];
      lo[c] = l12 < l3[c] ? l12 : l3[c];
      hi[c] = z12 > z3[c] ? z12 : z3[c];
    }
  }
  std::size_t padded_;
  std::vector<std::uint8_t> zero_occupied_;
  std::vector<std::int32_t> zero_lowest_, zero_least_;
  std::array<std::vector<std::uint8_t>, 4> occupied_;
  std::array<std::vector<std::int32_t>, 4> lowest_, least_;
  std::array<std::vector<std::int32_t>, 4> fine_x_, fine_y_;
  std::array<std::vector<std::uint8_t>, 4> stacked_;
  std::vector<std::int32_t> n_, sy_, syy_, sz_, syz_, lo_, hi_;
  std::vector<std::int64_t> szz_;
  // Columns first..last (empty when first > last): those each slot's row set, and those whose
  // column sums hold the rows above's.
  struct Span {
    std::int64_t first = std::numeric_limits<std::int64_t>::max();
    std::int64_t last = std::numeric_limits<std::int64_t>::min();
  };
  std::array<Span, 4> set_;
  Span summed_;
};

// The ten template cells of the column being coded, and version 6's six farther ones, in four
// shift registers that move one column right per cell: the row's three cells before it (bit 0
// the nearer), the row above's seven from offset −3 to 3, the row above that's five from −2 to
// 2 (bit 0 the leftmost) and the cell three rows above. The ten cells' concatenation numbers the
// context (computing it from ten loads per cell was 9% of a decode).
class OccupancyWindow {
 public:
  OccupancyWindow(const std::uint8_t* above, const std::uint8_t* above2, const std::uint8_t* above3)
      : above_(above), above2_(above2), above3_(above3) {
    for (int k = 0; k < 7; ++k) up_ |= static_cast<std::uint32_t>(above_[k - 3]) << k;
    for (int k = 0; k < 5; ++k) up2_ |= static_cast<std::uint32_t>(above2_[k - 2]) << k;
    up3_ = above3_[0];
  }
  // The ten cells T[k] of docs/FORMAT.md as one number (another numbering of the same 1024
  // contexts, which codes every bit with the same probability).
  std::size_t context() const { return std::size_t{(row_ & 3u) | (up_ & 0x3Eu) << 1 | (up2_ & 0xEu) << 6}; }
  // Version 6's secondary context: bit j the cell at S[j] of docs/FORMAT.md.
  std::size_t farther() const {
    return std::size_t{(row_ >> 2 & 1u) | (up_ & 1u) << 1 | (up_ >> 6 & 1u) << 2 | (up2_ & 1u) << 3 |
                       (up2_ >> 4 & 1u) << 4 | up3_ << 5};
  }
  // Moves from column c to c + 1, column c's cell being `occupied`.
  void next(std::int64_t c, unsigned occupied) {
    row_ = ((row_ << 1) | occupied) & 7u;
    up_ = (up_ >> 1) | static_cast<std::uint32_t>(above_[c + 4]) << 6;
    up2_ = (up2_ >> 1) | static_cast<std::uint32_t>(above2_[c + 3]) << 4;
    up3_ = above3_[c + 1];
  }

 private:
  const std::uint8_t* above_;
  const std::uint8_t* above2_;
  const std::uint8_t* above3_;
  std::uint32_t row_ = 0, up_ = 0, up2_ = 0, up3_ = 0;
};

// Version 6's secondary estimate of an occupancy bit (docs/FORMAT.md, "The columns"): the primary
// probability's place among 33 nodes of its log-odds, K[i] being the logistic function at
// (i − 16) / 2, and the nodes of the farther cells' state interpolated there. Integers only, so
// that every platform codes the same bits. Priced on every code word of level 5 (models fresh per
// block, as the format has them), against the ten cells alone: occupancy bits −4.9% on
// dragon_scans, −5.1% on autzen, −1.8% on igea, −1.9% on bunny; linear buckets of the
// probability instead of its log-odds −3.4% and −4.2% on the first two; reading and moving only
// the nearer node −4.0% and −4.1%; leaving out the cells whose sixteen are all empty (30% of
// them) −4.3% and −4.4% (FORMAT_NOTES.md, "Cost of code-word positions"). It costs a whole
// decode 15-17% of its speed (two dependent loads and a product more on the chain from one
// decoded bit to the next).
constexpr std::array<std::int32_t, ColumnModels::kSecondaryNodes> kKnots = {
    1, 1, 2, 3, 5, 8, 14, 23, 37, 60, 97, 155, 244, 374, 551, 773, 1024,
    1275, 1497, 1674, 1804, 1893, 1951, 1988, 2011, 2025, 2034, 2040, 2043, 2045, 2046, 2047, 2047};

// π(p) for every probability p < 2048, in 64ths of a node.
constexpr std::array<std::uint16_t, 2048> make_places() {
  std::array<std::uint16_t, 2048> places{};
  for (std::int32_t p = 0; p < 2048; ++p) {
    std::int32_t i = 0;
    while (i < 31 && kKnots[static_cast<std::size_t>(i) + 1] <= p) ++i;
    const std::int32_t lo = kKnots[static_cast<std::size_t>(i)], hi = kKnots[static_cast<std::size_t>(i) + 1];
    const std::int32_t within = hi > lo ? std::min(63, 64 * (p - lo) / (hi - lo)) : 63;
    places[static_cast<std::size_t>(p)] = static_cast<std::uint16_t>(std::clamp(64 * i + within, 0, 2047));
  }
  return places;
}
constexpr std::array<std::uint16_t, 2048> kPlaces = make_places();

// Codes one occupancy bit: with the primary model alone (versions 3-5), or refined by the
// secondary estimate of the farther cells' state (version 6), after which the primary model
// and the two nodes adapt to the bit.
template <typename Io>
unsigned occupancy_bit(Io& io, ColumnModels& m, const OccupancyWindow& window, unsigned value) {
  const std::size_t context = window.context();
  std::uint16_t& primary = m.occupied[context];
  if (!m.secondary) return io.bit(primary, value);
  auto& row = m.apm[window.farther()];
  // kPlaces[primary], read beside it: looked up after it, the place was one more load on the
  // chain from each decoded bit to the next (dragon_scans level 5, one thread, best of 15 in
  // three interleaved runs: 64-71 -> 62-64 ms).
  const std::uint32_t place = m.occupied_place[context];
  const std::size_t j = place >> 6;
  const std::uint32_t w = place & 63u;
  const std::uint32_t refined = (std::uint32_t{row[j]} * (64 - w) + std::uint32_t{row[j + 1]} * w) >> 11;
  // At most (2047 + 3·2047 + 2) / 4 = 2047; 0 only where both are at their least.
  const std::uint32_t p = std::max<std::uint32_t>((primary + 3 * refined + 2) >> 2, 1);
  const unsigned bit = io.bit_with(p, value);
  adapt_probability(primary, bit);
  m.occupied_place[context] = kPlaces[primary];
  const std::int32_t target = bit == 0 ? 65535 : 0;
  const auto move = [target](std::uint16_t& node, std::uint32_t weight) {
    node = static_cast<std::uint16_t>(node + (((target - node) * static_cast<std::int32_t>(weight)) >> 10));
  };
  move(row[j], 64 - w);
  move(row[j + 1], w);
  return bit;
}

// 128-bit integers for version 5's residual class (GCC and Clang; the one product that needs
// them, D·Σz², reaches 2^74).
__extension__ using Int128 = __int128;

struct Prediction {
  std::uint32_t value = 0;
  std::size_t context = 0;   // kind × 5 + spread
  std::size_t fraction = 1;  // where the unrounded prediction fell in [value − ½, value + ½), in quarters
  std::size_t slope = 0;     // the plane's |gradient| in cells a cell: < ½, < 1, < 2, more
  // A plane's D > 0 (0 for the other kinds) and 2·Da + |De| + |Df|: the plane's top over the
  // column's cell, p + (|b| + |c|)/2, is (2·Da + |De| + |Df|) / (2·D).
  std::int64_t det = 0, top = 0;
};

// Where the predicted plane reaches above height z in the column (version 4's contexts of
// "another point"): 0 when its top over the column's cell lies below z, 1 within half a cell
// above it, 2 within a cell, 3 higher; 4 when the prediction is not a plane. On range scans at
// the coarse levels most further points in a column are the surface crossing a cell boundary,
// which the plane foretells: igea's "another" decisions cost 26-29% fewer bits at levels 7 and
// 9, bunny's 10-13%, dragon_scans' 8-11%, 3-5% at level 5 (docs/FORMAT_NOTES.md, "Where the
// plane reaches").
std::size_t plane_reach(const Prediction& pred, std::uint32_t z) {
  if (pred.det == 0) return 4;
  // Twice the top's height above z, in units of 1/D.
  const std::int64_t above = pred.top - 2 * pred.det * static_cast<std::int64_t>(z);
  return static_cast<std::size_t>(above >= 0) + static_cast<std::size_t>(above >= pred.det) +
         static_cast<std::size_t>(above >= 2 * pred.det);
}

// The quarter of [q − ½, q + ½) that the unrounded prediction num / den fell in, given the
// remainder t = (2·num + den) − 2·den·q ∈ [0, 2·den) of the rounding division: floor(2t / den),
// by comparisons.
std::size_t quarter(std::int64_t t, std::int64_t den) {
  return static_cast<std::size_t>(2 * t >= den) + static_cast<std::size_t>(t >= den) +
         static_cast<std::size_t>(2 * t >= 3 * den);
}

// The lowest height of column (r, c) predicted from the columns behind it in the window: none,
// the raster-previous column's; one to three, their mean; four or more, the least-squares plane
// z = a + b·dx + c·dy through them evaluated at (0, 0), in exact integer arithmetic (the mean
// when they are collinear). Versions 3 and 4 place each window cell at its offset in cells and
// the context is the kind (0, 1, 2) × min(bit width of the heights' spread, 4). Version 5 places
// each at its first point's column relative to the predicted point's (point_window; the same
// offsets when t = 0), and a plane's context is its residuals' class instead of the spread
// (docs/FORMAT.md, "The columns"). With |dx|, |dy| ≤ 32, n ≤ 24 and z < 2^16 the cofactors stay
// below 2^31, D below 2^37 and the numerators below 2^53; Q needs 128 bits.
Prediction predict_lowest(const Rows& rows, std::int64_t r, std::int64_t c, std::uint32_t previous, int bits,
                          bool point_plane, int t, std::uint32_t px, std::uint32_t py) {
  const bool at_point = point_plane && t > 0;
  const auto [n, sx, sy, sz, sxx, sxy, syy, sxz, syz, szz, lo, hi] =
      at_point ? rows.point_window(r, c, t, px, py) : rows.window(r, c);
  if (n == 0) return {previous, 0, 1, 0};
  const std::size_t spread = std::min<std::size_t>(static_cast<std::size_t>(std::bit_width(hi - lo)), 4);
  const auto by_mean = [&, n = n, sz = sz] {
    // 2·sz + n < 2^22: a 32-bit division.
    const auto num = static_cast<std::uint32_t>(2 * sz + n), den = static_cast<std::uint32_t>(2 * n);
    const std::uint32_t mean = num / den;
    return Prediction{mean, (n < 4 ? 5 : 10) + spread, quarter(num - den * mean, n), std::min<std::size_t>(spread, 3)};
  };
  if (n < 4) return by_mean();
  // Cramer's rule for the normal equations M·(a, b, c) = (Σz, Σxz, Σyz), M symmetric: the three
  // numerators share M's cofactors, six of them, which depend on where the columns are and not
  // on their heights (the same integers as expanding each 3 × 3 determinant, in 24 products
  // instead of 36).
  const std::int64_t c00 = sxx * syy - sxy * sxy, c01 = sy * sxy - sx * syy, c02 = sx * sxy - sxx * sy;
  const std::int64_t c11 = n * syy - sy * sy, c12 = sx * sy - n * sxy, c22 = n * sxx - sx * sx;
  std::int64_t det = n * c00 + sx * c01 + sy * c02;
  if (det == 0) return by_mean();
  std::int64_t det_a = sz * c00 + sxz * c01 + syz * c02;
  const std::int64_t det_e = sz * c01 + sxz * c11 + syz * c12;
  const std::int64_t det_f = sz * c02 + sxz * c12 + syz * c22;
  std::size_t context = 10 + spread;
  if (point_plane) {
    // Q = D·ZZ − (A·Z + E·XZ + F·YZ) = D·RSS, RSS the plane's residual sum of squares; the
    // class is min(bit width of ⌊2·rms⌋, 4) with rms² = RSS / (n − 3), by comparisons.
    // (4·|Q| against (n − 3)·|D|, in whichever integer width holds them.)
    const auto rms_class = [](auto rss4, auto unit) {
      return static_cast<std::size_t>(rss4 >= unit) + static_cast<std::size_t>(rss4 >= 4 * unit) +
             static_cast<std::size_t>(rss4 >= 16 * unit) + static_cast<std::size_t>(rss4 >= 64 * unit);
    };
    const auto abs_det = static_cast<std::uint64_t>(det < 0 ? -det : det);
    const auto zz = static_cast<std::uint64_t>(szz);
    if (std::bit_width(abs_det) <= 50 && std::bit_width(abs_det) + std::bit_width(zz) <= 60) {
      // In 64 bits (every cell of one grid step, t = 0, and most others): |Q| = |D|·RSS ≤
      // |D|·Σz² < 2^60, since no plane fits worse than z = 0, so Q computed modulo 2^64 is Q
      // itself, whatever its products wrap to; 4·|Q| and 64·(n − 3)·|D| fit too. Four 128-bit
      // products were a tenth of predict_lowest.
      const auto wrap = [](std::int64_t a, std::int64_t b) {
        return static_cast<std::uint64_t>(a) * static_cast<std::uint64_t>(b);
      };
      const auto q = static_cast<std::int64_t>(wrap(det, szz) -
                                               (wrap(det_a, sz) + wrap(det_e, sxz) + wrap(det_f, syz)));
      context = 10 + rms_class(4 * static_cast<std::uint64_t>(q < 0 ? -q : q),
                               static_cast<std::uint64_t>(n - 3) * abs_det);
    } else {
      const Int128 q = Int128{det} * szz - (Int128{det_a} * sz + Int128{det_e} * sxz + Int128{det_f} * syz);
      context = 10 + rms_class(4 * (q < 0 ? -q : q), Int128{n - 3} * (det < 0 ? -det : det));
    }
  }
  if (det < 0) {
    det = -det;
    det_a = -det_a;
  }
  const auto [plane, rest] = floor_divide(2 * det_a + det, 2 * det);
  const std::int64_t top = (std::int64_t{1} << bits) - 1;
  // The plane's rise across one cell (version 5 measures in units of 2^u columns, a cell being
  // 2^(t−u) of them).
  const int per_cell = at_point ? t - unit_shift(t) : 0;
  const std::int64_t gradient = ((det_e < 0 ? -det_e : det_e) + (det_f < 0 ? -det_f : det_f)) << per_cell;
  const std::size_t slope = 2 * gradient < det ? 0 : gradient < det ? 1 : gradient < 2 * det ? 2 : 3;
  return {static_cast<std::uint32_t>(std::clamp<std::int64_t>(plane, 0, top)), context, quarter(rest, det), slope,
          det, 2 * det_a + gradient};
}

struct ColumnEncoding {
  RangeEncoder& rc;
  unsigned bit(std::uint16_t& p, unsigned value) {
    rc.encode(p, value);
    return value;
  }
  unsigned bit_with(std::uint32_t p, unsigned value) {
    rc.encode_with(p, value);
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
  unsigned bit_with(std::uint32_t p, unsigned /*value*/) { return rc.decode_with(p); }
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

// What it costs now to code a lowest height's residual with one context's models, in bits.
double residual_cost(std::int64_t residual, std::uint16_t zero, std::uint16_t sign, const ValueModel& magnitude) {
  if (residual == 0) return bit_cost(zero, 1);
  const std::int64_t m = residual < 0 ? -residual : residual;
  return bit_cost(zero, 0) + bit_cost(sign, residual < 0 ? 1u : 0u) + magnitude.cost(static_cast<std::uint32_t>(m - 1));
}

// Whether the writer codes the first point of point `i`'s cell one grid step nearer the
// prediction than where it lies (HeightChoice): only where its true height lies between the two
// steps' centres, and when the squared error it adds, in steps², costs less than λ times the
// bits it saves.
bool one_step_nearer(const HeightChoice& choice, std::size_t i, std::int64_t residual, std::uint16_t zero,
                     std::uint16_t sign, const ValueModel& magnitude) {
  const double e = static_cast<double>(choice.fraction[i]);
  if (residual > 0 ? e >= 0 : e <= 0) return false;
  const double added = 1 - 2 * std::abs(e);  // (1 − |e|)² − e²
  const double saved = residual_cost(residual, zero, sign, magnitude) -
                       residual_cost(residual + (residual > 0 ? -1 : 1), zero, sign, magnitude);
  return added < choice.lambda * saved;
}

// Whether moving point `i` (the first of its cell) to height z keeps the cell's points distinct
// and in coded order: the cell's further points in its column lie above it (shift 0: one
// column, by gaps of at least 1 without the duplicates flag).
bool height_is_free(std::span<const Point> truth, std::size_t i, int shift, bool duplicates, std::uint32_t z) {
  const Point& p = truth[i];
  for (std::size_t j = i + 1; j < truth.size() && truth[j][1] >> shift == p[1] >> shift &&
                              truth[j][0] >> shift == p[0] >> shift;
       ++j) {
    if (truth[j][0] == p[0] && truth[j][1] == p[1] && (truth[j][2] < z || (truth[j][2] == z && !duplicates))) {
      return false;
    }
  }
  return true;
}

// The walk; `truth` is empty when decoding, and otherwise in cell order for `shift`. Returns false
// on a decoded value off the grid, more than max_points points, or an exhausted stream.
template <typename Io>
bool walk_columns(Io& io, ColumnModels& m, int bits, int shift, bool duplicates, std::size_t max_points,
                  std::span<const Point> truth, std::vector<Point>& out, const HeightChoice& choice = {}) {
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
    rows.start(r, !(m.point_plane && shift > 0));
    OccupancyWindow window(rows.occupied_row(r - 1), rows.occupied_row(r - 2), rows.occupied_row(r - 3));
    const std::uint32_t cy = y0 + static_cast<std::uint32_t>(r);
    for (std::int64_t c = 0; c < width; ++c) {
      const std::uint32_t cx = x0 + static_cast<std::uint32_t>(c);
      const bool here = in_cell(cursor, cx, cy);
      const unsigned occupied = occupancy_bit(io, m, window, here ? 1u : 0u);
      window.next(c, occupied);
      if (occupied == 0) continue;
      if (++produced > max_points) return false;
      // The first point: where in the cell (shift > 0), and its height against the prediction.
      std::uint32_t ox = 0, oy = 0;
      if (shift > 0) {
        ox = io.direct(here ? truth[cursor][0] & mask : 0, shift);
        oy = io.direct(here ? truth[cursor][1] & mask : 0, shift);
      }
      const Prediction pred = predict_lowest(rows, r, c, previous, bits, m.point_plane, shift, ox, oy);
      const std::size_t near = pred.context * 4 + pred.fraction;
      std::int64_t residual = 0;
      if (here) {
        residual = static_cast<std::int64_t>(truth[cursor][2]) - static_cast<std::int64_t>(pred.value);
        if (!choice.fraction.empty() && residual != 0 &&
            one_step_nearer(choice, cursor, residual, m.zero[near], m.sign[near], m.magnitude[pred.context]) &&
            height_is_free(truth, cursor, shift, duplicates, truth[cursor][2] - (residual > 0 ? 1u : 0u) +
                                                                   (residual < 0 ? 1u : 0u))) {
          residual += residual > 0 ? -1 : 1;
        }
      }
      const std::int64_t z = static_cast<std::int64_t>(pred.value) +
                             code_residual(io, m.zero[near], m.sign[near], m.magnitude[pred.context], residual);
      if (z < 0 || z >= static_cast<std::int64_t>(size)) return false;
      auto z_here = static_cast<std::uint32_t>(z);
      out.push_back({cx << shift | ox, cy << shift | oy, z_here});
      if (m.point_plane && shift > 0) {
        const int u = unit_shift(shift);
        rows.set(r, c, z_here, static_cast<std::int32_t>((c << (shift - u)) + (ox >> u)),
                 static_cast<std::int32_t>((r << (shift - u)) + (oy >> u)));
      } else {
        rows.set(r, c, z_here);
      }
      previous = z_here;
      // Further points of the cell: up the column (shift 0), or anywhere in it.
      const std::size_t stack_context = rows.stacked(r, c - 1) || rows.stacked(r - 1, c) ? 1 : 0;
      std::size_t k = 1;
      for (;; ++k) {
        const bool more = in_cell(cursor + k, cx, cy);
        const std::size_t ctx = (std::min<std::size_t>(k - 1, 2) * 2 + stack_context) * 4 + pred.slope;
        const std::size_t reach_ctx = m.plane_reach ? ctx * ColumnModels::kReaches + plane_reach(pred, z_here) : ctx;
        if (io.bit(m.another[reach_ctx], more ? 1u : 0u) == 0) break;
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

ColumnModels::ColumnModels(int format_version)
    : plane_reach(format_version >= 4),
      point_plane(format_version >= 5),
      secondary(format_version >= 6),
      empty(kProbabilityHalf),
      other_zero(kProbabilityHalf),
      other_sign(kProbabilityHalf) {
  if (format_version >= 7) {
    for (auto* values : {&rectangle[0], &rectangle[1], &rectangle[2], &rectangle[3], &shift, &other_magnitude, &gap[0],
                         &gap[1]}) {
      values->use_unary_lengths();
    }
    for (auto& values : magnitude) values.use_unary_lengths();
  }
  occupied.fill(kProbabilityHalf);
  for (auto& row : apm) {
    for (std::size_t i = 0; i < kSecondaryNodes; ++i) row[i] = static_cast<std::uint16_t>(32 * kKnots[i]);
  }
  occupied_place.fill(kPlaces[kProbabilityHalf]);
  zero.fill(kProbabilityHalf);
  sign.fill(kProbabilityHalf);
  another.fill(kProbabilityHalf);
}

namespace {

// Grid columns of a code word's bounding rectangle per point (`points` not empty).
double columns_per_point(std::span<const Point> points) {
  std::uint32_t x_min = points.front()[0], x_max = x_min, y_min = points.front()[1], y_max = y_min;
  for (const Point& p : points) {
    x_min = std::min(x_min, p[0]);
    x_max = std::max(x_max, p[0]);
    y_min = std::min(y_min, p[1]);
    y_max = std::max(y_max, p[1]);
  }
  return static_cast<double>(x_max - x_min + 1) * static_cast<double>(y_max - y_min + 1) /
         static_cast<double>(points.size());
}

}  // namespace

int column_shift(std::span<const Point> points, int bits) {
  if (points.empty()) return 0;
  const double per_point = columns_per_point(points);
  int shift = 0;
  while (shift + 1 < bits && shift < kMaxColumnShift && 2 * std::ldexp(1.0, 2 * (shift + 1)) <= per_point) ++shift;
  return shift;
}

// column_shift's rule picks the cells' size from the points' density alone; a code word's
// points may code cheaper one size up or down, by how they sit in the cells. Where that can
// happen, the two sizes are priced by coding the code word with a copy of the block's models so
// far (the stream's length in bytes: such code words take hundreds to thousands of bytes) and
// the cheaper is written; the reader takes whatever shift a code word states. With x the area
// per point over the rule's least (2·4^t cells), priced over 1,766 code words of bunny levels
// 0-4, igea levels 1 and 3 and dragon_scans levels 0, 2 and 4: one size up won 14% of the time
// at x in [2, 2.25), half of the time from 2.5 on and 90% at 3.25 and more (rule 0 included),
// almost never below 2; one size down won 13-16% below x = 1.5 and almost never from 1.75 on.
// Pricing both neighbours everywhere gained no more (and two sizes away nothing at all) and
// slowed level 0's encode by a quarter; priced only where x says so, dragon_scans' level 0 takes
// 12% more CPU (1.44 -> 1.62 s). The writer prices on grids finer than 0.75 spacings only
// (levels 0-4; block_codec.cpp says why). bunny 2.1% smaller at level 2 and 4.1% at level 3, dragon_scans 1.3% at
// level 0 and 2.3% at level 4, the same points.
int cheapest_shift(const ColumnModels& models, std::span<const Point> sorted, int bits, bool duplicates) {
  const int rule = column_shift(sorted, bits);
  if (sorted.empty()) return rule;
  const double x = columns_per_point(sorted) / (2 * std::ldexp(1.0, 2 * rule));
  int other = rule;
  if (x >= 2 && rule < std::min(kMaxColumnShift, bits - 1)) other = rule + 1;
  if (x < 1.75 && rule > 0) other = rule - 1;
  if (other == rule) return rule;
  std::size_t cost[2] = {0, 0};
  std::vector<Point> trial;
  std::string bytes;
  for (int c = 0; c < 2; ++c) {
    const int shift = c == 0 ? rule : other;
    trial.clear();
    for (const std::uint32_t k : column_order(sorted, shift)) trial.push_back(sorted[k]);
    ColumnModels scratch = models;
    bytes.clear();
    RangeEncoder rc(bytes);
    encode_columns(rc, scratch, trial, bits, shift, duplicates);
    rc.finish();
    cost[c] = bytes.size();
  }
  return cost[1] < cost[0] ? other : rule;
}

std::vector<std::uint32_t> column_order(std::span<const Point> points, int shift) {
  std::vector<std::uint32_t> order(points.size());
  for (std::uint32_t k = 0; k < order.size(); ++k) order[k] = k;
  // Points already in the columns' order (the writer's raster order at shift 0, most levels'):
  // the identity, without a sort.
  const auto cell = [shift](const Point& p) { return std::pair(p[1] >> shift, p[0] >> shift); };
  bool ordered = true;
  for (std::size_t k = 1; k < points.size() && ordered; ++k) ordered = !(cell(points[k]) < cell(points[k - 1]));
  if (ordered) return order;
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
                    bool duplicates, const HeightChoice& choice, std::vector<Point>* coded) {
  SSPC_DCHECK(bits >= 1 && bits <= 16 && shift >= 0 && shift < bits && shift <= kMaxColumnShift);
  ColumnEncoding io{rc};
  if (io.bit(m.empty, points.empty() ? 1u : 0u) != 0) return;
  io.value(m.shift, static_cast<std::uint32_t>(shift));
  std::vector<Point> out;
  out.reserve(points.size());
  SSPC_DCHECK(choice.fraction.empty() || choice.fraction.size() == points.size());
  const bool walked = walk_columns(io, m, bits, shift, duplicates, points.size(), points, out, choice);
  SSPC_DCHECK(walked && out.size() == points.size());
  if (coded != nullptr) *coded = std::move(out);
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
