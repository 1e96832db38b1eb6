// The position coder of versions 3 to 7's code words (docs/FORMAT.md, "The columns"): a code word's
// grid points as columns along its frame's z axis, which is the patch's mean normal. The
// occupied columns are a binary image over the code word's bounding rectangle, coded cell by
// cell under a context of ten cells already coded (as JBIG codes bilevel images); each column's
// lowest height is predicted by the least-squares plane through the lowest heights of the
// occupied columns behind it, and further points in a column (overlapping scans) follow as gaps.
//
// Why columns and not an octree: both were measured on the same code words (level 5 with 1024-
// point patches and no instancing, FORMAT_NOTES.md "Cost of code-word positions"): an octree
// with neighbour contexts took 6.1, 5.6 and 6.9 bits a point on bunny, igea and dragon_scans;
// the columns 4.5, 3.6 and 6.5. In the code word's frame the surface is a height field almost
// everywhere, and an octree spends bits finding the height that a plane predicts.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "format/range_coder.hpp"

namespace sspc::codec {

// 8 / 0.0106 ≈ 755 points a byte at most: every point costs at least one decision of an
// adaptive probability (a cell's first point its height's zero flag, a further point "another
// point"), whose most probable bit costs −log2(2033/2048). (Version 6's refined occupancy
// probabilities reach 2047/2048, so the occupancy bit alone would not bound it.)
inline constexpr std::size_t kMaxColumnPointsPerByte = 1024;

// The adaptive models of one code-book block's code words (reset per block, so that blocks
// decode independently), for the format version the block belongs to (version 5 changes only how
// heights are predicted and their contexts chosen, not the models): version 4 splits each of
// version 3's contexts of "another point" five ways by where the predicted plane reaches, and
// version 6 refines each occupancy bit's probability by six farther cells, and version 7's value
// models code their lengths in unary (docs/FORMAT.md, "The columns" and "Range coding").
struct ColumnModels {
  static constexpr std::size_t kOccupancyContexts = 1024;
  static constexpr std::size_t kHeightContexts = 15;  // 3 predictor kinds × 5 spreads
  static constexpr std::size_t kAnotherContexts = 24;  // version 3's; version 4 has 5 × as many
  static constexpr std::size_t kReaches = 5;
  static constexpr std::size_t kSecondaryContexts = 64;  // six farther cells
  static constexpr std::size_t kSecondaryNodes = 33;
  explicit ColumnModels(int format_version = 7);
  bool plane_reach;  // version 4's contexts
  bool point_plane;  // version 5's plane at each point's own column, its context by the residuals
  bool secondary;    // version 6's secondary estimates of the occupancy bits
  std::uint16_t empty;
  std::array<ValueModel, 4> rectangle;  // x0, y0, width − 1, height − 1
  std::array<std::uint16_t, kOccupancyContexts> occupied;
  // Version 6: per state of the six farther cells, the occupancy bit's probability of a 0 (in
  // 1/65536) at 33 nodes of the primary probability's log-odds (docs/FORMAT.md, "The columns").
  std::array<std::array<std::uint16_t, kSecondaryNodes>, kSecondaryContexts> apm;
  // Where each occupancy probability lies among the nodes (a function of it, kept beside it so
  // that a decode reads both at once instead of one after the other).
  std::array<std::uint16_t, kOccupancyContexts> occupied_place;
  std::array<std::uint16_t, 4 * kHeightContexts> zero;  // the lowest height's residual is 0
  std::array<std::uint16_t, 4 * kHeightContexts> sign;  // ... and is negative
  std::array<ValueModel, kHeightContexts> magnitude;     // |residual| − 1
  std::array<std::uint16_t, kAnotherContexts * kReaches> another;  // one more point in the cell
  ValueModel shift;                                      // the code word's cell shift
  std::uint16_t other_zero, other_sign;                  // a further point's height in a cell
  ValueModel other_magnitude;                            // of shift > 0, against the previous
  std::array<ValueModel, 2> gap;         // to the next point up the column
};

// The writer's choice of lowest heights (version 5 writes; block_codec.cpp): `fraction[i]` is
// where point i's true height lies in its grid step, in steps from the step's centre ([−½, ½]).
// A first point of a cell whose true height lies between its step's centre and the prediction's
// may be coded one step nearer the prediction: that adds 1 − 2|e| steps² of squared error and
// saves the bits a likelier residual saves, and the writer takes it when the error added is
// below λ times the bits saved. Empty: every height as it lies.
struct HeightChoice {
  std::span<const float> fraction;
  double lambda = 0;
};

// Sparse code words are coded on cells of 2^shift × 2^shift grid columns, each point's place in
// its cell as 2·shift direct bits: a raster over every grid column would spend a decision on
// each of the many empty ones (at level 0 on bunny, under 1% of them are occupied). The writer
// takes the largest shift (up to kMaxColumnShift) whose cells cover at most half the rectangle's
// area per point (measured on bunny levels 0 and 2 and igea level 1: cells of up to the whole
// area per point cost 2–7% more, an eighth of it 5–25% more).
inline constexpr int kMaxColumnShift = 6;
int column_shift(std::span<const std::array<std::uint32_t, 3>> points, int bits);

// The shift the writer codes a code word with: column_shift's, or one size up or down where
// that codes cheaper with `models` as they stand (priced by coding it both ways, where one size
// up or down has been seen to win; column_coder.cpp). `points` as for column_shift; the models
// are not changed.
int cheapest_shift(const ColumnModels& models, std::span<const std::array<std::uint32_t, 3>> points, int bits,
                   bool duplicates);

// The order the columns code and decode a code word's points in, as indices into `points`, which
// must be sorted by (y, x, z): by cell (y >> shift, then x >> shift), then as they come.
std::vector<std::uint32_t> column_order(std::span<const std::array<std::uint32_t, 3>> points, int shift);

// Codes one code word's grid points (each coordinate below 2^bits, 1 ≤ bits ≤ 16), which must
// be in column_order for `shift` (0 ≤ shift < bits, shift ≤ kMaxColumnShift) and,
// unless `duplicates`, distinct.
void encode_columns(RangeEncoder& rc, ColumnModels& m, std::span<const std::array<std::uint32_t, 3>> points,
                    int bits, int shift, bool duplicates, const HeightChoice& choice = {},
                    std::vector<std::array<std::uint32_t, 3>>* coded = nullptr);

// Decodes one code word's points, in column_order, appending them to `out`. Fails
// (false) on a value off the grid, on more than `max_points` points, or when the stream runs out.
bool decode_columns(RangeDecoder& rc, ColumnModels& m, int bits, std::size_t max_points, bool duplicates,
                    std::vector<std::array<std::uint32_t, 3>>& out);

}  // namespace sspc::codec
