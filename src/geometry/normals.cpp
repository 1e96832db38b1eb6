// The normals API: argument checks, the k-NN search shared by the PCA and the orientation, and
// the keep / estimate / auto policy. The algorithms live in normals_pca.cpp (Hoppe 1992 §3.2)
// and normals_orientation.cpp (Hoppe 1992 §3.3).
#include "sspc/normals.hpp"

#include <algorithm>
#include <string>

#include "core/parallel.hpp"
#include "geometry/distinct_positions.hpp"
#include "geometry/normals_steps.hpp"
#include "sspc/neighbours.hpp"

namespace sspc {

namespace {

constexpr int kMinNeighbours = 3;
constexpr int kMaxNeighbours = 256;

Status check_options(const PointCloud& cloud, const NormalOptions& options) {
  if (options.k < kMinNeighbours || options.k > kMaxNeighbours) {
    return invalid_argument("normals: k must be in [" + std::to_string(kMinNeighbours) + ", " +
                            std::to_string(kMaxNeighbours) + "], got " + std::to_string(options.k));
  }
  if (cloud.size() < 3) {
    return invalid_argument("normals: estimating normals needs at least 3 points, the cloud has " +
                            std::to_string(cloud.size()));
  }
  if (cloud.size() > std::size_t{0xFFFFFFFFu}) {
    return resource_exhausted("normals: more than 2^32 - 1 points");
  }
  // Before any search: at scales float32 cannot square, every distance is 0 or infinite, and
  // the neighbour search degenerates (every point ties with every other).
  return check_coordinate_range(cloud.positions);
}

// Each point's k nearest neighbours, itself included (it is part of its own neighbourhood for
// the PCA, and its self-edge is harmless to the spanning tree).
KnnTable neighbourhoods(const PointCloud& cloud, const NormalOptions& options, const KdTree3* tree = nullptr) {
  progress_begin(options.progress, "normals: neighbours", cloud.size());
  const std::size_t k = std::min(static_cast<std::size_t>(options.k), cloud.size());
  // Indices only: PCA and the orientation need no distances (10.6M points: 0.68 of 1.4 GB).
  KnnTable table = knn_of_own_points(cloud.positions, k, options.progress, false, tree);
  progress_end(options.progress);
  return table;
}

void run_pca(PointCloud& cloud, const KnnTable& table, Progress* progress) {
  cloud.normals.resize(cloud.size());
  progress_begin(progress, "normals: PCA", cloud.size());
  detail::estimate_normals_pca(cloud.positions, table, cloud.normals, progress);
  progress_end(progress);
}

void run_mst(PointCloud& cloud, const KnnTable& table, Progress* progress) {
  progress_begin(progress, "normals: orient", cloud.size());
  detail::orient_normals_mst(cloud.positions, table, cloud.normals, progress);
  progress_end(progress);
}

}  // namespace

Status estimate_normals(PointCloud& cloud, const NormalOptions& options) {
  if (Status s = check_options(cloud, options); !s.ok()) return s;
  const KnnTable table = neighbourhoods(cloud, options);
  run_pca(cloud, table, options.progress);
  return {};
}

Status orient_normals(PointCloud& cloud, const NormalOptions& options) {
  if (!cloud.has_normals() || cloud.normals.size() != cloud.size()) {
    return invalid_argument("normals: orienting normals needs a cloud with normals");
  }
  if (options.viewpoint) {
    detail::orient_normals_towards(cloud.positions, *options.viewpoint, cloud.normals);
    return {};
  }
  if (Status s = check_options(cloud, options); !s.ok()) return s;
  const KnnTable table = neighbourhoods(cloud, options);
  run_mst(cloud, table, options.progress);
  return {};
}

Status ensure_normals(PointCloud& cloud, const NormalOptions& options) {
  return detail::ensure_normals(cloud, options, nullptr, nullptr);
}

Status detail::ensure_normals(PointCloud& cloud, const NormalOptions& options, KnnTable* searched,
                              const KdTree3* tree, const std::function<void()>& alongside) {
  const auto then_alongside = [&]() -> Status {
    if (alongside) alongside();
    return {};
  };
  switch (options.mode) {
    case NormalMode::kKeep:
      if (!cloud.has_normals()) {
        return invalid_argument(
            "normals: mode 'keep' needs normals in the input, and this cloud has none "
            "(use 'estimate' or 'auto' to compute them)");
      }
      return then_alongside();
    case NormalMode::kAuto:
      if (cloud.has_normals()) return then_alongside();
      break;
    case NormalMode::kEstimate: break;
  }
  if (Status s = check_options(cloud, options); !s.ok()) return s;
  // One k-NN search serves both steps.
  KnnTable table = neighbourhoods(cloud, options, tree);
  run_pca(cloud, table, options.progress);
  if (options.viewpoint) {
    detail::orient_normals_towards(cloud.positions, *options.viewpoint, cloud.normals);
    if (alongside) alongside();  // after: the viewpoint's orientation is parallel already
  } else if (alongside) {
    // Prim's algorithm is sequential: the other core takes `alongside` meanwhile.
    parallel_invoke([&] { run_mst(cloud, table, options.progress); }, alongside);
  } else {
    run_mst(cloud, table, options.progress);
  }
  if (searched != nullptr) *searched = std::move(table);
  return {};
}

}  // namespace sspc
