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

#include "format/container_format.hpp"
#include "format/encoded_model.hpp"

namespace sspc::codec {

struct TrimStats {
  std::uint64_t points_before = 0;
  std::uint64_t points_after = 0;
};

// `header` must carry the quantisation fields the writer will use (position_bits,
// rotation_bits, translation_step, bounds_min). Every translation must fit the grid.
EncodedModel trim_unclaimed_points(const EncodedModel& model, const ContainerHeader& header,
                                   TrimStats* stats = nullptr);

}  // namespace sspc::codec
