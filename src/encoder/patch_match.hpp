// Whether a patch may be replaced by an instance of a code word (Hubo et al. 2007, §4.3): the
// patch is aligned to the code word's surface by ICP (paper §4.2.2) and accepted only when the
// instance would decode close to the patch. The rules, each tested directly in
// tests/encoder/patch_match_test.cpp:
// - drift: the code word's origin lands within kMaxDrift coverage radii of the patch's centre
//   (the instance's region is the cell of that origin, and the patch's points must surround it);
// - error: within the coverage radius of the landed origin, the RMS distance from each patch
//   point to its nearest code-word point, and from each code-word point to its nearest cloud
//   point, is at most τ spacings (what the codec is judged by, docs/METRICS.md; the paper's MLS
//   residual passed code words sampled more sparsely than the patch or offset along it, and cost
//   dragon_scans 6 dB for a code-book ratio of 1.6);
// - holes: at most 1% of either side is farther than 2.5 spacings from the other (a code word
//   must neither leave a hole in the patch nor put points past a scan's edge);
// - density: the code word has within 10% of the patch's point count in that region (a code
//   word from a sparser or denser part of the scan changes the density, which the RMS tolerates).
#pragma once

#include <cstdint>
#include <span>

#include "encoder/codebook_builder.hpp"
#include "encoder/codeword_surface.hpp"
#include "geometry/rigid_transform.hpp"
#include "sspc/neighbours.hpp"
#include "sspc/point_cloud.hpp"

namespace sspc::codec {

inline constexpr float kMaxDrift = 0.5f;  // in coverage radii

struct Match {
  bool accepted = false;
  RigidTransform world_from_codeword;  // the instance's transform when accepted
};

// Tests the patch of `cloud` with point indices `idx` and centre `centre` against the code word
// `surface`. The alignment starts from the canonical frames: `world_from_canonical` is the
// patch's, `codeword_from_rep_canonical` takes the representative's canonical frame to the code
// word's. `points_tree` indexes cloud.positions. Uses o.tau, o.spacing, o.coverage_radius and
// o.patch_radius.
Match try_match(const PointCloud& cloud, const KdTree3& points_tree, std::span<const std::uint32_t> idx,
                const Vec3f& centre, const RigidTransform& world_from_canonical,
                const RigidTransform& codeword_from_rep_canonical, const CodewordSurface& surface,
                const CodebookOptions& o);

}  // namespace sspc::codec
