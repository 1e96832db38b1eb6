// Spatial (Morton, Z-order) sorting: neighbouring patches end up in the same file block, so a
// box decodes from few blocks and translations delta-code well.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "sspc/point_cloud.hpp"

namespace sspc::codec {

// The 63-bit Morton code of `p` quantised to 21 bits per axis within `bounds`.
std::uint64_t morton_code(const Vec3f& p, const Box3f& bounds);

// The permutation that sorts `points` by Morton code, ties by index.
std::vector<std::uint32_t> spatial_order(const std::vector<Vec3f>& points, const Box3f& bounds);

// The order the encoder takes a cloud's points in: by Morton code within the points' bounding
// box, ties by position (x, then y, then z), then by index, so that the same points in any order
// come out in one order (only coincident points keep theirs among themselves). Sorted in
// parallel, the same whatever the thread count.
std::vector<std::uint32_t> point_order(std::span<const Vec3f> points);

// Sorts `points` in place by spatial_order.
void sort_spatially(std::vector<Vec3f>& points, const Box3f& bounds);

}  // namespace sspc::codec
