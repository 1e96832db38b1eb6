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
  Progress* progress = nullptr;
};

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
