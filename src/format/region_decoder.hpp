// Region decoding (docs/FORMAT.md, "Decoding: regions"): patch k emits the code
// word's points whose nearest region centre is k's own, ties to the lower patch index.
//
// The test runs in the code word's frame: with e_j = R_kᵀ (c_j − c_k) the neighbour's centre
// seen from the code word, point q is nearer to c_k than to c_j iff |e_j|² − 2 q·e_j > 0. That
// needs one dot product per neighbour and no transform of rejected points; and since every
// quantity is computed by the one function below from the decoded block data, a whole-model,
// one-patch and box decode produce bit-identical points.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "format/resample.hpp"
#include "sspc/point_cloud.hpp"

namespace sspc::codec {

struct NeighbourInstance {
  std::uint32_t index = 0;
  Vec3f centre;
};

// The neighbourhood N_k of FORMAT.md: j belongs to it iff centre_distance2(c_j, c_k) ≤
// neighbour_threshold2(ρ), ρ the radius of k's code word.
inline float centre_distance2(const Vec3f& a, const Vec3f& b) {
  const float dx = a.x() - b.x(), dy = a.y() - b.y(), dz = a.z() - b.z();
  return dx * dx + dy * dy + dz * dz;
}
inline float neighbour_threshold2(float radius) {
  return 4.0f * radius * radius * 1.0001f;
}

// A decoded code word's arrays (normals and colours may be null).
struct CodewordView {
  const Vec3f* points = nullptr;
  const float* norm2 = nullptr;
  const Vec3f* normals = nullptr;
  const Rgb8* colours = nullptr;
  std::size_t size = 0;
};

// Patch k's region in its code word's frame: which code-word points k keeps. Reusable: reset()
// keeps the storage.
class RegionTest {
 public:
  // `neighbours` must be exactly N_k (any order).
  void reset(std::uint32_t k, const Eigen::Matrix3f& world_from_codeword_rotation, const Vec3f& centre,
             std::span<const NeighbourInstance> neighbours);
  // Whether k keeps code-word point q (with norm2 = |q|² as the decoder computes it).
  bool claims(const Vec3f& q, float norm2) const;
  // claims() for each of the n points of a code word at once: keep[i] is all ones where k keeps
  // point i, 0 where it does not. The same arithmetic as claims(), so the same answers, but a
  // neighbour at a time over all points, without branches: a trimmed code word's points are
  // almost all kept, so claims() ran through every neighbour within reach of almost every
  // point, a mispredicted branch at each.
  void claims_all(const Vec3f* points, const float* norm2, std::size_t n, std::vector<std::uint32_t>& keep) const;

 private:
  struct FrameNeighbour {
    float x, y, z, ee;  // e_j and |e_j|²
    std::uint32_t index;
  };
  std::uint32_t k_ = 0;
  std::vector<FrameNeighbour> frame_;
};

// Appends patch k's points to `out`: with `overlap` all of them, otherwise those of its region
// against `neighbours` (exactly N_k, any order). `clip`, when not null, drops points outside it
// (inclusive bounds). `out` must have normals/colours arrays in step with its positions when
// the code word has them.
void emit_patch(std::uint32_t k, const Eigen::Matrix3f& world_from_codeword_rotation,
                const Vec3f& centre, const CodewordView& codeword,
                std::span<const NeighbourInstance> neighbours, bool overlap, const Box3f* clip,
                PointCloud& out, std::vector<std::uint32_t>* parents = nullptr);

// Resampling (FORMAT.md, "Resampling"): appends to `out` the m × m points that stand for each
// point j of `part`, patch k's points as emit_patch gave them (with every attribute decoded)
// from code-word points `parents`, in order; each new point carries its parent's attributes
// and, when `part` has normals, the fit's normal turned to agree with its parent's. `clip`, when
// not null, drops new points outside it.
void emit_resampled(const Eigen::Matrix3f& world_from_codeword_rotation, const Vec3f& centre,
                    const CodewordFit& surface, int m, float step, const PointCloud& part,
                    std::span<const std::uint32_t> parents, const Box3f* clip, PointCloud& out);

// Inline: called for every code-word point a patch decodes (out of line, one patch of
// dragon_scans decoded in 11.2 us instead of 10.7, interleaved decode_bench runs).
inline bool RegionTest::claims(const Vec3f& q, float norm2) const {
  // Neighbours are sorted by |e_j|²; those with |e_j|² > 4.001·|q|² are more than 2|q| away and
  // cannot claim q (s ≥ |e_j|(|e_j| − 2|q|), a margin far above rounding), so the loop stops
  // there. Skipping them never changes the outcome of the rule.
  const float reach = 4.001f * norm2;
  for (const FrameNeighbour& f : frame_) {
    if (f.ee > reach) break;
    const float s = f.ee - 2.0f * (q.x() * f.x + q.y() * f.y + q.z() * f.z);
    if (s > 0.0f || (s == 0.0f && k_ < f.index)) continue;
    return false;
  }
  return true;
}

}  // namespace sspc::codec
