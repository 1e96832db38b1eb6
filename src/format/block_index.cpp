#include "format/block_index.hpp"

namespace sspc::codec {

BlockIndex::BlockIndex(const std::vector<Box3f>& boxes) : leaf_boxes_(boxes) {
  if (boxes.empty()) return;
  nodes_.reserve(2 * boxes.size() / 4 + 2);
  build(boxes, 0, static_cast<std::uint32_t>(boxes.size()));
}

std::int32_t BlockIndex::build(const std::vector<Box3f>& boxes, std::uint32_t begin,
                               std::uint32_t end) {
  const auto id = static_cast<std::int32_t>(nodes_.size());
  nodes_.push_back(Node{});
  Box3f box;
  for (std::uint32_t b = begin; b < end; ++b) box.extend(boxes[b]);
  nodes_.back().box = box;
  nodes_.back().begin = begin;
  nodes_.back().end = end;
  // Leaves of up to four blocks; halving keeps the depth at log2(blocks) ≤ 32, within the
  // traversal stack.
  if (end - begin > 4) {
    const std::uint32_t mid = begin + (end - begin) / 2;
    const std::int32_t left = build(boxes, begin, mid);
    const std::int32_t right = build(boxes, mid, end);
    nodes_[static_cast<std::size_t>(id)].left = left;
    nodes_[static_cast<std::size_t>(id)].right = right;
  }
  return id;
}

}  // namespace sspc::codec
