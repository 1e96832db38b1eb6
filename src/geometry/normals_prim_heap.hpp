// The priority queue of Prim's algorithm for the orientation tree (normals_orientation.cpp): a
// 8-ary min-heap with decrease-key, holding each point at most once.
//
// Why not std::priority_queue with lazy deletion: on a k-NN graph weighted by normal agreement,
// Prim's frontier is a large part of the cloud (cheap edges on flat ground are taken anywhere
// along it), and lazy deletion left ~4.7 entries per point, each popped with a full sift-down
// through a heap larger than the cache. Decrease-key keeps one entry per point; eight children
// per node take a third of a binary heap's depth, and the eight keys compared at each level
// are one cache line's worth. autzen's orientation (normals_bench, two interleaved runs each):
// 8.60-8.63 s with four children, 7.85-7.97 with eight, 8.52-8.78 with sixteen. The pop order,
// and so the tree, is the same for any number: every key is distinct.
//
// Keys pack (cost, point) into one 64-bit word: a non-negative float's bits order like the float,
// so one integer comparison orders by cost and then by point index, which makes the tree unique.
#pragma once

#include <bit>
#include <cstdint>
#include <limits>
#include <vector>

namespace sspc::detail {

class PrimHeap {
 public:
  static constexpr std::uint32_t kUnseen = std::numeric_limits<std::uint32_t>::max();
  static constexpr std::uint32_t kDone = kUnseen - 1;
  static constexpr std::uint32_t kArity = 8;

  explicit PrimHeap(std::size_t points) : slot_(points, kUnseen) {}

  // `cost` must be ≥ +0.0 (not -0.0, not NaN).
  static std::uint64_t key(float cost, std::uint32_t point) {
    return (std::uint64_t{std::bit_cast<std::uint32_t>(cost)} << 32) | point;
  }
  static std::uint32_t point_of(std::uint64_t key) { return static_cast<std::uint32_t>(key); }

  bool empty() const { return heap_.empty(); }
  bool done(std::uint32_t point) const { return slot_[point] == kDone; }

  // A hint that `point` (and `extra`, its caller-side data) will be looked at soon.
  void prefetch(std::uint32_t point, const void* extra) const {
    __builtin_prefetch(slot_.data() + point);
    __builtin_prefetch(extra);
  }

  // Inserts `point` or lowers its key; returns false (and changes nothing) when the point is
  // done or already queued with a key ≤ the new one.
  bool push_or_decrease(float cost, std::uint32_t point) {
    const std::uint64_t k = key(cost, point);
    std::uint32_t i = slot_[point];
    if (i == kDone) return false;
    if (i == kUnseen) {
      i = static_cast<std::uint32_t>(heap_.size());
      heap_.push_back(k);
    } else if (heap_[i] <= k) {
      return false;
    }
    sift_up(i, k);
    return true;
  }

  // Removes and returns the smallest key's point, marking it done.
  std::uint32_t pop() {
    const std::uint32_t top = point_of(heap_.front());
    slot_[top] = kDone;
    const std::uint64_t last = heap_.back();
    heap_.pop_back();
    if (!heap_.empty()) sift_down(0, last);
    return top;
  }

 private:
  void place(std::uint32_t i, std::uint64_t k) {
    heap_[i] = k;
    slot_[point_of(k)] = i;
  }

  void sift_up(std::uint32_t i, std::uint64_t k) {
    while (i > 0) {
      const std::uint32_t parent = (i - 1) / kArity;
      if (heap_[parent] <= k) break;
      place(i, heap_[parent]);
      i = parent;
    }
    place(i, k);
  }

  void sift_down(std::uint32_t i, std::uint64_t k) {
    const std::size_t n = heap_.size();
    for (;;) {
      const std::size_t first = std::size_t{kArity} * i + 1;
      if (first >= n) break;
      const std::size_t end = first + kArity < n ? first + kArity : n;
      std::size_t best = first;
      for (std::size_t c = first + 1; c < end; ++c) {
        if (heap_[c] < heap_[best]) best = c;
      }
      if (heap_[best] >= k) break;
      place(i, heap_[best]);
      i = static_cast<std::uint32_t>(best);
    }
    place(i, k);
  }

  std::vector<std::uint64_t> heap_;
  std::vector<std::uint32_t> slot_;  // per point: its heap index, kUnseen or kDone
};

}  // namespace sspc::detail
