// Tiled encoding: the cloud cut into octree-aligned tiles, each encoded on its own with a margin
// of its neighbours' points, the tiles' patches and code words joined into one model (one
// ordinary .sspc: random access across tiles is the block index's, as in any file).
//
// The rule that makes a tiled model the untiled one up to the centres' placement:
// - every tile uses the whole cloud's spacing and patch radius (the level's parameters are
//   the same everywhere);
// - a tile's centres cover its own points only, and its patches gather points from its own
//   points and a margin of 1.5 patch radii plus 8 spacings around it, so that a patch near the
//   border holds the same points as untiled (a patch reaches one patch radius), and the normals
//   estimated there see the same neighbourhoods (k = 16 nearest are within a few spacings);
// - the region decoder's cells are those of all centres, across tiles: a point near a border
//   decodes from whichever tile's centre is nearest, as it would untiled.
// Not the paper's (§4 encodes the whole cloud at once); the memory a tile needs is that of its
// points, which is what the scale issue's --memory-limit will size (docs/ARCHITECTURE.md).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "sspc/point_cloud.hpp"

namespace sspc::codec {

struct TilePlan {
  std::vector<Box3f> boxes;                 // octree leaves, depth-first (Morton) order
  std::vector<std::vector<std::uint32_t>> points;  // each leaf's points, ascending
};

// Octree leaves over `positions`' bounding box, each cell split in eight until it holds at most
// `max_points` points (or is 2^-20 of the box), empty leaves dropped. Points on a split plane go
// to the upper half, so every point is in exactly one leaf.
TilePlan plan_tiles(std::span<const Vec3f> positions, std::uint64_t max_points);

}  // namespace sspc::codec
