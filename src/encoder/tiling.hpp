// Tiled encoding: the cloud cut into octree-aligned tiles, each encoded on its own with a margin
// of its neighbours' points, the tiles' patches and code words written one tile after the other
// into one model (one ordinary .sspc: random access across tiles is the block index's, as in any
// file; encoder/container_writer.hpp's ContainerStreamWriter).
//
// The rule that makes a tiled model the untiled one up to the centres' placement:
// - every tile uses the whole cloud's spacing and patch radius (the level's parameters are
//   the same everywhere);
// - a tile's centres cover its own points only, and its patches gather points from its own
//   points and a margin of one patch radius plus 8 spacings around it, so that a patch near the
//   border holds the same points as untiled (a patch reaches one patch radius from its centre,
//   an own point), and the normals estimated there see the same neighbourhoods (k = 16 nearest
//   are within a few spacings);
// - the region decoder's cells are those of all centres, across tiles: a point near a border
//   decodes from whichever tile's centre is nearest, as it would untiled.
// Not the paper's (§4 encodes the whole cloud at once). The memory a tile needs is that of its
// points, so a tile size follows from a memory limit, and the plan itself needs only the
// counts of a fixed grid, which a pass over a file too large to hold gives (tile_store.hpp).
#pragma once

#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "sspc/point_cloud.hpp"

namespace sspc::codec {

// The counting grid: 2^7 cells along each axis of the bounding box (2M cells, 16 MB of counts).
// A leaf is never finer than a grid cell, so a cell holding more than the tile size (128³ cells
// over 1e9 points of terrain hold about 60k each) makes a tile larger than asked, never a wrong one.
inline constexpr int kTileGridDepth = 7;
inline constexpr std::uint32_t kNoTile = std::numeric_limits<std::uint32_t>::max();

struct TilePlan {
  Box3f bounds;  // of every point
  int depth = kTileGridDepth;
  std::vector<Box3f> boxes;           // the leaves, swept along the longest axis (tiling.cpp)
  std::vector<std::uint64_t> points;  // each leaf's point count
  std::vector<std::uint32_t> tile_of_cell;  // per grid cell: its leaf, or kNoTile

  // The grid cell of `p`: per axis floor((p − min) / extent · 2^depth), clamped to the grid, so
  // a point on a split plane goes to the upper side and the bounds' maximum to the last cell.
  std::uint32_t cell_of(const Vec3f& p) const;
  std::uint32_t tile_of(const Vec3f& p) const { return tile_of_cell[cell_of(p)]; }
  std::size_t size() const { return boxes.size(); }
};

// Counts points per grid cell, then plans: a cell is halved across its longest side (in the
// world) while it holds more than `max_points` points and is wider than one grid cell there,
// empty leaves dropped. Every cut is an octree plane (a cell's middle), so the tiles are unions of
// octree cells, but halving one axis at a time makes tiles between half the limit and the limit
// where an octree's eighths would make them an eighth of it, and never cuts a flat cloud (airborne
// LiDAR) across its thickness: larger tiles, less margin.
class TilePlanner {
 public:
  explicit TilePlanner(const Box3f& bounds, int depth = kTileGridDepth);
  void add(std::span<const Vec3f> points);
  TilePlan plan(std::uint64_t max_points);

 private:
  TilePlan plan_;
  std::vector<std::uint64_t> counts_;
};

// Both steps over points in memory.
TilePlan plan_tiles(std::span<const Vec3f> positions, std::uint64_t max_points);

}  // namespace sspc::codec
