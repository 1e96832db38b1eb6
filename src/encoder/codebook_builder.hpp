// The greedy code book (Hubo et al. 2007, §4.2–4.3): patches, their canonical
// frames and descriptors, then, repeatedly, the remaining patch of smallest curvature becomes a
// code word and every remaining patch whose descriptor lies within L1 radius ε of its own is
// aligned to it by ICP and replaced by a reference to it when the MLS error is under τ.
// Rejected candidates go back to the pool.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "encoder/descriptor.hpp"
#include "format/encoded_model.hpp"
#include "sspc/neighbours.hpp"
#include "sspc/point_cloud.hpp"
#include "sspc/progress.hpp"

namespace sspc::codec {

struct CodebookOptions {
  float patch_radius = 0;     // points within this of a centre form its patch
  float coverage_radius = 0;  // every point is within this of a centre
  float spacing = 0;          // nominal point spacing
  float epsilon = 0.5f;       // L1 radius in descriptor space
  float tau = 0.25f;          // MLS RMS error threshold, in units of `spacing`
  DescriptorParams descriptor;
  // Coverage is restored for the first `covered_points` points only (0: all). A tile of a tiled
  // encode lists its own points first and its margin after; the margin is its neighbours' to
  // cover (encoder/tiling.hpp).
  std::size_t covered_points = 0;
  // The code words keep their points' normals once matched. They serve the matching (ICP is
  // point-to-plane); a file that stores no normals needs none after it, and at level 5 they
  // cost 12 bytes a code-word point, some 40 bytes a source point (code words overlap 3.5×).
  bool keep_normals = true;
  // Each code word's frame turned about its normal to follow the sampling lattice of the
  // patch's scan, where it has one (codebook_builder.cpp, lattice_aligned). Worth it where the
  // grid is finer than about a spacing and a cell holds at most one lattice point: the writer
  // asks for it at grid steps up to kLatticeAlignedStep spacings.
  bool align_to_lattice = false;
  Progress* progress = nullptr;
};

// The coarsest grid step, in point spacings, at which code words follow the scan's lattice
// (levels 0-6): measured on bunny and igea at every level, aligned frames took 1.3-8% fewer
// bits at levels 0-6 (but bunny's level 3, 1% more) and moved levels 7-9 by -2.4% to +0.7%
// and -0.1 to +0.05 dB, where a cell holds several lattice points.
inline constexpr float kLatticeAlignedStep = 1.25f;

struct CodebookStats {
  std::size_t patches = 0;
  std::size_t codewords = 0;
  std::size_t candidates_tested = 0;  // ICP alignments run
  std::size_t accepted = 0;           // patches replaced by a reference
  std::size_t repaired = 0;           // patches added to restore coverage after matching
  double mean_patch_points = 0;
  std::size_t codeword_points = 0;    // Σ code-word sizes
  double seconds_descriptors = 0;     // gathering patches, their frames and descriptors
};

// `centres` in file order; `points_tree` indexes cloud.positions; cloud has unit normals.
EncodedModel build_codebook(const PointCloud& cloud, const KdTree3& points_tree,
                            std::span<const Vec3f> centres, const CodebookOptions& options,
                            CodebookStats* stats);

}  // namespace sspc::codec
