// A k-nearest result set for nanoflann whose answer does not depend on the tree's shape.
//
// nanoflann's own KNNResultSet keeps whichever of two equidistant points it meets first, so the
// k-th neighbour among ties depends on leaf size and build order. This one keeps the k smallest
// (distance, index) pairs: among equal distances the lower index wins, always, which makes every
// k-NN answer in sspc reproducible and equal to a brute-force scan.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>

namespace sspc::detail {

template <typename Distance>
class CanonicalKnnResultSet {
 public:
  CanonicalKnnResultSet(std::size_t k, std::uint32_t* indices, Distance* distances)
      : k_(k), indices_(indices), distances_(distances) {}

  std::size_t size() const { return count_; }
  bool full() const { return count_ == k_; }

  // nanoflann offers a point only when its distance is below worstDist(); ties with the current
  // k-th are let through (see worstDist) and settled here by index.
  bool addPoint(Distance distance, std::uint32_t index) {
    if (full() && !before(distance, index, distances_[k_ - 1], indices_[k_ - 1])) return true;
    std::size_t i = full() ? k_ - 1 : count_++;
    while (i > 0 && before(distance, index, distances_[i - 1], indices_[i - 1])) {
      distances_[i] = distances_[i - 1];
      indices_[i] = indices_[i - 1];
      --i;
    }
    distances_[i] = distance;
    indices_[i] = index;
    if (full()) bound_ = loosen(distances_[k_ - 1]);
    return true;
  }

  // Slightly above the k-th distance: nanoflann prunes a subtree whose lower bound is above
  // this and skips a leaf point not strictly below it, and its incrementally updated lower
  // bounds can round a few ulps high. The slack keeps equidistant candidates in play.
  Distance worstDist() const { return bound_; }

 private:
  static bool before(Distance da, std::uint32_t ia, Distance db, std::uint32_t ib) {
    return da < db || (da == db && ia < ib);
  }
  // At least the next value above d + d·1e-5 (0 gives the smallest subnormal), without a call
  // to nextafter, which was 1.8% of an encode's time (it runs on every point a full set takes).
  // No subnormal enters the arithmetic (slow on x86): squared distances this side of zero are
  // 0 or far above the smallest normal (kMinSpacing).
  static Distance loosen(Distance d) {
    return d > 0 ? d + d * Distance(2e-5) : std::numeric_limits<Distance>::denorm_min();
  }

  std::size_t k_;
  std::uint32_t* indices_;
  Distance* distances_;
  std::size_t count_ = 0;
  Distance bound_ = std::numeric_limits<Distance>::infinity();
};

}  // namespace sspc::detail
