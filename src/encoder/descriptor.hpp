// The patch descriptor (Hubo et al. 2007, §4.2.2).
//
// Two 1-D histograms, of the canonical normals' x and of their y, each coordinate first
// stretched by s(v) = tanh(a·v) / tanh(a), which widens the bins near 0 where most normals of a
// near-flat patch fall. Each histogram is normalised and made cumulative; the L1 distance
// between cumulative histograms is the match distance (a 1-D earth mover's distance), so the
// concatenation is compared with plain L1 and indexed by an L1 k-d tree.
//
// The last bin of a normalised cumulative histogram is always 1, so it is not stored: a
// descriptor has 2·(bins − 1) entries and loses nothing.
#pragma once

#include <span>

#include "sspc/point_cloud.hpp"

namespace sspc {

struct DescriptorParams {
  int bins = 16;        // per coordinate, 2..256
  float stretch = 2.5f; // a in tanh(a·v)/tanh(a); larger widens the centre more
  int dimension() const { return 2 * (bins - 1); }
};

// Writes `params.dimension()` floats to `out` for normals already in the canonical frame.
// An empty normal list gives the descriptor of a flat patch (all mass in the centre bin).
void compute_descriptor(std::span<const Vec3f> canonical_normals, const DescriptorParams& params,
                        std::span<float> out);

// The match distance: L1 between two descriptors of equal dimension.
float match_distance(std::span<const float> a, std::span<const float> b);

}  // namespace sspc
