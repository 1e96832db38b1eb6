// KdTree3: sspc's one neighbour-search structure, a thin layer over nanoflann's static k-d tree.
//
// nanoflann gives single-query k-NN and radius search; this file adds what every caller would
// otherwise repeat: parallel batched k-NN with self-exclusion, and the nominal spacing.
#include <algorithm>
#include <cmath>
#include <cstdint>

#include <nanoflann.hpp>

#include "core/parallel.hpp"
#include "sspc/neighbors.hpp"

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
  return impl_->tree.knnSearch(query.data(), k, indices, distances_squared);
}

std::size_t KdTree3::knn(const Vec3f& query, std::size_t k, std::vector<Neighbor>& out) const {
  out.clear();
  if (k == 0 || points_.empty()) return 0;
  k = std::min(k, points_.size());
  std::vector<std::uint32_t> idx(k);
  std::vector<float> d2(k);
  const std::size_t n = impl_->tree.knnSearch(query.data(), k, idx.data(), d2.data());
  out.reserve(n);
  for (std::size_t i = 0; i < n; ++i) out.push_back({idx[i], d2[i]});
  return n;
}

std::uint32_t KdTree3::nearest(const Vec3f& query, float* distance_squared) const {
  std::uint32_t index = 0;
  float d2 = 0;
  impl_->tree.knnSearch(query.data(), 1, &index, &d2);
  if (distance_squared != nullptr) *distance_squared = d2;
  return index;
}

std::size_t KdTree3::radius(const Vec3f& query, float r, std::vector<Neighbor>& out,
                            bool sorted) const {
  out.clear();
  if (points_.empty() || !(r >= 0)) return 0;
  std::vector<std::pair<std::uint32_t, float>> matches;
  nanoflann::SearchParams params;
  params.sorted = sorted;
  impl_->tree.radiusSearch(query.data(), r * r, matches, params);
  out.reserve(matches.size());
  for (const auto& [i, d2] : matches) out.push_back({i, d2});
  if (sorted) {
    // nanoflann sorts by distance only; break ties by index so results are reproducible.
    std::stable_sort(out.begin(), out.end(), [](const Neighbor& a, const Neighbor& b) {
      return a.distance_squared < b.distance_squared ||
             (a.distance_squared == b.distance_squared && a.index < b.index);
    });
  }
  return out.size();
}

KnnTable KdTree3::knn_batch(std::span<const Vec3f> queries, std::size_t k,
                            bool exclude_self) const {
  KnnTable table;
  table.k = k;
  table.indices.assign(queries.size() * k, 0);
  table.distances_squared.assign(queries.size() * k, 0.0f);
  table.count.assign(queries.size(), 0);
  if (k == 0 || points_.empty()) return table;
  const std::size_t ask = std::min(k + (exclude_self ? 1 : 0), points_.size());
  parallel_for_ranges(0, queries.size(), 256, [&](std::size_t begin, std::size_t end) {
    std::vector<std::uint32_t> idx(ask);
    std::vector<float> d2(ask);
    for (std::size_t q = begin; q < end; ++q) {
      const std::size_t found = impl_->tree.knnSearch(queries[q].data(), ask, idx.data(), d2.data());
      std::uint32_t* out_i = table.indices.data() + q * k;
      float* out_d = table.distances_squared.data() + q * k;
      std::size_t n = 0;
      for (std::size_t j = 0; j < found && n < k; ++j) {
        if (exclude_self && idx[j] == q) continue;
        out_i[n] = idx[j];
        out_d[n] = d2[j];
        ++n;
      }
      table.count[q] = static_cast<std::uint32_t>(n);
    }
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
  parallel_for(0, count, 64, [&](std::size_t s) {
    const std::size_t i = s * n / count;  // s < count ≤ 2^32 keeps the product in range
    std::uint32_t idx[2];
    float d2[2];
    const std::size_t found = tree.knn(tree.points()[i], 2, idx, d2);
    // The first hit is the point itself, unless duplicates tie with it; either way the second
    // distance is the nearest other sample (0 for exact duplicates).
    nearest[s] = found == 2 ? std::sqrt(d2[1]) : 0.0f;
  });
  auto mid = nearest.begin() + static_cast<std::ptrdiff_t>(count / 2);
  std::nth_element(nearest.begin(), mid, nearest.end());
  return static_cast<double>(*mid);
}

double nominal_spacing(const PointCloud& cloud, std::size_t samples) {
  if (cloud.size() < 2) return 0.0;
  const KdTree3 tree(cloud.positions);
  return nominal_spacing(tree, samples);
}

}  // namespace sspc
