// Tile planning for tiled encoding (encoder/tiling.hpp).
#include "encoder/tiling.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace sspc::codec {

std::uint32_t TilePlan::cell_of(const Vec3f& p) const {
  const int n = 1 << depth;
  std::uint32_t index = 0;
  for (int a = 2; a >= 0; --a) {
    const double lo = bounds.min()[a], extent = double{bounds.max()[a]} - lo;
    int i = 0;
    if (extent > 0) i = static_cast<int>(std::floor((double{p[a]} - lo) / extent * n));
    index = (index << depth) | static_cast<std::uint32_t>(std::clamp(i, 0, n - 1));
  }
  return index;
}

TilePlanner::TilePlanner(const Box3f& bounds, int depth) {
  plan_.bounds = bounds;
  plan_.depth = depth;
  counts_.assign(std::size_t{1} << (3 * depth), 0);
}

void TilePlanner::add(std::span<const Vec3f> points) {
  for (const Vec3f& p : points) ++counts_[plan_.cell_of(p)];
}

namespace {

struct Splitter {
  TilePlan& plan;
  std::uint64_t max_points;
  std::vector<std::vector<std::uint64_t>> levels;  // levels[d]: counts of the depth-d cells

  std::size_t index(int d, const std::array<int, 3>& i) const {
    return (((static_cast<std::size_t>(i[2]) << d) | static_cast<std::size_t>(i[1])) << d) |
           static_cast<std::size_t>(i[0]);
  }

  Box3f box(int d, const std::array<int, 3>& i) const {
    Vec3f lo, hi;
    const double n = std::ldexp(1.0, d);
    for (std::size_t a = 0; a < 3; ++a) {
      const auto axis = static_cast<Eigen::Index>(a);
      const double min = plan.bounds.min()[axis], extent = double{plan.bounds.max()[axis]} - min;
      lo[axis] = static_cast<float>(min + extent * (i[a] / n));
      hi[axis] = i[a] + 1 == static_cast<int>(n) ? plan.bounds.max()[axis]
                                                 : static_cast<float>(min + extent * ((i[a] + 1) / n));
    }
    return Box3f(lo, hi);
  }

  void split(int d, const std::array<int, 3>& i) {
    const std::uint64_t count = levels[static_cast<std::size_t>(d)][index(d, i)];
    if (count == 0) return;
    if (count <= max_points || d == plan.depth) {
      const auto tile = static_cast<std::uint32_t>(plan.boxes.size());
      plan.boxes.push_back(box(d, i));
      plan.points.push_back(count);
      const int shift = plan.depth - d, side = 1 << shift;
      for (int z = 0; z < side; ++z) {
        for (int y = 0; y < side; ++y) {
          for (int x = 0; x < side; ++x) {
            const std::array<int, 3> cell{(i[0] << shift) + x, (i[1] << shift) + y, (i[2] << shift) + z};
            plan.tile_of_cell[index(plan.depth, cell)] = tile;
          }
        }
      }
      return;
    }
    for (int octant = 0; octant < 8; ++octant) {
      split(d + 1, {2 * i[0] + (octant & 1), 2 * i[1] + ((octant >> 1) & 1), 2 * i[2] + ((octant >> 2) & 1)});
    }
  }
};

}  // namespace

TilePlan TilePlanner::plan(std::uint64_t max_points) {
  TilePlan plan = plan_;
  const int depth = plan.depth;
  Splitter s{plan, std::max<std::uint64_t>(max_points, 1), {}};
  s.levels.resize(static_cast<std::size_t>(depth) + 1);
  s.levels[static_cast<std::size_t>(depth)] = counts_;
  for (int d = depth; d > 0; --d) {
    std::vector<std::uint64_t>& coarse = s.levels[static_cast<std::size_t>(d) - 1];
    coarse.assign(std::size_t{1} << (3 * (d - 1)), 0);
    const int side = 1 << d;
    for (int z = 0; z < side; ++z) {
      for (int y = 0; y < side; ++y) {
        for (int x = 0; x < side; ++x) {
          coarse[s.index(d - 1, {x >> 1, y >> 1, z >> 1})] += s.levels[static_cast<std::size_t>(d)][s.index(d, {x, y, z})];
        }
      }
    }
  }
  plan.tile_of_cell.assign(counts_.size(), kNoTile);
  s.split(0, {0, 0, 0});
  return plan;
}

TilePlan plan_tiles(std::span<const Vec3f> positions, std::uint64_t max_points) {
  Box3f bounds;
  for (const Vec3f& p : positions) bounds.extend(p);
  TilePlanner planner(bounds);
  planner.add(positions);
  return planner.plan(max_points);
}

}  // namespace sspc::codec
