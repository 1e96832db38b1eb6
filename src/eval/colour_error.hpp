// One direction A→B of the colour distortion: each point of A against the colour of its nearest
// point of B, as MPEG's metric software (mpeg-pcc-dmetric, source/pcc_distortion.cpp,
// findMetric, with its default --neighborsProc=1) compares colours, but in RGB rather than its
// default YCbCr. Where several points of B are equidistant from a, a is compared with their mean
// colour. docs/METRICS.md, "Colour".
#pragma once

#include <span>

#include "eval/nearest_groups.hpp"
#include "sspc/point_cloud.hpp"

namespace sspc::eval {

// `groups`: for each point of A, its nearest group among B's points, index for index with
// `from`; `to` holds one colour per point of B. Returns the mean over A's points and over R, G
// and B of (a's channel − the group's mean channel)², in 8-bit levels squared. Bit-identical
// whatever the thread count.
double colour_mse(std::span<const Rgb8> from, std::span<const Rgb8> to,
                  const NearestGroups& groups);

}  // namespace sspc::eval
