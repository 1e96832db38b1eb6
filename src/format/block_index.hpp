// A bounding-box tree over the patch blocks' boxes (the patch seek table), so that the blocks
// near a point or meeting a box are found in O(log blocks) instead of a scan: a region decode
// asks this once per patch.
//
// The encoder writes patches in spatial order, so consecutive blocks are near each other and a
// tree that simply halves the block range is a good one; on a file in any other order it is
// still correct, only slower.
#pragma once

#include <cstdint>
#include <vector>

#include "sspc/point_cloud.hpp"

namespace sspc::codec {

class BlockIndex {
 public:
  BlockIndex() = default;
  explicit BlockIndex(const std::vector<Box3f>& boxes);

  // f(block) for every block whose box is within squared distance `radius2` of `p`, in
  // increasing block order.
  template <typename F>
  void for_each_near(const Vec3f& p, float radius2, F&& f) const {
    visit([&](const Box3f& b) { return b.squaredExteriorDistance(p) <= radius2; }, f);
  }
  // f(block) for every block whose box is within squared distance `radius2` of `box`.
  template <typename F>
  void for_each_meeting(const Box3f& box, float radius2, F&& f) const {
    visit([&](const Box3f& b) { return b.squaredExteriorDistance(box) <= radius2; }, f);
  }

 private:
  struct Node {
    Box3f box;
    std::uint32_t begin = 0, end = 0;  // blocks covered
    std::int32_t left = -1, right = -1;
  };
  std::int32_t build(const std::vector<Box3f>& boxes, std::uint32_t begin, std::uint32_t end);

  template <typename Test, typename F>
  void visit(Test&& test, F&& f) const {
    if (nodes_.empty()) return;
    // Left before right keeps the callback order increasing.
    std::int32_t stack[64];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const Node& n = nodes_[static_cast<std::size_t>(stack[--top])];
      if (!test(n.box)) continue;
      if (n.left < 0) {
        for (std::uint32_t b = n.begin; b < n.end; ++b) {
          if (test(leaf_boxes_[b])) f(static_cast<std::size_t>(b));
        }
      } else {
        stack[top++] = n.right;
        stack[top++] = n.left;
      }
    }
  }

  std::vector<Node> nodes_;
  std::vector<Box3f> leaf_boxes_;
};

}  // namespace sspc::codec
