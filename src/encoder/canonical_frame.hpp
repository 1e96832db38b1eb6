// Translation and orientation normalisation of a patch (Hubo et al. 2007, §4.2.1).
//
// The canonical frame has its origin at the patch centroid, +Z along the mean normal, and +X at
// the patch's mean normal azimuth. After the first rotation the plain sum of the normals' x,y
// parts is zero by construction, so the azimuth is the circular mean of the *unit* azimuth
// vectors; when those cancel too (a rotationally symmetric bump) the principal axis of the
// normals' x,y components is used, its sign fixed by their third moment. Flat patches have no
// meaningful azimuth at all: ICP refines whatever this frame gives.
#pragma once

#include <cstdint>
#include <span>

#include "geometry/rigid_transform.hpp"
#include "sspc/point_cloud.hpp"

namespace sspc {

struct CanonicalFrame {
  RigidTransform world_from_canonical;
  // How well the azimuth is defined, in [0, 1]: the resultant length of the unit azimuth
  // vectors, or the principal-axis anisotropy when that was used; 0 for a flat patch.
  float azimuth_confidence = 0;
};

// Frame of the points `indices` of `positions`/`normals` (normals unit length, consistently
// oriented). An empty index list gives the identity.
CanonicalFrame canonical_frame(std::span<const Vec3f> positions, std::span<const Vec3f> normals,
                               std::span<const std::uint32_t> indices);

}  // namespace sspc
