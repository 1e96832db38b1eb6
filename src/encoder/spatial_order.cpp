#include "encoder/spatial_order.hpp"

#include <algorithm>
#include <numeric>
#include <tuple>
#include <utility>

#include "core/parallel.hpp"

namespace sspc::codec {

namespace {

// Spreads the low 21 bits of v three apart.
std::uint64_t spread_bits(std::uint64_t v) {
  v &= 0x1FFFFF;
  v = (v | v << 32) & 0x1F00000000FFFFULL;
  v = (v | v << 16) & 0x1F0000FF0000FFULL;
  v = (v | v << 8) & 0x100F00F00F00F00FULL;
  v = (v | v << 4) & 0x10C30C30C30C30C3ULL;
  v = (v | v << 2) & 0x1249249249249249ULL;
  return v;
}

}  // namespace

std::uint64_t morton_code(const Vec3f& p, const Box3f& bounds) {
  std::uint64_t code = 0;
  for (int a = 0; a < 3; ++a) {
    const float extent = bounds.max()[a] - bounds.min()[a];
    const float u = extent > 0 ? (p[a] - bounds.min()[a]) / extent : 0.0f;
    const auto q = static_cast<std::uint64_t>(std::clamp(u, 0.0f, 1.0f) * 2097151.0f);
    code |= spread_bits(q) << (2 - a);
  }
  return code;
}

std::vector<std::uint32_t> spatial_order(const std::vector<Vec3f>& points, const Box3f& bounds) {
  std::vector<std::uint64_t> codes(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) codes[i] = morton_code(points[i], bounds);
  std::vector<std::uint32_t> order(points.size());
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    return codes[a] < codes[b] || (codes[a] == codes[b] && a < b);
  });
  return order;
}

std::vector<std::uint32_t> point_order(std::span<const Vec3f> points) {
  Box3f bounds;
  for (const Vec3f& p : points) bounds.extend(p);
  // (code, index) pairs: the comparison reads the positions only where two codes tie.
  std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(points.size());
  parallel_for(0, points.size(), 4096, [&](std::size_t i) {
    keyed[i] = {morton_code(points[i], bounds), static_cast<std::uint32_t>(i)};
  });
  parallel_sort(keyed.begin(), keyed.end(), [&](const auto& a, const auto& b) {
    if (a.first != b.first) return a.first < b.first;
    const Vec3f& p = points[a.second];
    const Vec3f& q = points[b.second];
    return std::tie(p.x(), p.y(), p.z(), a.second) < std::tie(q.x(), q.y(), q.z(), b.second);
  });
  std::vector<std::uint32_t> order(points.size());
  parallel_for(0, points.size(), 4096, [&](std::size_t i) { order[i] = keyed[i].second; });
  return order;
}

void sort_spatially(std::vector<Vec3f>& points, const Box3f& bounds) {
  const std::vector<std::uint32_t> order = spatial_order(points, bounds);
  std::vector<Vec3f> sorted(points.size());
  for (std::size_t i = 0; i < order.size(); ++i) sorted[i] = points[order[i]];
  points = std::move(sorted);
}

}  // namespace sspc::codec
