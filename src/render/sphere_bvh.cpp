#include "render/sphere_bvh.hpp"

#include <algorithm>
#include <array>
#include <limits>

namespace sspc::render {

namespace {

constexpr int kBins = 12;
constexpr std::uint32_t kLeafSize = 4;

Box3f sphere_box(const Sphere& s) {
  return Box3f(s.centre - Vec3f::Constant(s.radius), s.centre + Vec3f::Constant(s.radius));
}

float area(const Box3f& b) {
  if (b.isEmpty()) return 0;
  const Vec3f e = b.sizes();
  return 2 * (e.x() * e.y() + e.y() * e.z() + e.z() * e.x());
}

}  // namespace

SphereBvh::SphereBvh(std::vector<Sphere> spheres) : spheres_(std::move(spheres)) {
  order_.resize(spheres_.size());
  for (std::uint32_t i = 0; i < order_.size(); ++i) order_[i] = i;
  if (!spheres_.empty()) {
    nodes_.reserve(2 * spheres_.size());
    build(0, static_cast<std::uint32_t>(spheres_.size()), 0);
  }
}

std::uint32_t SphereBvh::build(std::uint32_t first, std::uint32_t count, int depth) {
  const auto index = static_cast<std::uint32_t>(nodes_.size());
  nodes_.emplace_back();
  Box3f box, centres;
  for (std::uint32_t i = first; i < first + count; ++i) {
    box.extend(sphere_box(spheres_[order_[i]]));
    centres.extend(spheres_[order_[i]].centre);
  }
  nodes_[index].box = box;
  if (count <= kLeafSize) {
    nodes_[index].first = first;
    nodes_[index].count = count;
    return index;
  }
  // Binned SAH over the centres' widest axis; cost = Σ area(side) × items(side).
  int axis = 0;
  centres.sizes().maxCoeff(&axis);
  const float lo = centres.min()[axis], extent = centres.sizes()[axis];
  std::uint32_t split = first;  // no SAH split yet
  if (extent > 0 && depth < kMedianDepth) {
    std::array<Box3f, kBins> bin_box;
    std::array<std::uint32_t, kBins> bin_count{};
    const auto bin_of = [&](std::uint32_t item) {
      const float u = (spheres_[order_[item]].centre[axis] - lo) / extent;
      return std::min(kBins - 1, static_cast<int>(u * kBins));
    };
    for (std::uint32_t i = first; i < first + count; ++i) {
      const int b = bin_of(i);
      bin_box[static_cast<std::size_t>(b)].extend(sphere_box(spheres_[order_[i]]));
      ++bin_count[static_cast<std::size_t>(b)];
    }
    float best = std::numeric_limits<float>::infinity();
    int best_bin = -1;
    for (int cut = 1; cut < kBins; ++cut) {
      Box3f left, right;
      std::uint32_t nl = 0, nr = 0;
      for (int b = 0; b < cut; ++b) {
        left.extend(bin_box[static_cast<std::size_t>(b)]);
        nl += bin_count[static_cast<std::size_t>(b)];
      }
      for (int b = cut; b < kBins; ++b) {
        right.extend(bin_box[static_cast<std::size_t>(b)]);
        nr += bin_count[static_cast<std::size_t>(b)];
      }
      if (nl == 0 || nr == 0) continue;
      const float cost = area(left) * static_cast<float>(nl) + area(right) * static_cast<float>(nr);
      if (cost < best) {
        best = cost;
        best_bin = cut;
      }
    }
    if (best_bin > 0) {
      const auto middle = std::stable_partition(order_.begin() + first, order_.begin() + first + count,
                                                [&](std::uint32_t s) {
                                                  const float u = (spheres_[s].centre[axis] - lo) / extent;
                                                  return std::min(kBins - 1, static_cast<int>(u * kBins)) < best_bin;
                                                });
      split = static_cast<std::uint32_t>(middle - order_.begin());
    }
  }
  if (split == first || split == first + count) {
    // No SAH split (too deep, all centres in one bin, or coincident): the median along the axis.
    std::stable_sort(order_.begin() + first, order_.begin() + first + count, [&](std::uint32_t a, std::uint32_t b) {
      return spheres_[a].centre[axis] < spheres_[b].centre[axis];
    });
    split = first + count / 2;
  }
  build(first, split - first, depth + 1);  // the left child is index + 1
  const std::uint32_t right = build(split, first + count - split, depth + 1);
  nodes_[index].first = right;
  nodes_[index].count = 0;
  return index;
}

}  // namespace sspc::render
