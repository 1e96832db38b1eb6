// One direction A→B of the point-cloud distortion: over A's points, the distance to the nearest
// point of B (paper §6's RMS(A,B), its maximum the one-sided Hausdorff distance), and MPEG's
// point-to-point (D1) and point-to-plane (D2) mean squared errors as mpeg-pcc-dmetric's
// findMetric computes them (source/pcc_distortion.cpp). Formulas: docs/METRICS.md.
#pragma once

#include <span>

#include "eval/nearest_groups.hpp"
#include "sspc/metrics.hpp"
#include "sspc/point_cloud.hpp"

namespace sspc::eval {

// `groups`: for each point of `from`, its nearest group among `to`. `to_normals`: one normal per
// point of `to` for D2, or empty for D1 only (has_d2 stays false). Bit-identical whatever the
// thread count.
DirectedError directed_error(std::span<const Vec3f> from, std::span<const Vec3f> to,
                             const NearestGroups& groups, std::span<const Vec3f> to_normals);
DirectedError directed_error(std::span<const Vec3f> from, std::span<const Vec3f> to,
                             const NearestGroups& groups, std::span<const Vec3d> to_normals);

}  // namespace sspc::eval
