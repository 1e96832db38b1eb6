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
    const double lo = static_cast<double>(bounds.min()[a]), extent = static_cast<double>(bounds.max()[a]) - lo;
    int i = 0;
    if (extent > 0) i = static_cast<int>(std::floor((static_cast<double>(p[a]) - lo) / extent * n));
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

// Cells [lo, hi) of the grid along each axis.
struct Range {
  std::array<int, 3> lo{}, hi{};
};

struct Splitter {
  TilePlan& plan;
  std::uint64_t max_points;
  int side = 0;
  std::vector<std::uint64_t> sums;  // summed-volume table: (side + 1)³ prefix sums of the counts

  std::size_t at(int x, int y, int z) const {
    const auto n = static_cast<std::size_t>(side) + 1;
    return (static_cast<std::size_t>(z) * n + static_cast<std::size_t>(y)) * n + static_cast<std::size_t>(x);
  }
  std::uint64_t count(const Range& r) const {
    const auto& [x0, y0, z0] = r.lo;
    const auto& [x1, y1, z1] = r.hi;
    return sums[at(x1, y1, z1)] - sums[at(x0, y1, z1)] - sums[at(x1, y0, z1)] - sums[at(x1, y1, z0)] +
           sums[at(x0, y0, z1)] + sums[at(x0, y1, z0)] + sums[at(x1, y0, z0)] - sums[at(x0, y0, z0)];
  }
  Box3f box(const Range& r) const {
    Vec3f lo, hi;
    for (std::size_t a = 0; a < 3; ++a) {
      const auto axis = static_cast<Eigen::Index>(a);
      const double min = static_cast<double>(plan.bounds.min()[axis]),
                   extent = static_cast<double>(plan.bounds.max()[axis]) - min;
      lo[axis] = static_cast<float>(min + extent * r.lo[a] / side);
      hi[axis] = r.hi[a] == side ? plan.bounds.max()[axis] : static_cast<float>(min + extent * r.hi[a] / side);
    }
    return Box3f(lo, hi);
  }

  void split(const Range& r) {
    const std::uint64_t n = count(r);
    if (n == 0) return;
    // The axis to halve: the longest in the world of those wider than one cell.
    int axis = -1;
    double longest = 0;
    for (std::size_t a = 0; a < 3; ++a) {
      const auto e = static_cast<Eigen::Index>(a);
      const double extent =
          (static_cast<double>(plan.bounds.max()[e]) - static_cast<double>(plan.bounds.min()[e])) * (r.hi[a] - r.lo[a]);
      if (r.hi[a] - r.lo[a] > 1 && (axis < 0 || extent > longest)) {
        axis = static_cast<int>(a);
        longest = extent;
      }
    }
    if (n <= max_points || axis < 0) {
      const auto tile = static_cast<std::uint32_t>(plan.boxes.size());
      plan.boxes.push_back(box(r));
      plan.points.push_back(n);
      for (int z = r.lo[2]; z < r.hi[2]; ++z) {
        for (int y = r.lo[1]; y < r.hi[1]; ++y) {
          for (int x = r.lo[0]; x < r.hi[0]; ++x) {
            plan.tile_of_cell[(((static_cast<std::size_t>(z) << plan.depth) | static_cast<std::size_t>(y)) << plan.depth) |
                              static_cast<std::size_t>(x)] = tile;
          }
        }
      }
      return;
    }
    const auto a = static_cast<std::size_t>(axis);
    Range lower = r, upper = r;
    lower.hi[a] = upper.lo[a] = (r.lo[a] + r.hi[a]) / 2;
    split(lower);
    split(upper);
  }
};

// The leaves renumbered in a sweep along the bounds' longest axis: by their boxes' lower corner
// along it, then along the next longest, then the last. A tiled encode writes tile t's code
// book once no later tile can reach it (ContainerStreamWriter), and holds it (on disk) until
// then. In the splits' depth-first order a leaf beside the first cut waits for the far half's
// leaves beside it, about half the tiles later, so the code books held grew with the cloud: 1B
// points of terrain in 344 tiles held 15 GB of them on disk at a quarter of the way and were
// heading past the disk's free space. Swept, a tile waits for the leaves in a slab about one tile
// wide beyond it, about √n of n tiles on a surface (Tiling.SweptLeavesWaitForFewTiles).
void sweep_order(TilePlan& plan) {
  std::array<Eigen::Index, 3> axes{0, 1, 2};
  const Vec3f extent = plan.bounds.isEmpty() ? Vec3f::Zero() : Vec3f(plan.bounds.max() - plan.bounds.min());
  std::stable_sort(axes.begin(), axes.end(), [&](Eigen::Index a, Eigen::Index b) { return extent[a] > extent[b]; });
  std::vector<std::uint32_t> order(plan.size());
  for (std::size_t t = 0; t < order.size(); ++t) order[t] = static_cast<std::uint32_t>(t);
  std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    const Vec3f& pa = plan.boxes[a].min();
    const Vec3f& pb = plan.boxes[b].min();
    for (const Eigen::Index axis : axes) {
      if (pa[axis] != pb[axis]) return pa[axis] < pb[axis];
    }
    return false;
  });
  std::vector<std::uint32_t> renumbered(plan.size());
  std::vector<Box3f> boxes(plan.size());
  std::vector<std::uint64_t> points(plan.size());
  for (std::size_t k = 0; k < order.size(); ++k) {
    renumbered[order[k]] = static_cast<std::uint32_t>(k);
    boxes[k] = plan.boxes[order[k]];
    points[k] = plan.points[order[k]];
  }
  plan.boxes = std::move(boxes);
  plan.points = std::move(points);
  for (std::uint32_t& t : plan.tile_of_cell) {
    if (t != kNoTile) t = renumbered[t];
  }
}

}  // namespace

TilePlan TilePlanner::plan(std::uint64_t max_points) {
  TilePlan plan = plan_;
  Splitter s{plan, std::max<std::uint64_t>(max_points, 1), 1 << plan.depth, {}};
  const int side = s.side;
  s.sums.assign(static_cast<std::size_t>(side + 1) * static_cast<std::size_t>(side + 1) * static_cast<std::size_t>(side + 1), 0);
  for (int z = 1; z <= side; ++z) {
    for (int y = 1; y <= side; ++y) {
      for (int x = 1; x <= side; ++x) {
        const std::uint64_t c = counts_[(((static_cast<std::size_t>(z - 1) << plan.depth) | static_cast<std::size_t>(y - 1))
                                         << plan.depth) | static_cast<std::size_t>(x - 1)];
        s.sums[s.at(x, y, z)] = c + s.sums[s.at(x - 1, y, z)] + s.sums[s.at(x, y - 1, z)] + s.sums[s.at(x, y, z - 1)] -
                                s.sums[s.at(x - 1, y - 1, z)] - s.sums[s.at(x - 1, y, z - 1)] -
                                s.sums[s.at(x, y - 1, z - 1)] + s.sums[s.at(x - 1, y - 1, z - 1)];
      }
    }
  }
  plan.tile_of_cell.assign(counts_.size(), kNoTile);
  s.split(Range{{0, 0, 0}, {side, side, side}});
  sweep_order(plan);
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
