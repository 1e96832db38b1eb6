// KdTreeL1: L1 (Manhattan) neighbour search over descriptor vectors of runtime dimension, over
// nanoflann's k-d tree. The code book (Hubo et al. 2007, §4.3) compares
// patch descriptors, cumulative histograms, with the L1 distance, a 1-D earth mover's distance.
//
// nanoflann's L1_Adaptor sums in groups of four, so its distances can differ in the last bit
// from a plain loop; this file plugs in its own metric, l1_distance, so that the tree's answer
// and a caller's own comparison against ε always agree.
#include <algorithm>
#include <cmath>
#include <limits>

#include <nanoflann.hpp>

#include "geometry/knn_result_set.hpp"
#include "sspc/neighbours.hpp"

namespace sspc {

float l1_distance(const float* a, const float* b, std::size_t dimension) {
  float sum = 0;
  for (std::size_t i = 0; i < dimension; ++i) sum += std::abs(a[i] - b[i]);
  return sum;
}

namespace {

struct RowsAdaptor {
  const float* data;
  std::size_t dimension;
  std::size_t rows;
  std::size_t kdtree_get_point_count() const { return rows; }
  float kdtree_get_pt(std::size_t i, std::size_t d) const { return data[i * dimension + d]; }
  template <class Box>
  bool kdtree_get_bbox(Box& /*box*/) const {
    return false;
  }
};

// The metric interface nanoflann expects: a whole-vector distance and the per-coordinate
// contribution it uses to bound the distance to a cell (|a − b| is a valid lower bound in L1).
struct L1Metric {
  using ElementType = float;
  using DistanceType = float;
  const RowsAdaptor& source;
  explicit L1Metric(const RowsAdaptor& rows) : source(rows) {}
  float evalMetric(const float* a, std::uint32_t b, std::size_t size, float /*worst*/ = -1) const {
    return l1_distance(a, source.data + static_cast<std::size_t>(b) * source.dimension, size);
  }
  template <typename U, typename V>
  float accum_dist(U a, V b, std::size_t /*dim*/) const {
    return std::abs(a - b);
  }
};

using L1Tree = nanoflann::KDTreeSingleIndexAdaptor<L1Metric, RowsAdaptor, -1, std::uint32_t>;

// Collects items with distance ≤ radius; searches a slightly larger ball because nanoflann's
// cell bounds, summed in another order, can round a few ulps above the exact distance.
class L1RadiusResultSet {
 public:
  L1RadiusResultSet(float radius, std::vector<L1Neighbour>& out)
      : radius_(radius),
        search_bound_(
            std::nextafter(radius + radius * 1e-4f, std::numeric_limits<float>::infinity())),
        out_(out) {}
  std::size_t size() const { return out_.size(); }
  bool full() const { return true; }
  bool addPoint(float distance, std::uint32_t index) {
    if (distance <= radius_) out_.push_back({index, distance});
    return true;
  }
  float worstDist() const { return search_bound_; }

 private:
  float radius_;
  float search_bound_;
  std::vector<L1Neighbour>& out_;
};

}  // namespace

struct KdTreeL1::Impl {
  RowsAdaptor adaptor;
  L1Tree tree;
  Impl(const float* data, std::size_t dimension, std::size_t rows, std::size_t leaf_size)
      : adaptor{data, dimension, rows},
        tree(static_cast<int>(dimension), adaptor,
             nanoflann::KDTreeSingleIndexAdaptorParams(leaf_size)) {}
};

KdTreeL1::KdTreeL1(std::span<const float> data, std::size_t dimension, std::size_t leaf_size)
    : data_(data),
      dimension_(std::max<std::size_t>(dimension, 1)),
      rows_(data.size() / dimension_),
      impl_(std::make_unique<Impl>(data.data(), dimension_, rows_,
                                   std::max<std::size_t>(leaf_size, 1))) {}

KdTreeL1::~KdTreeL1() = default;
KdTreeL1::KdTreeL1(KdTreeL1&&) noexcept = default;
KdTreeL1& KdTreeL1::operator=(KdTreeL1&&) noexcept = default;

std::size_t KdTreeL1::radius(std::span<const float> query, float r,
                             std::vector<L1Neighbour>& out) const {
  out.clear();
  if (rows_ == 0 || !(r >= 0) || query.size() < dimension_) return 0;
  L1RadiusResultSet result(r, out);
  impl_->tree.findNeighbors(result, query.data(), nanoflann::SearchParams());
  std::sort(out.begin(), out.end(), [](const L1Neighbour& a, const L1Neighbour& b) {
    return a.distance < b.distance || (a.distance == b.distance && a.index < b.index);
  });
  return out.size();
}

std::size_t KdTreeL1::knn(std::span<const float> query, std::size_t k,
                          std::vector<L1Neighbour>& out) const {
  out.clear();
  if (rows_ == 0 || k == 0 || query.size() < dimension_) return 0;
  k = std::min(k, rows_);
  std::vector<std::uint32_t> indices(k);
  std::vector<float> distances(k);
  detail::CanonicalKnnResultSet<float> result(k, indices.data(), distances.data());
  impl_->tree.findNeighbors(result, query.data(), nanoflann::SearchParams());
  out.resize(result.size());
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = {indices[i], distances[i]};
  return out.size();
}

}  // namespace sspc
