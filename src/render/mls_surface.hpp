// The MLS surface of a point set and its intersection with rays (Adamson & Alexa 2003,
// "Approximating and intersecting surfaces from points"; SPEC step 10, paper §5).
//
// f(x) = n(x) · (x − a(x)), where a(x) and n(x) are the averages of the points and normals
// near x weighted by exp(−|x − p|² / h²). The surface is f = 0 where points are near (the
// nearest within `reach` = 3h); elsewhere it is undefined, which is what ends it at the edge
// of a scan or a patch. (At 2h, the gaps of a random sampling let rays through a sphere of
// 40k points.)
//
// A ray is intersected by marching: through empty space in steps as long as the distance to the
// nearest point allows, near points in steps of h/2 watching the sign of f, and once f changes
// sign, by regula falsi on f inside that bracket: the first crossing along the ray is found
// unless two lie closer than h/2, where iterating Adamson and Alexa's plane intersection from
// the first point within reach may converge on a farther sheet.
//
// The class is the one surface both renderers use: over a whole cloud (the uncompressed model)
// and over one code word's points in the code word's frame (the compressed model).
#pragma once

#include <optional>
#include <span>
#include <vector>

#include "sspc/neighbors.hpp"
#include "sspc/point_cloud.hpp"

namespace sspc::render {

struct SurfaceHit {
  float t = 0;      // along the ray, whose direction is a unit vector
  Vec3f normal;     // unit, facing the ray's origin
  int evaluations = 0;
};

class MlsSurface {
 public:
  // `points` and `normals` (unit, same length) must outlive the surface. `bandwidth` is h.
  MlsSurface(std::span<const Vec3f> points, std::span<const Vec3f> normals, float bandwidth);

  // The first intersection with o + t·d (|d| = 1) for t in [t_min, t_max], if any.
  std::optional<SurfaceHit> intersect(const Vec3f& o, const Vec3f& d, float t_min, float t_max) const;

  // a(x) and n(x) (unnormalised mean normal); false where no point is within reach of x.
  bool evaluate(const Vec3f& x, Vec3f& a, Vec3f& n) const;
  // The same, and the distance from x to the nearest point.
  bool evaluate(const Vec3f& x, Vec3f& a, Vec3f& n, float& nearest) const;

  float bandwidth() const { return h_; }
  const KdTree3& tree() const { return tree_; }

 private:
  std::span<const Vec3f> points_;
  std::span<const Vec3f> normals_;
  float h_;
  float reach_;
  KdTree3 tree_;
};

}  // namespace sspc::render
