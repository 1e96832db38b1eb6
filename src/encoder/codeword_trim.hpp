// Trimming code words to the points their instances claim (docs/FORMAT.md, "Decoding: regions"; beyond the paper).
//
// The paper stores each representative's whole sphere of radius R. The decoder keeps, of each
// instance, only the code-word points in the instance's own region (the Voronoi cell of its
// centre; docs/FORMAT.md, "Decoding: regions"), and a cell is much smaller than the sphere
// around it: on dragon_scans a sphere held 3.2 times the points of its cell. A point that no
// instance of its code word claims is never decoded, so the writer drops it. The decision is
// made on the values a reader decodes (quantised transforms and positions) with the reader's own
// region test, so a trimmed file decodes to exactly the points of the untrimmed one; only the
// overlap mode, which emits every stored point, sees the difference.
#pragma once

#include <cstdint>
#include <span>

#include "format/container_format.hpp"
#include "format/encoded_model.hpp"

namespace sspc::codec {

struct TrimStats {
  std::uint64_t points_before = 0;
  std::uint64_t points_after = 0;
};

// Each code word in the frame a reader decodes for its representative patch (the patch it was
// built from, PatchInstance::representative): the points move by the transform's quantisation
// error, so the representative decodes exactly its own points, up to the code words' grid,
// whatever the transform's bits; the other instances' transforms absorb the same move, so they
// decode what they did before. Without it, a half-step translation grid added 0.25 steps RMS
// to every point, about 1 dB (docs/FORMAT_NOTES.md, "Cost of patches").
void express_in_decoded_frames(EncodedModel& model, const ContainerHeader& header);

// One point per occupied cell of the code words' grid (docs/FORMAT.md, "Code-book blocks"): a
// cell's points decode to the same position, so only the first is kept, with the mean of the
// cell's normals (normalised) and colours. On a grid coarser than the spacing this drops
// 20–30% of the points for ≤ 0.06 dB of the paper's PSNR (docs/FORMAT_NOTES.md). `header` must
// carry position_bits and patch_radius.
void merge_duplicate_cells(EncodedModel& model, const ContainerHeader& header);

// `header` must carry the quantisation fields the writer will use (position_bits,
// rotation_bits, translation_step, bounds_min). Every translation must fit the grid.
//
// A tile of a larger model (ContainerStreamWriter): `model` holds the tile's code words and the
// patches that use them, numbered from `first_index` in the whole model, and `others` the
// whole model's other patches that may neighbour them (their index in the whole model and the
// patch). The claims are then those the whole model's decode makes; leaving a neighbour out
// only keeps more points (a point claimed against fewer centres is claimed against more).
struct IndexedPatch {
  std::uint32_t index = 0;
  PatchInstance patch;
};
EncodedModel trim_unclaimed_points(const EncodedModel& model, const ContainerHeader& header,
                                   TrimStats* stats = nullptr, std::span<const IndexedPatch> others = {},
                                   std::uint32_t first_index = 0);

}  // namespace sspc::codec
