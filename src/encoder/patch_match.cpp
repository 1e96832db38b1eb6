// The code book's acceptance test (Hubo et al. 2007, §4.3), measured by nearest-point
// distances rather than the paper's MLS residual: see patch_match.hpp.
#include "encoder/patch_match.hpp"

#include <algorithm>
#include <vector>

#include "encoder/icp.hpp"

namespace sspc::codec {

Match try_match(const PointCloud& cloud, const KdTree3& points_tree, std::span<const std::uint32_t> idx,
                const Vec3f& centre,
                const RigidTransform& world_from_canonical, const RigidTransform& codeword_from_rep_canonical,
                const CodewordSurface& surface, const CodebookOptions& o) {
  // Start: k's canonical frame laid onto the representative's canonical frame.
  const RigidTransform canonical_from_world = world_from_canonical.inverse();
  std::vector<Vec3f> source;
  source.reserve(idx.size());
  // Start: the canonical rotations, with k's centre on the code word's origin.
  RigidTransform start = codeword_from_rep_canonical * canonical_from_world;
  start.translation -= start.apply(centre);
  // ICP aligns a deterministic subset of at most kIcpPoints points (a stride through the
  // patch): the 6 parameters are fixed long before 64 points, and the alignment was 70% of the
  // encoder's time on dragon_scans with whole 400-point patches. The test below uses them all.
  constexpr std::size_t kIcpPoints = 96;
  const std::size_t stride = (idx.size() + kIcpPoints - 1) / kIcpPoints;
  for (std::size_t j = 0; j < idx.size(); j += std::max<std::size_t>(stride, 1)) {
    source.push_back(start.apply(cloud.positions[idx[j]]));
  }
  IcpOptions icp;
  icp.max_pair_distance = std::max(3.0f * o.spacing, 0.3f * o.coverage_radius);
  icp.converged_step = 0.01f * o.spacing;
  icp.max_iterations = 20;
  icp.abandon_rms = 3.0f * o.tau * o.spacing;  // hopeless: the test below needs RMS ≤ τ
  icp.point_to_point_weight = 1.0f;
  icp.lever_arm = o.patch_radius;
  const IcpResult aligned = align_point_to_plane(source, surface, icp);

  const RigidTransform codeword_from_world =
      aligned.target_from_source * start;
  const RigidTransform world_from_codeword = codeword_from_world.inverse();
  Match m;
  // The instance's region is the cell of where the code word's origin lands. ICP may slide a
  // patch onto its copy (on exactly self-similar surfaces the copy is rarely centred where the
  // patch is); build_codebook restores coverage afterwards. Beyond half the coverage radius the
  // patch's points no longer surround the new region.
  const Vec3f landed = world_from_codeword.translation;
  if ((landed - centre).norm() > kMaxDrift * o.coverage_radius) return m;

  // The test measures what the codec is judged by (docs/METRICS.md): within the region the
  // instance will decode (the points within the coverage radius of its centre), the RMS
  // distance from each source point to the nearest code-word point, and from each code-word
  // point to the nearest source point. The paper's MLS residual sees only the distance to the
  // surface: a code word sampled more sparsely than the patch, or offset along it, passed that
  // test and cost dragon_scans 6 dB for a code-book ratio of 1.6. Besides the RMS, no more than
  // 1% of either side may be farther than a hole (2.5 spacings): a code word must neither leave
  // a hole in the patch nor put points where the surface has none (past a scan's edge).
  const float core2 = o.coverage_radius * o.coverage_radius;
  const float hole2 = (2.5f * o.spacing) * (2.5f * o.spacing);
  const double tau2 = static_cast<double>(o.tau * o.spacing) * static_cast<double>(o.tau * o.spacing);
  // Each side's sum and hole count only grow, and how many points it sums is known before its
  // nearest-point queries: a side stops at the first point past either bound, with the answer
  // the whole sum would give. Most candidates fail (the code-book ratio is 1.0-1.1 on scans),
  // most of them within a few percent of their points.
  const auto rejected = [tau2](double sse, std::size_t holes, std::size_t n) {
    return sse > tau2 * static_cast<double>(n) || holes * 100 > n;
  };
  std::size_t source_core = 0;
  for (const std::uint32_t i : idx) source_core += (cloud.positions[i] - landed).squaredNorm() <= core2 ? 1u : 0u;
  std::size_t n = 0;
  for (const Vec3f& p : surface.points()) n += p.squaredNorm() <= core2 ? 1u : 0u;
  if (source_core == 0 || n == 0) return m;
  // The instance decodes about as many points as the code word has in its region: a code word
  // from a sparser or denser part of the scan (single against overlapping range scans) would
  // change the density, which the nearest-point RMS tolerates up to τ. Within 10% either way.
  if (n * 10 < source_core * 9 || n * 10 > source_core * 11) return m;
  double sse = 0;
  std::size_t holes = 0;
  for (std::size_t j = 0; j < idx.size(); ++j) {
    if ((cloud.positions[idx[j]] - landed).squaredNorm() > core2) continue;
    float d2 = 0;
    surface.tree().nearest(codeword_from_world.apply(cloud.positions[idx[j]]), &d2);
    sse += static_cast<double>(d2);
    holes += d2 > hole2 ? 1 : 0;
    if (rejected(sse, holes, source_core)) return m;
  }
  sse = 0;
  holes = 0;
  for (const Vec3f& p : surface.points()) {
    if (p.squaredNorm() > core2) continue;
    float d2 = 0;
    points_tree.nearest(world_from_codeword.apply(p), &d2);
    sse += static_cast<double>(d2);
    holes += d2 > hole2 ? 1 : 0;
    if (rejected(sse, holes, n)) return m;
  }
  m.accepted = true;
  m.world_from_codeword = world_from_codeword;
  return m;
}

}  // namespace sspc::codec
