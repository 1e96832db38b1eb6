// Angular error of normals: for each TEST point, the angle between its normal and the normal of
// its nearest REF point (the mean over REF's equidistant group). Orientation counts, because the
// MLS surface and the patch descriptors depend on it: a flipped normal is 180°, not 0°.
// docs/METRICS.md, "Normals' angular error".
#pragma once

#include <cstdint>
#include <span>

#include "eval/nearest_groups.hpp"
#include "sspc/point_cloud.hpp"

namespace sspc::eval {

struct NormalAngleStats {
  double mean_deg = 0;
  double p95_deg = 0;        // nearest-rank 95th percentile
  std::uint64_t points = 0;  // TEST points with a defined angle
};

// The angle between two vectors in degrees, in [0, 180]; the vectors need not be unit length.
// NaN when either is zero.
double angle_degrees(const Vec3d& a, const Vec3d& b);

// `test_to_ref`: for each TEST point its nearest group among REF's points. Points whose normal is
// zero, or whose group has only zero normals, have no angle and are left out of the statistics.
// Bit-identical whatever the thread count.
NormalAngleStats normal_angle_error(std::span<const Vec3f> test_normals,
                                    std::span<const Vec3f> ref_normals,
                                    const NearestGroups& test_to_ref);

}  // namespace sspc::eval
