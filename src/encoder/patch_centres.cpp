// Patch centres: Poisson-disk start, repulsion and feature attraction, coverage repair
// (Hubo et al. 2007, §4.1; Turk 1992 "Re-tiling polygonal surfaces" for the repulsion, Pauly
// et al. 2002 for centres spread over a point-sampled surface).
#include "encoder/patch_centres.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "core/parallel.hpp"
#include "encoder/spatial_order.hpp"
#include "sspc/synthetic.hpp"

namespace sspc::codec {

namespace {

// A hash grid of cell 2R over the centres chosen so far: the ball of radius R about any point
// meets at most 2x2x2 cells, the ones on the point's side of its cell's middle. Asked eight
// times for every input point, one after another (the Poisson-disk start is sequential), so it
// is a flat table with linear probing and each cell's centres a linked list through one array:
// autzen's start took 3.3 s with std::unordered_map's node per cell and vector per node.
class CentreGrid {
 public:
  CentreGrid(float radius, const Vec3f& origin)
      : radius_(radius), cell_(2 * radius), origin_(origin), slots_(1024, kNone) {}

  bool covered(const Vec3f& p) const {
    const float r2 = radius_ * radius_;
    Eigen::Vector3i base;
    for (int a = 0; a < 3; ++a) {
      const float u = (p[a] - origin_[a]) / cell_;
      const float f = std::floor(u);
      base[a] = static_cast<int>(f) - (u - f < 0.5f ? 1 : 0);
    }
    for (int dx = 0; dx < 2; ++dx)
      for (int dy = 0; dy < 2; ++dy)
        for (int dz = 0; dz < 2; ++dz) {
          const std::uint32_t cell = find(key(base.x() + dx, base.y() + dy, base.z() + dz));
          if (cell == kNone) continue;
          for (std::uint32_t c = head_[cell]; c != kNone; c = next_[c]) {
            if ((centres_[c] - p).squaredNorm() <= r2) return true;
          }
        }
    return false;
  }

  void add(const Vec3f& p) {
    Eigen::Vector3i at;
    for (int a = 0; a < 3; ++a) at[a] = static_cast<int>(std::floor((p[a] - origin_[a]) / cell_));
    const std::uint64_t k = key(at.x(), at.y(), at.z());
    std::uint32_t cell = find(k);
    if (cell == kNone) {
      if (2 * (keys_.size() + 1) > slots_.size()) grow();
      cell = static_cast<std::uint32_t>(keys_.size());
      keys_.push_back(k);
      head_.push_back(kNone);
      insert(cell);
    }
    next_.push_back(head_[cell]);
    head_[cell] = static_cast<std::uint32_t>(centres_.size());
    centres_.push_back(p);
  }

 private:
  static constexpr std::uint32_t kNone = 0xFFFFFFFFu;

  static std::uint64_t key(int x, int y, int z) {
    const auto u = [](int v) { return static_cast<std::uint64_t>(static_cast<std::uint32_t>(v) & 0x1FFFFFu); };
    return (u(x) << 42) | (u(y) << 21) | u(z);
  }
  std::size_t slot_of(std::uint64_t k) const {
    k ^= k >> 29;
    k *= 0xBF58476D1CE4E5B9ull;
    return static_cast<std::size_t>(k ^ (k >> 32)) & (slots_.size() - 1);
  }
  std::uint32_t find(std::uint64_t k) const {
    for (std::size_t s = slot_of(k);; s = (s + 1) & (slots_.size() - 1)) {
      const std::uint32_t cell = slots_[s];
      if (cell == kNone || keys_[cell] == k) return cell;
    }
  }
  void insert(std::uint32_t cell) {
    std::size_t s = slot_of(keys_[cell]);
    while (slots_[s] != kNone) s = (s + 1) & (slots_.size() - 1);
    slots_[s] = cell;
  }
  void grow() {
    slots_.assign(2 * slots_.size(), kNone);
    for (std::uint32_t cell = 0; cell < keys_.size(); ++cell) insert(cell);
  }

  float radius_;
  float cell_;
  Vec3f origin_;
  std::vector<std::uint32_t> slots_;  // a cell number, or kNone
  std::vector<std::uint64_t> keys_;   // each cell's key
  std::vector<std::uint32_t> head_;   // each cell's last centre added
  std::vector<std::uint32_t> next_;   // each centre's predecessor in its cell
  std::vector<Vec3f> centres_;
};

// The tangent plane of the nearest input point: keeps centres on the surface.
Vec3f project_to_surface(const Vec3f& c, const PointCloud& cloud, const KdTree3& tree) {
  float d2 = 0;
  const std::uint32_t i = tree.nearest(c, &d2);
  const Vec3f& p = cloud.positions[i];
  const Vec3f& n = cloud.normals[i];
  return c - (c - p).dot(n) * n;
}

// A seeded random permutation (Fisher–Yates over SplitMix64).
std::vector<std::uint32_t> random_order(std::size_t n, std::uint64_t seed) {
  std::vector<std::uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  synthetic::Rng rng(seed);
  for (std::size_t i = n; i > 1; --i) {
    const std::size_t j = static_cast<std::size_t>(rng.next_u64() % i);
    std::swap(order[i - 1], order[j]);
  }
  return order;
}

void repulse(std::vector<Vec3f>& centres, float radius, const PointCloud& cloud, const KdTree3& tree) {
  const KdTree3 centre_tree(centres);
  std::vector<Vec3f> moved(centres.size());
  parallel_for_ranges(0, centres.size(), 256, [&](std::size_t begin, std::size_t end) {
    std::vector<Neighbour> near;
    for (std::size_t k = begin; k < end; ++k) {
      const Vec3f c = centres[k];
      centre_tree.radius(c, radius, near);
      Vec3f push = Vec3f::Zero();
      for (const Neighbour& nb : near) {
        if (nb.index == k) continue;
        const float d = std::sqrt(nb.distance_squared);
        if (d <= 0) continue;
        push += (c - centres[nb.index]) * ((radius - d) / (d * radius));
      }
      // A quarter of the overlap per round: firm enough to spread, gentle enough not to
      // oscillate between neighbours.
      moved[k] = project_to_surface(c + 0.25f * radius * push, cloud, tree);
    }
  });
  centres = std::move(moved);
}

}  // namespace

// C_p: how much the normals around p disagree; large on creases and ridges.
void feature_strength(const PointCloud& cloud, const KnnTable& neighbours, std::span<float> strength) {
  parallel_for(0, cloud.size(), 4096, [&](std::size_t p) {
    strength[p] = 0.0f;
    double sum = 0, sum2 = 0;
    std::size_t n = 0;
    for (const std::uint32_t q : neighbours.row(p)) {
      if (q == p) continue;
      const auto d = static_cast<double>(cloud.normals[p].dot(cloud.normals[q]));
      sum += d;
      sum2 += d * d;
      if (++n == kFeatureNeighbours) break;
    }
    if (n == 0) return;
    const auto count = static_cast<double>(n);
    const double mean = sum / count;
    strength[p] = static_cast<float>(std::sqrt(std::max(0.0, sum2 / count - mean * mean)));
  });
}

namespace {

void attract(std::vector<Vec3f>& centres, float radius, const PointCloud& cloud, const KdTree3& tree,
             std::span<const float> strength) {
  std::vector<Vec3f> moved(centres.size());
  parallel_for_ranges(0, centres.size(), 64, [&](std::size_t begin, std::size_t end) {
    std::vector<Neighbour> near;
    for (std::size_t k = begin; k < end; ++k) {
      tree.radius(centres[k], radius, near);
      Vec3d sum = Vec3d::Zero();
      double weight = 0;
      for (const Neighbour& nb : near) {
        sum += static_cast<double>(strength[nb.index]) * cloud.positions[nb.index].cast<double>();
        weight += static_cast<double>(strength[nb.index]);
      }
      // A flat patch has no feature to be drawn to: it stays where repulsion put it.
      moved[k] = weight > 1e-6 * static_cast<double>(near.size())
                     ? project_to_surface(Vec3f((sum / weight).cast<float>()), cloud, tree)
                     : centres[k];
    }
  });
  centres = std::move(moved);
}

std::vector<float> nearest_centre_distances(std::span<const Vec3f> points, std::span<const Vec3f> centres) {
  const KdTree3 centre_tree(centres);
  std::vector<float> distance(points.size());
  parallel_for(0, points.size(), 4096, [&](std::size_t i) {
    float d2 = 0;
    centre_tree.nearest(points[i], &d2);
    distance[i] = std::sqrt(d2);
  });
  return distance;
}

}  // namespace

double max_distance_to_centres(std::span<const Vec3f> points, std::span<const Vec3f> centres) {
  if (points.empty() || centres.empty()) return 0;
  const std::vector<float> d = nearest_centre_distances(points, centres);
  return static_cast<double>(*std::max_element(d.begin(), d.end()));
}

std::vector<Vec3f> poisson_disk_start(std::span<const Vec3f> positions, float spread, std::uint64_t seed,
                                      Progress* progress) {
  std::vector<Vec3f> centres;
  if (positions.empty()) return centres;
  Box3f box;  // as PointCloud::bounding_box
  for (const Vec3f& p : positions) box.extend(p);
  CentreGrid grid(spread, box.min());
  const std::vector<std::uint32_t> order = random_order(positions.size(), seed);
  constexpr std::size_t kAhead = 16;  // the points are visited at random: fetch ahead
  for (std::size_t i = 0; i < order.size(); ++i) {
    if (i + kAhead < order.size()) __builtin_prefetch(positions.data() + order[i + kAhead]);
    const Vec3f& p = positions[order[i]];
    if (!grid.covered(p)) {
      grid.add(p);
      centres.push_back(p);
    }
    if ((i & 0xFFFF) == 0xFFFF) progress_advance(progress, 0x10000);
  }
  progress_advance(progress, order.size() & 0xFFFF);  // the last, partial chunk
  return centres;
}

std::vector<Vec3f> choose_patch_centres(const PointCloud& cloud, const KdTree3& points_tree,
                                        const CentreOptions& options, CentreStats* stats) {
  const float radius = options.coverage_radius;
  const float spread = radius * options.spread;
  Progress* progress = options.progress;
  std::vector<Vec3f> centres;
  if (cloud.empty()) return centres;
  const Vec3f origin = cloud.bounding_box().min();

  progress_begin(progress, "centres: Poisson-disk start", cloud.size(), "points");
  if (options.start.empty()) {
    centres = poisson_disk_start(cloud.positions, spread, options.seed, progress);
  } else {
    centres.assign(options.start.begin(), options.start.end());
    progress_advance(progress, cloud.size());
  }
  progress_end(progress);
  const std::size_t initial = centres.size();

  const int rounds = std::max(options.repulsion_rounds, options.attraction_rounds);
  // Counted in centres moved (each round moves every centre), so that the rate means something.
  progress_begin(progress, "centres: repulsion and feature attraction",
                 static_cast<std::uint64_t>(rounds) * centres.size(), "centres");
  std::vector<float> searched;
  std::span<const float> strength = options.strength;
  if (options.attraction_rounds > 0 && strength.size() != cloud.size()) {
    searched.resize(cloud.size());
    feature_strength(cloud, points_tree.knn_batch(cloud.positions, kFeatureNeighbours, true, nullptr, false), searched);
    strength = searched;
  }
  for (int round = 0; round < rounds; ++round) {
    if (round < options.repulsion_rounds) repulse(centres, spread, cloud, points_tree);
    if (round < options.attraction_rounds) attract(centres, radius, cloud, points_tree, strength);
    progress_advance(progress, centres.size());
  }
  progress_end(progress);

  progress_begin(progress, "centres: coverage repair", cloud.size(), "points");
  std::size_t repaired = 0;
  {
    const std::vector<float> distance = nearest_centre_distances(cloud.positions, centres);
    CentreGrid grid(radius, origin);
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      if (distance[i] <= radius) continue;
      const Vec3f& p = cloud.positions[i];
      if (grid.covered(p)) continue;
      grid.add(p);
      centres.push_back(p);
      ++repaired;
    }
    progress_advance(progress, cloud.size());
  }
  progress_end(progress);

  sort_spatially(centres, cloud.bounding_box());
  if (stats != nullptr) {
    stats->initial = initial;
    stats->repaired = repaired;
  }
  return centres;
}

}  // namespace sspc::codec
