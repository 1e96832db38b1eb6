// The MLS surface of a code word's points (Adamson & Alexa 2003, "Approximating and
// intersecting surfaces from points"; the surface the renderer intersects, SPEC step 10), used
// by the encoder to measure how well a candidate patch fits a representative (paper §4.3).
//
// f(x) = n(x) · (x − a(x)), with a(x) and n(x) the Gaussian-weighted means of the nearby points
// and normals, weights exp(−|x − p|² / h²). |f(x)| is the distance from x to the local plane of
// the surface, the error the paper's τ bounds.
#pragma once

#include <span>
#include <vector>

#include "sspc/neighbors.hpp"
#include "sspc/point_cloud.hpp"

namespace sspc::codec {

class CodewordSurface {
 public:
  // `points` and `normals` must outlive the surface. `bandwidth` is h.
  CodewordSurface(std::span<const Vec3f> points, std::span<const Vec3f> normals, float bandwidth);

  std::span<const Vec3f> points() const { return points_; }
  std::span<const Vec3f> normals() const { return normals_; }
  const KdTree3& tree() const { return tree_; }
  float bandwidth() const { return bandwidth_; }

  // f(x) as above over the `kNeighbours` nearest points; `nearest_distance` gets the distance
  // to the nearest point (how far x is from any sample: a hole or the patch's edge).
  float mls_residual(const Vec3f& x, float* nearest_distance) const;

  static constexpr std::size_t kNeighbours = 10;

 private:
  std::span<const Vec3f> points_;
  std::span<const Vec3f> normals_;
  float bandwidth_;
  KdTree3 tree_;
};

}  // namespace sspc::codec
