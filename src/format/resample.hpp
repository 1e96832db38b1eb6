// Resampling a code word on its local surface (docs/FORMAT.md, "Resampling"; the paper's
// surface view of a patch, §3, taken to the decoder's output).
//
// At coarse levels the code words' grid is several source spacings wide, so a decode holds a
// fraction of the source's points and the paper's point-to-point PSNR is set by the gaps
// between them, not by how far they lie from the surface. A header whose `resample` byte is
// m ≥ 1 asks the decoder to replace each decoded point by m × m points on a weighted quadratic
// fitted to its 16 nearest code-word points, spread over the point's grid cell: the decode
// then holds about the source's count, on the surface the code word describes. Measured with a
// prototype on the decoded levels 7-9 (bunny, igea, dragon_scans): +2.6 to +7.1 dB at the same
// bits, except dragon_scans at level 7 (-0.2 dB), whose decode holds 73% of the source's points
// (docs/FORMAT_NOTES.md, "Resampling").
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "sspc/neighbours.hpp"
#include "sspc/point_cloud.hpp"

namespace sspc::codec {

inline constexpr int kMaxResample = 4;
inline constexpr std::size_t kResampleNeighbours = 16;

// One code word's points and a k-d tree over them. The points must outlive it and not move.
class CodewordFit {
 public:
  explicit CodewordFit(std::span<const Vec3f> points);

  // Appends to `points` the m × m points that stand for code-word point i (in the code word's
  // frame, `step` the code words' grid step), and their unit normals to `normals` unless it is
  // null (a decode without normals).
  void resample(std::uint32_t i, int m, float step, std::vector<Vec3f>& points,
                std::vector<Vec3f>* normals) const;

  // What the tree holds beyond the points, for the block cache's count.
  std::uint64_t memory_bytes() const;

 private:
  std::span<const Vec3f> points_;
  KdTree3 tree_;
};

}  // namespace sspc::codec
