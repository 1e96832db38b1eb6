// A code word's points and normals with their k-d tree: the target that candidate patches are
// aligned to by ICP and then measured against by nearest-point distances (paper §4.3).
// The paper measured the fit by the MLS residual n(x)·(x − a(x)); the encoder now
// measures what the codec is judged by, nearest-point distances (see try_match in
// codebook_builder.cpp), so only the points, their normals (for point-to-plane ICP) and the
// tree are needed here. The MLS surface itself lives in src/render/mls_surface.
#pragma once

#include <span>

#include "sspc/neighbours.hpp"
#include "sspc/point_cloud.hpp"

namespace sspc::codec {

class CodewordSurface {
 public:
  // `points` and `normals` (same length) must outlive the surface.
  CodewordSurface(std::span<const Vec3f> points, std::span<const Vec3f> normals);

  std::span<const Vec3f> points() const { return points_; }
  std::span<const Vec3f> normals() const { return normals_; }
  const KdTree3& tree() const { return tree_; }

 private:
  std::span<const Vec3f> points_;
  std::span<const Vec3f> normals_;
  KdTree3 tree_;
};

}  // namespace sspc::codec
