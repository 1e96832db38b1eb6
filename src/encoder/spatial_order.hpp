// Spatial (Morton, Z-order) sorting: neighbouring patches end up in the same file block, so a
// box decodes from few blocks and translations delta-code well.
#pragma once

#include <cstdint>
#include <vector>

#include "sspc/point_cloud.hpp"

namespace sspc::codec {

// The 63-bit Morton code of `p` quantised to 21 bits per axis within `bounds`.
std::uint64_t morton_code(const Vec3f& p, const Box3f& bounds);

// The permutation that sorts `points` by Morton code, ties by index.
std::vector<std::uint32_t> spatial_order(const std::vector<Vec3f>& points, const Box3f& bounds);

// Sorts `points` in place by spatial_order.
void sort_spatially(std::vector<Vec3f>& points, const Box3f& bounds);

}  // namespace sspc::codec
