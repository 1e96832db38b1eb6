// Tile planning for tiled encoding (encoder/tiling.hpp).
#include "encoder/tiling.hpp"

#include <algorithm>
#include <array>
#include <numeric>

namespace sspc::codec {
namespace {

constexpr int kMaxDepth = 20;

void split(std::span<const Vec3f> positions, const Box3f& box, std::vector<std::uint32_t>& points,
           std::uint64_t max_points, int depth, TilePlan& out) {
  if (points.empty()) return;
  if (points.size() <= max_points || depth == kMaxDepth) {
    out.boxes.push_back(box);
    out.points.push_back(std::move(points));
    return;
  }
  const Vec3f mid = box.center();
  std::array<std::vector<std::uint32_t>, 8> child;
  for (std::uint32_t i : points) {
    const Vec3f& p = positions[i];
    const int octant = (p.x() >= mid.x() ? 1 : 0) | (p.y() >= mid.y() ? 2 : 0) | (p.z() >= mid.z() ? 4 : 0);
    child[static_cast<std::size_t>(octant)].push_back(i);
  }
  points.clear();
  points.shrink_to_fit();
  for (int octant = 0; octant < 8; ++octant) {
    Vec3f lo = box.min(), hi = box.max();
    for (int a = 0; a < 3; ++a) {
      if ((octant >> a) & 1) {
        lo[a] = mid[a];
      } else {
        hi[a] = mid[a];
      }
    }
    split(positions, Box3f(lo, hi), child[static_cast<std::size_t>(octant)], max_points, depth + 1, out);
  }
}

}  // namespace

TilePlan plan_tiles(std::span<const Vec3f> positions, std::uint64_t max_points) {
  Box3f bounds;
  for (const Vec3f& p : positions) bounds.extend(p);
  std::vector<std::uint32_t> all(positions.size());
  std::iota(all.begin(), all.end(), 0u);
  TilePlan plan;
  split(positions, bounds, all, std::max<std::uint64_t>(max_points, 1), 0, plan);
  return plan;
}

}  // namespace sspc::codec
