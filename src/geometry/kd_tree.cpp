// KdTree3: sspc's one neighbour-search structure, a thin layer over nanoflann's static k-d tree.
//
// nanoflann gives single-query k-NN and radius search; this file adds what every caller would
// otherwise repeat: answers that do not depend on the tree's shape (ties broken by index, the
// radius inclusive), parallel batched k-NN with self-exclusion, and the nominal spacing.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>

#include <nanoflann.hpp>

#include "core/parallel.hpp"
#include "geometry/distinct_positions.hpp"
#include "geometry/knn_result_set.hpp"
#include "sspc/neighbours.hpp"

namespace sspc {

namespace {

struct PointsAdaptor {
  std::span<const Vec3f> points;
  std::size_t kdtree_get_point_count() const { return points.size(); }
  float kdtree_get_pt(std::size_t i, std::size_t dim) const {
    return points[i][static_cast<Eigen::Index>(dim)];
  }
  template <class Box>
  bool kdtree_get_bbox(Box& /*box*/) const {
    return false;
  }
};

using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, PointsAdaptor>,
                                                 PointsAdaptor, 3, std::uint32_t>;

// Collects the points with squared distance ≤ r² exactly. nanoflann's own radius set keeps
// d² < r² and may prune a few ulps early, so it searches a slightly larger ball and this set
// applies the exact test, the same one a brute-force scan makes.
// With `out` null it only counts them: what radius_count needs, without storing a neighbour a
// point (a patch-radius estimate at 16,384 points a patch stored 33M of them; under the
// sanitizers growing the vectors was a fifth of encoding a small cloud at level 9).
class InclusiveRadiusResultSet {
 public:
  InclusiveRadiusResultSet(float radius_squared, std::vector<Neighbour>* out)
      : radius_squared_(radius_squared),
        search_bound_(std::nextafter(radius_squared + radius_squared * 1e-5f,
                                     std::numeric_limits<float>::infinity())),
        out_(out) {}
  std::size_t size() const { return count_; }
  bool full() const { return true; }
  bool addPoint(float distance_squared, std::uint32_t index) {
    if (distance_squared <= radius_squared_) {
      ++count_;
      if (out_ != nullptr) out_->push_back({index, distance_squared});
    }
    return true;
  }
  float worstDist() const { return search_bound_; }

 private:
  float radius_squared_;
  float search_bound_;
  std::vector<Neighbour>* out_;
  std::size_t count_ = 0;
};

bool neighbour_before(const Neighbour& a, const Neighbour& b) {
  return a.distance_squared < b.distance_squared ||
         (a.distance_squared == b.distance_squared && a.index < b.index);
}

}  // namespace

struct KdTree3::Impl {
  PointsAdaptor adaptor;
  Tree tree;
  Impl(std::span<const Vec3f> points, std::size_t leaf_size)
      : adaptor{points}, tree(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(leaf_size)) {}
};

KdTree3::KdTree3(std::span<const Vec3f> points, std::size_t leaf_size)
    : points_(points), impl_(std::make_unique<Impl>(points, std::max<std::size_t>(leaf_size, 1))) {}

KdTree3::~KdTree3() = default;
KdTree3::KdTree3(KdTree3&&) noexcept = default;
KdTree3& KdTree3::operator=(KdTree3&&) noexcept = default;

std::size_t KdTree3::knn(const Vec3f& query, std::size_t k, std::uint32_t* indices,
                         float* distances_squared) const {
  if (k == 0 || points_.empty()) return 0;
  k = std::min(k, points_.size());
  detail::CanonicalKnnResultSet<float> result(k, indices, distances_squared);
  impl_->tree.findNeighbors(result, query.data(), nanoflann::SearchParams());
  return result.size();
}

std::size_t KdTree3::knn(const Vec3f& query, std::size_t k, std::vector<Neighbour>& out) const {
  out.clear();
  if (k == 0 || points_.empty()) return 0;
  k = std::min(k, points_.size());
  std::vector<std::uint32_t> idx(k);
  std::vector<float> d2(k);
  const std::size_t n = knn(query, k, idx.data(), d2.data());
  out.reserve(n);
  for (std::size_t i = 0; i < n; ++i) out.push_back({idx[i], d2[i]});
  return n;
}

std::uint32_t KdTree3::nearest(const Vec3f& query, float* distance_squared) const {
  std::uint32_t index = 0;
  float d2 = 0;
  knn(query, 1, &index, &d2);
  if (distance_squared != nullptr) *distance_squared = d2;
  return index;
}

std::size_t KdTree3::radius(const Vec3f& query, float r, std::vector<Neighbour>& out,
                            bool sorted) const {
  out.clear();
  if (points_.empty() || !(r >= 0)) return 0;
  InclusiveRadiusResultSet result(r * r, &out);
  impl_->tree.findNeighbors(result, query.data(), nanoflann::SearchParams());
  // Sorted by distance, then index, so that results are reproducible.
  if (sorted) std::sort(out.begin(), out.end(), neighbour_before);
  return out.size();
}

std::size_t KdTree3::radius_count(const Vec3f& query, float r) const {
  if (points_.empty() || !(r >= 0)) return 0;
  InclusiveRadiusResultSet result(r * r, nullptr);
  impl_->tree.findNeighbors(result, query.data(), nanoflann::SearchParams());
  return result.size();
}

KnnTable KdTree3::knn_batch(std::span<const Vec3f> queries, std::size_t k, bool exclude_self,
                            Progress* progress, bool distances) const {
  KnnTable table;
  table.k = k;
  table.indices.assign(queries.size() * k, 0);
  if (distances) table.distances_squared.assign(queries.size() * k, 0.0f);
  table.count.assign(queries.size(), 0);
  if (k == 0 || points_.empty()) return table;
  const std::size_t ask = std::min(k + (exclude_self ? 1 : 0), points_.size());
  // When the queries are the tree's own points, answer them in the order the leaves store them:
  // consecutive queries then walk the same nodes and leaves, three times as fast on a cloud in
  // random order. Each row is still written at its query's index, so the table is the same.
  const bool own_points = queries.data() == points_.data() && queries.size() == points_.size();
  const std::vector<std::uint32_t>& leaf_order = impl_->tree.vAcc;
  parallel_for_ranges(0, queries.size(), 256, [&](std::size_t begin, std::size_t end) {
    std::vector<std::uint32_t> idx(ask);
    std::vector<float> d2(ask);
    for (std::size_t r = begin; r < end; ++r) {
      const std::size_t q = own_points ? leaf_order[r] : r;
      const std::size_t found = knn(queries[q], ask, idx.data(), d2.data());
      std::uint32_t* out_i = table.indices.data() + q * k;
      float* out_d = distances ? table.distances_squared.data() + q * k : nullptr;
      std::size_t n = 0;
      for (std::size_t j = 0; j < found && n < k; ++j) {
        if (exclude_self && idx[j] == q) continue;
        out_i[n] = idx[j];
        if (out_d != nullptr) out_d[n] = d2[j];
        ++n;
      }
      table.count[q] = static_cast<std::uint32_t>(n);
    }
    progress_advance(progress, end - begin);
  });
  return table;
}

double nominal_spacing(const KdTree3& tree, std::size_t samples) {
  const std::size_t n = tree.size();
  if (n < 2 || samples == 0) return 0.0;
  const std::size_t count = std::min({samples, n, std::size_t{1} << 24});
  // Evenly strided sample: deterministic, and spread over the file's order (scanner order is
  // usually spatially coherent, so a stride covers the whole object).
  std::vector<float> nearest(count, 0.0f);
  std::atomic<bool> coincident{false};
  parallel_for(0, count, 64, [&](std::size_t s) {
    const std::size_t i = s * n / count;  // s < count ≤ 2^32 keeps the product in range
    std::uint32_t idx[2];
    float d2[2];
    const std::size_t found = tree.knn(tree.points()[i], 2, idx, d2);
    nearest[s] = found == 2 ? std::sqrt(d2[1]) : 0.0f;
    if (nearest[s] == 0.0f) coincident.store(true, std::memory_order_relaxed);
  });
  if (coincident) {
    // A sampled point shares its position with another: a median over points would count
    // duplicates as zero distances (0 when most points are doubled, and every step derived from
    // it stops moving). The spacing is that of the distinct positions.
    // (No position repeats when the squared distance underflowed instead: that median stands.)
    const DistinctPositions distinct(tree.points());
    if (distinct.gathered()) {
      if (distinct.positions().size() < 2) return 0.0;
      const KdTree3 positions(distinct.positions());
      return nominal_spacing(positions, samples);
    }
  }
  auto mid = nearest.begin() + static_cast<std::ptrdiff_t>(count / 2);
  std::nth_element(nearest.begin(), mid, nearest.end());
  return static_cast<double>(*mid);
}

double nominal_spacing(const PointCloud& cloud, std::size_t samples) {
  if (cloud.size() < 2) return 0.0;
  const KdTree3 tree(cloud.positions);
  return nominal_spacing(tree, samples);
}

namespace {

struct Extent {
  double largest = 0;  // the largest |coordinate|
  double side = 0;     // the bounding box's longest side
};

Extent measure_extent(std::span<const Vec3f> positions) {
  Vec3d lo = Vec3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  double largest = 0;
  for (const Vec3f& p : positions) {
    const Vec3d q = p.cast<double>();
    largest = std::max(largest, q.cwiseAbs().maxCoeff());
    lo = lo.cwiseMin(q);
    hi = hi.cwiseMax(q);
  }
  return {largest, positions.empty() ? 0.0 : (hi - lo).maxCoeff()};
}

Status spacing_too_small(double spacing) {
  char text[256];
  std::snprintf(text, sizeof text,
                "the point spacing is %.3g: sspc computes in float32 and needs at least %.0e (squared distances "
                "would underflow); scale the cloud up (to metres, say)",
                spacing, kMinSpacing);
  return invalid_argument(text);
}

}  // namespace

namespace {

// The spacing-free checks, on an extent already measured.
Status check_extent(const Extent& e) {
  if (e.largest > kMaxCoordinate) {
    char text[256];
    std::snprintf(text, sizeof text,
                  "coordinates reach %.3g: sspc computes in float32 and needs every |coordinate| at most %.0e "
                  "(squared distances would overflow); remove the outliers or subtract an origin",
                  e.largest, kMaxCoordinate);
    return invalid_argument(text);
  }
  // The spacing is at most the extent: a cloud this small has a spacing below the limit.
  if (e.side > 0 && e.side < kMinSpacing) {
    char text[256];
    std::snprintf(text, sizeof text,
                  "the cloud spans only %.3g: sspc computes in float32 and needs a point spacing of at least %.0e "
                  "(squared distances would underflow); scale the cloud up (to metres, say)",
                  e.side, kMinSpacing);
    return invalid_argument(text);
  }
  return Status();
}

}  // namespace

Status check_coordinate_range(std::span<const Vec3f> positions) {
  return check_extent(measure_extent(positions));
}

Status check_geometry_range(std::span<const Vec3f> positions, double spacing) {
  const Extent e = measure_extent(positions);  // one pass over the points for both checks
  SSPC_RETURN_IF_ERROR(check_extent(e));
  if (e.side == 0) return invalid_argument("all points coincide");
  if (!(spacing >= kMinSpacing)) return spacing_too_small(spacing);
  if (e.side > kMaxExtentInSpacings * spacing) {
    char text[320];
    std::snprintf(text, sizeof text,
                  "the cloud spans %.3g along an axis but its points are %.3g apart: %.3g spacings, more than "
                  "float32 resolves (%.0f); remove the outliers far from the rest, or split the cloud",
                  e.side, spacing, e.side / spacing, kMaxExtentInSpacings);
    return invalid_argument(text);
  }
  return Status();
}

}  // namespace sspc
