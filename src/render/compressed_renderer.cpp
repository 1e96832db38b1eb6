// The compressed renderer (paper §5, and beyond it: docs/ARCHITECTURE.md, "Rendering"). The
// paper traces each instance against its code word's MLS surface and blends the hits of
// overlapping patches; but a code word trimmed to its instances' regions ends at each region's
// border, so every patch's surface is one-sided there and no blend can restore the surface
// that is missing (measured: image PSNR against the render of the decoded model 16.6-23.7 dB at
// level 5, torn silhouettes, seams and blotches). Here an MLS evaluation at x sees the points of
// every instance whose region reaches x: the model is cut into the bricks of a BrickScene, and a
// brick's surface is built, when a ray first needs it, from the points the public random-access
// API decodes in the brick's box widened by the support radius (CompressedModel::decode_box),
// normals estimated there the way a decoded cloud's are when the model stores none. That is the
// MLS surface of the decoded model, seamless across instances, held within a memory budget
// while the model itself stays compressed.
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <mutex>
#include <numbers>
#include <tuple>
#include <unordered_map>
#include <utility>

#include <Eigen/Eigenvalues>

#include "core/parallel.hpp"
#include "core/stopwatch.hpp"
#include "geometry/normals_steps.hpp"
#include "render/brick_scene.hpp"
#include "render/compressed_scene.hpp"
#include "render/shading.hpp"
#include "sspc/neighbours.hpp"
#include "sspc/normals.hpp"
#include "sspc/render.hpp"

namespace sspc {

namespace {

// Points per brick the grid aims at. A brick decodes the points within its margin too (the
// support radius, plus the neighbourhood of PCA normals when the model has none), about 1.5
// times its own at this size; larger bricks cost more memory per brick for fewer duplicates.
constexpr double kPointsPerDecodedBrick = 32768;
// The k of the PCA normals a decoded cloud gets (NormalOptions' default, as `sspc render`
// estimates them), and the least a brick decodes around itself for their neighbourhoods, in
// point spacings: the 16 nearest neighbours on a surface sampled evenly at one spacing lie
// within about 2.3 spacings. Airborne LiDAR is sampled in scan lines: on autzen's level-5 decode
// the 16 nearest lie beyond 4 spacings for 26% of the points (median 3.2, 99th percentile 9.0,
// 99.9th 12.2), and a brick that decoded 4 spacings around itself gave the points near its faces
// other normals than the whole decode's: 34.7 dB against the render of the decode. The reach is
// measured (DecodedSampling) and this is its floor.
constexpr int kNormalNeighbours = 16;
// The leaves of the k-d trees a brick and the spacing's sample build for their k-NN: 24 points,
// as the encoder's (src/encoder/encoder.cpp), not KdTree3's 10. The answers are the same (ties
// by lower index, whatever the tree's shape).
constexpr std::size_t kBrickTreeLeaf = 24;
constexpr float kNormalReach = 4.0f;
// The share of sampled points whose 16 nearest a brick's margin holds.
constexpr double kNormalReachQuantile = 0.999;
constexpr double kMaxNormalReach = 32;

// The part of the memory budget given to the model's cache of decoded blocks: 1/kModelCacheShare.
constexpr std::uint64_t kModelCacheShare = 8;

// Patches sampled to measure the decoded model's spacing.
constexpr std::size_t kSpacingPatches = 1024;

// The area spacing (DecodedSampling) is at most this many nominal spacings: about 2 on a
// Poisson-disc-free random sampling, 1 to 1.5 on scans; a hostile model must not make the
// coarse levels' support span many level-0 bricks (each one's occupancy marks that many).
constexpr double kMaxAreaSpacing = 4;
// Levels of detail (BrickScene::add_levels): 0 and the coarser 1 to 3, one point a cell of 2, 4
// and 8 area spacings (DecodedSampling).
constexpr int kLevels = 4;
// The least bandwidth of a coarse level, in its cells. Where the sampling is uneven (scan lines:
// the nominal spacing shorter than the area spacing), twice level 0's bandwidth is fewer cells
// than level 0's is spacings; with at least this many the support radius (1.9 cells) holds
// about 11 cells' points on a surface, and every place on it lies within 0.71 cells of one.
// Before, a coarse level's bandwidth was as many cells as level 0's is spacings: on autzen
// (area spacing 2.2 nominal ones) 4.4 times level 0's instead of twice, 28-36 points in the
// support where level 0 has 5, and the coarse surfaces blurred. At level 5 seen whole at 1024²
// with --lod 0.5 (1 in brackets), against a render of 2 × 2 rays a pixel where every point
// gives 20.05 dB: 19.74 dB instead of 19.05 (18.35, 17.17); the first frame 2.97 s instead of
// 3.37 (2.78, 3.54), the next 0.92 s instead of 1.36 (1.20, 1.94).
constexpr double kMinCellBandwidth = 0.75;
// A model of at most kWholeDecodePoints source points is decoded whole to measure its sampling
// (whole_sampling), where the budget holds kWholeDecodeBytes a point (positions, k-d tree and
// the decode's transient buffers); larger ones, or under a smaller budget, are sampled.
constexpr std::uint64_t kWholeDecodePoints = std::uint64_t{1} << 20;
constexpr std::uint64_t kWholeDecodeBytes = 64;
// Points whose nearest neighbour is measured, about (nominal_spacing's sample).
constexpr double kSpacingSamples = 10000;
// What is decoded around a sampled patch, in the header's spacings: its points' neighbours
// within that reach are found.
constexpr float kSampleMargin = 16;

struct DecodedSampling {
  double spacing = 0;       // nominal spacing of the decoded points
  double normal_reach = 0;  // kNormalReachQuantile of the distance to the 16th nearest (self included)
  // The side of the square each point has to itself on the surface, 1/√density, from the median
  // distance d to the 16th nearest (16 points in a disc of radius d): levels of detail bin the
  // points in cells of twice, 4 and 8 times it, and so keep about a quarter, a 16th and a 64th
  // of them. The nominal spacing (the nearest neighbour's distance) is shorter wherever the
  // sampling is uneven, as along a scanner's lines: cells of twice it kept a third of
  // dragon_scans' points at level 3 where a 64th was meant, 1.8 times as many igea's at level 1.
  double area_spacing = 0;
};

// The sampling from the decoded spacing and the distances to the 16th nearest at sampled points.
DecodedSampling sampling_from(double spacing, std::vector<float> reach) {
  DecodedSampling sampling;
  sampling.spacing = spacing;
  // The floor: the sampled path measures among distinct positions, where the normals' search
  // counts coincident points too, whose 16th nearest lies no farther.
  sampling.normal_reach = static_cast<double>(kNormalReach) * sampling.spacing;
  sampling.area_spacing = sampling.spacing;
  if (!reach.empty()) {
    auto mid = reach.begin() + static_cast<std::ptrdiff_t>(reach.size() / 2);
    std::nth_element(reach.begin(), mid, reach.end());
    sampling.area_spacing = std::max(sampling.spacing, static_cast<double>(*mid) * std::sqrt(std::numbers::pi / 16));
    auto at = reach.begin() + static_cast<std::ptrdiff_t>(static_cast<double>(reach.size() - 1) * kNormalReachQuantile);
    std::nth_element(reach.begin(), at, reach.end());
    // At most kMaxNormalReach spacings: a sparse or hostile model must not make every brick
    // decode the model around it.
    sampling.normal_reach =
        std::clamp(static_cast<double>(*at), sampling.normal_reach, kMaxNormalReach * sampling.spacing);
  }
  return sampling;
}

// Positions in lexicographic order, for sorting them to their distinct ones.
bool position_less(const Vec3f& a, const Vec3f& b) {
  return std::tie(a.x(), a.y(), a.z()) < std::tie(b.x(), b.y(), b.z());
}

// The nominal spacing of the decoded model (nominal_spacing of its distinct positions), which is
// what a render of the decode takes its bandwidth from, measured without decoding it all: over
// the points of up to kSpacingPatches patches spread through the file, each decoded with what
// lies around it so that its border points find their true nearest neighbours. It differs from
// the header's spacing (the source's): at coarse levels the codec's grid merges points, and the
// bunny's decoded spacing is 1.9 times the source's at level 9; taking the header's, the direct
// render scored 25.6 dB against the render of the decode.
StatusOr<DecodedSampling> decoded_sampling(const CompressedModel& model) {
  const ModelInfo info = model.info();
  const std::size_t patches = model.patch_count();
  const std::size_t count = std::min(patches, kSpacingPatches);
  // One stride through every sampled patch's points, so that each point weighs the same, as in
  // nominal_spacing's sample: dense patches count for more than sparse ones (a stride per patch
  // overweighted the sparse ones: dragon_scans' spacing came out 8% long, 33 dB).
  const double sampled_points =
      static_cast<double>(info.source_points) * static_cast<double>(count) / static_cast<double>(patches);
  const auto stride = static_cast<std::size_t>(std::max(1.0, sampled_points / kSpacingSamples));
  // Over 1024 patches spread through the file, the sampled patches and what lies around them
  // are about the whole model: decoded on one core, autzen level 5 took 3.0 s, the largest part
  // of a cold frame's build. So the patches are decoded in parallel, twice: first for their
  // sizes and boxes, from which the stride's place in each follows (it runs on from one patch
  // into the next), then (from the cache) for the points it picks, each with what lies around
  // it. The values are gathered in the patches' order.
  struct Sample {
    std::size_t patch = 0, size = 0, first = 0;  // first: the stride's first point in it
    Box3f box;
    bool one_position = false;  // every point of the patch at one position
    bool skipped = false;
    Status status;
  };
  std::vector<Sample> samples(count);
  const float margin = kSampleMargin * info.spacing;
  parallel_for(0, count, 1, [&](std::size_t s) {
    Sample& sample = samples[s];
    sample.patch = s * patches / count;
    auto own = model.decode_patch(sample.patch);
    if (!own.ok()) {
      sample.status = own.status();
      return;
    }
    sample.size = own->size();
    if (own->empty()) return;
    // Everything decoded near the patch's points: their nearest neighbours may be another
    // patch's. A neighbour farther than the margin leaves that point's distance too long, which
    // only matters where the spacing itself exceeds the margin.
    sample.box = own->bounding_box();
    sample.box.extend(sample.box.min() - Vec3f::Constant(margin));
    sample.box.extend(sample.box.max() + Vec3f::Constant(margin));
    const Vec3f& p0 = own->positions[0];
    sample.one_position =
        std::all_of(own->positions.begin(), own->positions.end(), [&](const Vec3f& p) { return p == p0; });
  });
  const auto distinct_points = [](std::vector<Vec3f>& points) {
    std::sort(points.begin(), points.end(), position_less);
    points.erase(std::unique(points.begin(), points.end()), points.end());
    return points.size();
  };
  std::size_t offset = 0;
  for (Sample& sample : samples) {
    SSPC_RETURN_IF_ERROR(sample.status);
    if (sample.size == 0) continue;
    // A patch of one position whose surroundings hold no other gives no distance, and the
    // stride does not move on past it (rare: found here, in order).
    if (sample.one_position) {
      SSPC_ASSIGN_OR_RETURN(PointCloud around, model.decode_box(sample.box));
      if (distinct_points(around.positions) < 2) {
        sample.skipped = true;
        continue;
      }
    }
    sample.first = offset;
    std::size_t i = offset;
    while (i < sample.size) i += stride;
    offset = i - sample.size;  // where the stride falls in the next sampled patch
  }
  std::vector<std::vector<float>> nearest_of(count), reach_of(count);
  parallel_for(0, count, 1, [&](std::size_t s) {
    Sample& sample = samples[s];
    if (sample.size == 0 || sample.skipped) return;
    auto own = model.decode_patch(sample.patch);
    auto around = model.decode_box(sample.box);
    if (!own.ok() || !around.ok()) {
      sample.status = own.ok() ? around.status() : own.status();
      return;
    }
    // Distinct positions: the nearest neighbour at another position, as nominal_spacing has it.
    if (distinct_points(around->positions) < 2) return;
    const KdTree3 tree(around->positions, kBrickTreeLeaf);
    for (std::size_t i = sample.first; i < own->size(); i += stride) {
      std::uint32_t index[kNormalNeighbours];
      float d2[kNormalNeighbours];
      const std::size_t found = tree.knn(own->positions[i], kNormalNeighbours, index, d2);
      if (found >= 2) nearest_of[s].push_back(std::sqrt(d2[1]));
      if (found == kNormalNeighbours) reach_of[s].push_back(std::sqrt(d2[found - 1]));
    }
  });
  std::vector<float> nearest, reach;
  for (std::size_t s = 0; s < count; ++s) {
    SSPC_RETURN_IF_ERROR(samples[s].status);
    nearest.insert(nearest.end(), nearest_of[s].begin(), nearest_of[s].end());
    reach.insert(reach.end(), reach_of[s].begin(), reach_of[s].end());
  }
  double spacing = static_cast<double>(info.spacing);
  if (!nearest.empty()) {
    auto mid = nearest.begin() + static_cast<std::ptrdiff_t>(nearest.size() / 2);
    std::nth_element(nearest.begin(), mid, nearest.end());
    spacing = static_cast<double>(*mid);
  }
  return sampling_from(spacing, std::move(reach));
}

// The sampling of a model small enough to decode whole (decoded_sampling): its spacing is
// nominal_spacing of the decode, the very figure a render of the decode takes, and the reach
// of the 16 nearest is measured at the same sampled points. The estimates of the sampled path
// come from another sample of the same points; they agree to about 1%, but where the two fall
// on either side of a rung of the spacing ladder (render::ladder_spacing), the two renders take
// bandwidths 9% apart and differ as any two bandwidths do: the bunny's level-9 model scored 32.8
// dB against the render of its decode (192², its points encoded in Morton order), inf measured whole.
//
// The header's count of source points, which chose this path, is data like any other: the
// decode (render::decode_within) is given up once it holds more than `max_points`, and then
// this gives nullopt and the caller samples instead, so that a header understating its points
// cannot make the scene decode beyond its budget.
StatusOr<std::optional<DecodedSampling>> whole_sampling(const CompressedModel& model, std::uint64_t max_points) {
  SSPC_ASSIGN_OR_RETURN(const std::optional<PointCloud> decoded, render::decode_within(model, max_points));
  if (!decoded) return std::optional<DecodedSampling>();
  const PointCloud& all = *decoded;
  if (all.size() < 2) return std::optional(sampling_from(static_cast<double>(model.info().spacing), {}));
  SSPC_RETURN_IF_ERROR(check_coordinate_range(all.positions));
  const KdTree3 tree(all.positions, kBrickTreeLeaf);
  const double spacing = nominal_spacing(tree);
  const std::size_t n = all.size();
  const std::size_t count = std::min<std::size_t>(n, static_cast<std::size_t>(kSpacingSamples));
  std::vector<float> reach(count, -1.0f);
  parallel_for(0, count, 64, [&](std::size_t s) {
    std::uint32_t index[kNormalNeighbours];
    float d2[kNormalNeighbours];
    if (tree.knn(all.positions[s * n / count], kNormalNeighbours, index, d2) == kNormalNeighbours) {
      reach[s] = std::sqrt(d2[kNormalNeighbours - 1]);
    }
  });
  std::erase(reach, -1.0f);
  return std::optional(sampling_from(spacing, std::move(reach)));
}

// The nominal spacing of the decode to the bit, as nominal_spacing measures it on the decoded
// cloud that a render of the decode reads, for a model too large to decode whole: the decode's
// points are counted patch by patch (each patch dropped once counted, so memory stays the
// model's cache), nominal_spacing's sample (point s·n/count of the decode's order, count =
// min(10000, n)) is found in its patch, and each sampled point's nearest other point is sought
// among what is decoded around the samples of its patch, `margin` wide and wider where that
// holds no nearer point. The two renders then take the same rung of the spacing ladder (the
// sampled path's estimate, another sample of the same points, put autzen's level-0 model a rung
// below its decode's: 0.789 against 0.807, 26.2 dB against the render of the decode). nullopt
// where a sampled point shares its position with another (nominal_spacing then measures the
// distinct positions of the whole cloud, which only a whole decode gives): the caller samples.
// A cell of exact_sampling's grid, and its hash.
struct Cell {
  std::array<std::int64_t, 3> at{};
  bool operator==(const Cell&) const = default;
};
struct CellHash {
  std::size_t operator()(const Cell& c) const {
    return static_cast<std::size_t>((static_cast<std::uint64_t>(c.at[0]) * 0x9E3779B97F4A7C15ull) ^
                                    (static_cast<std::uint64_t>(c.at[1]) * 0xC2B2AE3D27D4EB4Full) ^
                                    (static_cast<std::uint64_t>(c.at[2]) * 0x165667B19E3779F9ull));
  }
};

// Decodes every patch of the model in parallel and hands each to visit(k, points); the first
// failure, in patch order, once all are done.
template <typename Visit>
Status for_each_decoded_patch(const CompressedModel& model, Visit&& visit) {
  const std::size_t patches = model.patch_count();
  std::vector<Status> failed(patches);
  parallel_for(0, patches, 1, [&](std::size_t k) {
    auto part = model.decode_patch(k);
    if (!part.ok()) {
      failed[k] = part.status();
      return;
    }
    visit(k, *part);
  });
  for (const Status& status : failed) SSPC_RETURN_IF_ERROR(status);
  return Status();
}

StatusOr<std::optional<DecodedSampling>> exact_sampling(const CompressedModel& model, float margin) {
  const std::size_t patches = model.patch_count();
  std::vector<std::uint64_t> first(patches + 1, 0);  // where each patch's points begin in the decode
  SSPC_RETURN_IF_ERROR(
      for_each_decoded_patch(model, [&](std::size_t k, const PointCloud& part) { first[k + 1] = part.size(); }));
  for (std::size_t k = 0; k < patches; ++k) first[k + 1] += first[k];
  const std::uint64_t n = first[patches];
  if (n < 2) return std::optional(sampling_from(static_cast<double>(model.info().spacing), {}));
  // nominal_spacing's sample, grouped by patch.
  const std::uint64_t count = std::min<std::uint64_t>({n, static_cast<std::uint64_t>(kSpacingSamples), std::uint64_t{1} << 24});
  std::vector<std::size_t> patch_of(count);
  for (std::uint64_t s = 0, k = 0; s < count; ++s) {
    const std::uint64_t i = s * n / count;
    while (first[k + 1] <= i) ++k;
    patch_of[s] = k;
  }
  // The sampled points, from their patches.
  std::vector<Vec3f> sample(count);
  std::vector<std::uint64_t> begins;  // the first sample of each patch that has some
  for (std::uint64_t s = 0; s < count; ++s) {
    if (s == 0 || patch_of[s] != patch_of[s - 1]) begins.push_back(s);
  }
  begins.push_back(count);
  std::vector<Status> status(begins.size());
  parallel_for(0, begins.size() - 1, 1, [&](std::size_t g) {
    const std::size_t k = patch_of[begins[g]];
    auto own = model.decode_patch(k);
    if (!own.ok()) {
      status[g] = own.status();
      return;
    }
    for (std::uint64_t s = begins[g]; s < begins[g + 1]; ++s) {
      sample[s] = own->positions[static_cast<std::size_t>(s * n / count - first[k])];
    }
  });
  for (const Status& st : status) SSPC_RETURN_IF_ERROR(st);
  // Cells of the margin's edge, each listing the samples in it and in the 26 around it: a
  // decoded point is measured against those only, so each sample's nearest are sought within
  // the margin at least.
  const Vec3f origin = model.info().bounds.min();
  const auto cell_of = [&](const Vec3f& p) {
    Cell c;
    for (std::size_t a = 0; a < 3; ++a) {
      c.at[a] = static_cast<std::int64_t>(std::floor((p[static_cast<Eigen::Index>(a)] - origin[static_cast<Eigen::Index>(a)]) / margin));
    }
    return c;
  };
  std::unordered_map<Cell, std::vector<std::uint32_t>, CellHash> cells;
  for (std::uint64_t s = 0; s < count; ++s) {
    const Cell c = cell_of(sample[s]);
    for (std::int64_t dz = -1; dz <= 1; ++dz) {
      for (std::int64_t dy = -1; dy <= 1; ++dy) {
        for (std::int64_t dx = -1; dx <= 1; ++dx) {
          cells[Cell{{c.at[0] + dx, c.at[1] + dy, c.at[2] + dz}}].push_back(static_cast<std::uint32_t>(s));
        }
      }
    }
  }
  // Each sample's 16 smallest squared distances, as a sorted array under its own lock; `bound`
  // the 16th once there are 16, read without the lock to pass most points by.
  struct Best {
    std::mutex mutex;
    std::array<float, kNormalNeighbours> d2;
    std::size_t size = 0;
    std::atomic<float> bound{std::numeric_limits<float>::infinity()};
  };
  std::vector<Best> best(count);
  SSPC_RETURN_IF_ERROR(for_each_decoded_patch(model, [&](std::size_t, const PointCloud& part) {
    for (const Vec3f& p : part.positions) {
      const auto found = cells.find(cell_of(p));
      if (found == cells.end()) continue;
      for (const std::uint32_t s : found->second) {
          // As nanoflann's L2 metric sums it: ((0 + dx²) + dy²) + dz².
          float d2 = 0;
          for (int a = 0; a < 3; ++a) {
            const float diff = sample[s][a] - p[a];
            d2 += diff * diff;
          }
          Best& b = best[s];
          if (!(d2 < b.bound.load(std::memory_order_relaxed))) continue;
          std::lock_guard lock(b.mutex);
          if (b.size == kNormalNeighbours && !(d2 < b.d2[kNormalNeighbours - 1])) continue;
          std::size_t i = b.size == kNormalNeighbours ? kNormalNeighbours - 1 : b.size++;
          while (i > 0 && d2 < b.d2[i - 1]) {
            b.d2[i] = b.d2[i - 1];
            --i;
          }
          b.d2[i] = d2;
          if (b.size == kNormalNeighbours) b.bound.store(b.d2[kNormalNeighbours - 1], std::memory_order_relaxed);
      }
    }
  }));
  std::vector<float> nearest(count, 0.0f), reach;
  for (std::uint64_t s = 0; s < count; ++s) {
    const Best& b = best[s];
    // The sample itself is among the points: its first distance is 0, the second its nearest
    // other point's, which lies within the margin (the cells searched) or is not known.
    if (b.size < 2 || !(std::sqrt(b.d2[1]) < 0.999f * margin)) return std::optional<DecodedSampling>();
    nearest[s] = std::sqrt(b.d2[1]);
    if (b.size == kNormalNeighbours) reach.push_back(std::sqrt(b.d2[kNormalNeighbours - 1]));
  }
  if (std::find(nearest.begin(), nearest.end(), 0.0f) != nearest.end()) return std::optional<DecodedSampling>();
  auto mid = nearest.begin() + static_cast<std::ptrdiff_t>(count / 2);
  std::nth_element(nearest.begin(), mid, nearest.end());
  return std::optional(sampling_from(static_cast<double>(*mid), std::move(reach)));
}

class CompressedScene final : public render::BrickScene {
 public:
  Status build(std::shared_ptr<const CompressedModel> model, float bandwidth, std::uint64_t budget,
               Progress* progress);

 private:
  StatusOr<SurfacePtr> load(int level, std::size_t b) const override;
  // Level 0: the decoded points themselves. Coarser levels: one point a cell of 2^level area
  // spacings.
  StatusOr<SurfacePtr> load_points(std::size_t b) const;
  StatusOr<SurfacePtr> load_cells(int level, std::size_t b) const;
  std::uint64_t source_bytes() const override { return model_->cache_bytes(); }
  // The model's cache gets what the bricks leave of the budget, and at least its share.
  void bricks_resized(std::uint64_t brick_bytes) const override {
    model_->set_cache_budget(std::max(model_budget_, budget_ > brick_bytes ? budget_ - brick_bytes : 0));
  }

  std::shared_ptr<const CompressedModel> model_;
  bool has_normals_ = false;
  float h_ = 0;
  float r_ = 0;       // the MLS support radius
  float margin_ = 0;  // what a brick decodes around its box
  std::uint64_t budget_ = 0;        // the scene's: bricks and the model's cache together
  std::uint64_t model_budget_ = 0;  // the least the model's cache gets
  std::vector<std::uint32_t> codeword_of_patch_;
};

Status CompressedScene::build(std::shared_ptr<const CompressedModel> model, float bandwidth, std::uint64_t budget,
                              Progress* progress) {
  const ModelInfo info = model->info();
  if (model->patch_count() == 0) return invalid_argument("the model has no patches");
  const auto start = std::chrono::steady_clock::now();
  // The header's spacing is data like any other: 0 or a denormal (the format allows ≥ 0) would
  // make the bandwidth, and so every step of the march, vanish. An encoder writes a patch radius
  // of 1.6-36 spacings (8-4096 points a patch); far outside that the model cannot be rendered.
  if (!(info.spacing >= 1e-3f * info.patch_radius && info.spacing <= 10.0f * info.patch_radius)) {
    char text[200];
    std::snprintf(text, sizeof text,
                  "the model's point spacing %.3g does not fit its patch radius %.3g (an encoder writes 1.6 to 36 "
                  "spacings a radius): it cannot be rendered",
                  static_cast<double>(info.spacing), static_cast<double>(info.patch_radius));
    return invalid_argument(text);
  }
  if (static_cast<double>(info.spacing) < kMinSpacing ||
      !(info.bounds.min().cast<double>().cwiseAbs().maxCoeff() <= kMaxCoordinate) ||
      !(info.bounds.max().cast<double>().cwiseAbs().maxCoeff() <= kMaxCoordinate)) {
    return invalid_argument("the model's bounds reach beyond 1e18 or its spacing is below 1e-18, outside "
                            "float32's range: it cannot be rendered");
  }
  model_ = std::move(model);
  has_normals_ = info.has_normals;
  // The model's decoded blocks count in the budget: left at its own default they held autzen's
  // whole code book decoded (160 MB) beside 64 MiB of bricks. The bricks get all but an eighth
  // of it, and the model's cache whatever the bricks leave (bricks_resized), at least that
  // eighth, which holds the blocks a brick's decode needs many times over (autzen level 5:
  // 0.45 MB a code-word block). A fixed eighth made neighbouring bricks decode the same blocks
  // again: a cold frame of autzen at level of detail 0.5 under the default 512 MiB decoded its
  // code book 2.7 times over (951 block decodes of 358 blocks) while the bricks held 117 MB;
  // lent what the bricks left, each block once, and the frame took 3.4 s instead of 4.8. While
  // the spacing is sampled no brick is held, so the cache has the whole budget from the start
  // (the samples' surroundings share blocks: autzen level 5 under 64 MiB built in 3.3 s, not
  // 7.2 with an eighth).
  budget_ = budget;
  model_budget_ = budget / kModelCacheShare;
  model_->set_cache_budget(budget);
  std::optional<DecodedSampling> measured;
  if (info.source_points <= kWholeDecodePoints && info.source_points * kWholeDecodeBytes <= budget) {
    SSPC_ASSIGN_OR_RETURN(measured, whole_sampling(*model_, budget / kWholeDecodeBytes));
  }
  if (!measured) {
    SSPC_ASSIGN_OR_RETURN(measured, exact_sampling(*model_, kSampleMargin * info.spacing));
  }
  if (!measured) {
    SSPC_ASSIGN_OR_RETURN(measured, decoded_sampling(*model_));
  }
  const DecodedSampling sampling = *measured;
  budget -= model_budget_;
  // On the ladder surface_spacing puts a point cloud's spacing on, so that this estimate and
  // the decode's (another sample of the same points) give the same bandwidth.
  const double spacing = render::ladder_spacing(sampling.spacing);
  if (!(spacing >= kMinSpacing && spacing <= 10.0 * static_cast<double>(info.patch_radius))) {
    return invalid_argument("the decoded model's point spacing does not fit its patch radius: it cannot be rendered");
  }
  h_ = static_cast<float>(static_cast<double>(bandwidth) * spacing);
  r_ = render::MlsSurface(std::span<const Vec3f>(), std::span<const Vec3f>(), h_).support_radius();
  margin_ = r_ + (has_normals_ ? 0.0f : static_cast<float>(sampling.normal_reach));

  // The decoded points lie within the code word's radius of their patch's centre, which may
  // put them beyond the source's bounds (by up to the codec's error), and the surface reaches r
  // beyond them: the grid covers all of it, or rays would stop short of surface that is there.
  const std::size_t patches = model_->patch_count();
  codeword_of_patch_.resize(patches);
  std::vector<Vec3f> centres(patches);
  Box3f reach_box = info.bounds;
  const float reach = info.codeword_radius;
  progress_begin(progress, "scene", patches, "patches");
  for (std::size_t k = 0; k < patches; ++k) {
    SSPC_ASSIGN_OR_RETURN(const PatchRecord p, model_->patch(k));
    codeword_of_patch_[k] = p.codeword;
    centres[k] = p.translation;
    reach_box.extend(p.translation - Vec3f::Constant(reach + r_));
    reach_box.extend(p.translation + Vec3f::Constant(reach + r_));
    if ((k & 1023) == 1023) progress_advance(progress, 1024);
  }
  progress_end(progress);
  bounds_ = info.bounds;

  // Bricks of about kPointsPerDecodedBrick points on a surface (points per brick grow with its
  // area), at least 8 support radii across.
  const Vec3f extent = info.bounds.max() - info.bounds.min();
  const float area = std::max({extent.x() * extent.y(), extent.y() * extent.z(), extent.x() * extent.z(), 1e-30f});
  const double points = std::max<double>(1.0, static_cast<double>(info.source_points));
  const float edge = std::max(8 * r_, std::sqrt(area * static_cast<float>(kPointsPerDecodedBrick / points)));
  SSPC_RETURN_IF_ERROR(layout(reach_box, edge, h_, budget));

  // A brick holds surface when some patch's points can reach it.
  for (const Vec3f& c : centres) {
    int lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      lo[a] = brick_coordinate(c[a] - reach - r_, a);
      hi[a] = brick_coordinate(c[a] + reach + r_, a);
    }
    for (int z = lo[2]; z <= hi[2]; ++z) {
      for (int y = lo[1]; y <= hi[1]; ++y) {
        for (int x = lo[0]; x <= hi[0]; ++x) set_occupied(brick_index(x, y, z));
      }
    }
  }
  progress_end(progress);
  // Level 1's cells twice the area spacing, and its bandwidth twice level 0's, but at least
  // kMinCellBandwidth cells (so that where the spacing is even, h doubles from level to level
  // and is as many cells as level 0's is spacings).
  const double cell = 2 * std::min(sampling.area_spacing, kMaxAreaSpacing * sampling.spacing);
  const double coarse_h = std::max(2.0 * static_cast<double>(h_), kMinCellBandwidth * cell);
  add_levels(kLevels, static_cast<float>(cell), static_cast<float>(coarse_h));
  build_seconds_ = seconds_since(start);
  memory_bytes_ = brick_count() / 8 + codeword_of_patch_.size() * sizeof(std::uint32_t);
  return Status();
}

StatusOr<CompressedScene::SurfacePtr> CompressedScene::load(int level, std::size_t b) const {
  return level == 0 ? load_points(b) : load_cells(level, b);
}

StatusOr<CompressedScene::SurfacePtr> CompressedScene::load_points(std::size_t b) const {
  const Box3f own = brick_box(b);
  const Box3f wide(own.min() - Vec3f::Constant(margin_), own.max() + Vec3f::Constant(margin_));
  std::vector<std::uint32_t> patch_of;
  DecodeOptions options;
  options.patch_of = &patch_of;
  SSPC_ASSIGN_OR_RETURN(PointCloud cloud, model_->decode_box(wide, options));
  // The surface needs the points within r of the brick; the rest are there for their normals.
  std::vector<std::uint32_t> kept;
  const float r2 = r_ * r_;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (own.squaredExteriorDistance(cloud.positions[i]) <= r2) kept.push_back(static_cast<std::uint32_t>(i));
  }
  std::vector<Vec3f> positions, normals;
  std::vector<std::uint32_t> ids;
  positions.reserve(kept.size());
  ids.reserve(kept.size());
  for (const std::uint32_t i : kept) {
    positions.push_back(cloud.positions[i]);
    ids.push_back(codeword_of_patch_[patch_of[i]]);
  }
  if (has_normals_) {
    normals.reserve(kept.size());
    for (const std::uint32_t i : kept) normals.push_back(cloud.normals[i]);
  } else if (cloud.size() >= 4) {
    // PCA over the 16 nearest among all the decoded points, as estimate_normals gives a decoded
    // cloud (the same tree, ties by lower index), but for the kept points only, not for the
    // margin that is there for their neighbourhoods. PCA alone, without
    // the spanning tree's orientation: the MLS surface takes the principal axis of Σ w nnᵀ,
    // which no normal's sign changes, and a hit's normal faces the ray (the tree was 22% of a
    // compressed render of autzen, perf at 512², the image the same).
    SSPC_RETURN_IF_ERROR(check_coordinate_range(cloud.positions));
    const std::size_t k = std::min<std::size_t>(kNormalNeighbours, cloud.size() - 1);
    const KnnTable table = KdTree3(cloud.positions, kBrickTreeLeaf).knn_batch(positions, k, false, nullptr, false);
    normals.resize(kept.size());
    detail::estimate_normals_pca(cloud.positions, table, normals, nullptr);
  } else {
    // PCA needs 3 neighbours: a brick reached by fewer than 4 points (a stray few at its
    // margin) shows none of them.
    positions.clear();
    ids.clear();
  }
  return SurfacePtr(
      std::make_shared<const render::MlsSurface>(positions, normals, h_, 0.0f, ids));
}

// A coarse level's brick: the decoded points binned in a grid of cells 2^level area spacings wide,
// anchored at the scene's grid so that every brick bins alike, and one point a cell, the
// centroid of its points, with the normal of the PCA of the points of the cell and its 26
// neighbours (their moments summed: about 9 cells' points on a surface, 36 at level 1 and 576 at
// level 3, with no neighbour search). A brick decodes every cell within its support radius plus
// two cells, so that the cells it keeps (a centroid within the support radius of its box) have
// all their neighbours whole, whichever brick holds them: two bricks give a shared cell the same
// point and normal. The surface's bandwidth is as many cells as level 0's is spacings, and it ends
// where level 0's would (MlsSurface::end_within), not 2^level times farther from the points.
StatusOr<CompressedScene::SurfacePtr> CompressedScene::load_cells(int level, std::size_t b) const {
  const float cell = level_cell(level);
  const float h = level_bandwidth(level);
  const float r = render::MlsSurface(std::span<const Vec3f>(), std::span<const Vec3f>(), h).support_radius();
  const Box3f own = brick_box(b, level);
  const Vec3f origin = brick_box(0).min();  // the grid's corner
  const float reach = r + 2 * cell;
  std::int64_t lo[3];
  std::int64_t n[3];
  Box3f wide;
  // Cell coordinates as floats first: far outside int64's range they must not be converted.
  const auto cell_of = [&](float v, int a) { return std::floor((v - origin[a]) / cell); };
  double cells = 1;
  for (int a = 0; a < 3; ++a) {
    const float first = cell_of(own.min()[a] - reach, a), last = cell_of(own.max()[a] + reach, a);
    cells *= static_cast<double>(last) - static_cast<double>(first) + 1;
    if (!(std::abs(first) < 1e15f && std::abs(last) < 1e15f) || !(cells < 1e15)) {
      return invalid_argument("level of detail: a brick of the model spans too many cells (a point spacing far "
                              "below its extent)");
    }
    lo[a] = static_cast<std::int64_t>(first);
    const auto hi = static_cast<std::int64_t>(last);
    n[a] = hi - lo[a] + 1;
    // Half a cell more: a point that the floor below puts in an edge cell is decoded whatever
    // the rounding of the box's bounds.
    wide.min()[a] = origin[a] + static_cast<float>(lo[a]) * cell - 0.5f * cell;
    wide.max()[a] = origin[a] + static_cast<float>(hi + 1) * cell + 0.5f * cell;
  }
  std::vector<std::uint32_t> patch_of;
  DecodeOptions options;
  options.patch_of = &patch_of;
  SSPC_ASSIGN_OR_RETURN(const PointCloud cloud, model_->decode_box(wide, options));

  // Points by cell, and within a cell by position, so that sums do not depend on the decode's order.
  std::vector<std::pair<std::uint64_t, std::uint32_t>> binned;
  binned.reserve(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    std::int64_t g[3];
    bool inside = true;
    for (int a = 0; a < 3; ++a) {
      const float u = cell_of(cloud.positions[i][a], a);
      g[a] = static_cast<std::int64_t>(std::clamp(u, -1e15f, 1e15f)) - lo[a];
      inside = inside && g[a] >= 0 && g[a] < n[a];
    }
    if (!inside) continue;
    const auto key = static_cast<std::uint64_t>(g[0] + n[0] * (g[1] + n[1] * g[2]));
    binned.emplace_back(key, static_cast<std::uint32_t>(i));
  }
  // By cell, and within a cell in the decode's order (a filtered run of one order through the
  // model, whichever the box), so that every brick sums a cell's points alike.
  std::sort(binned.begin(), binned.end());

  // Per cell its points' count, sums and second moments (about the brick's centre), as one row.
  enum : std::size_t { kCount, kX, kY, kZ, kXX, kXY, kXZ, kYY, kYZ, kZZ, kMoments };
  const Eigen::Vector3d centre = own.center().cast<double>();
  std::vector<std::uint64_t> keys;
  std::vector<std::array<double, kMoments>> moments;
  std::vector<std::uint32_t> first_id;  // the code word of each cell's first point
  for (const auto& [key, index] : binned) {
    if (keys.empty() || keys.back() != key) {
      keys.push_back(key);
      moments.push_back({});
      first_id.push_back(codeword_of_patch_[patch_of[index]]);
    }
    auto& m = moments.back();
    const Eigen::Vector3d p = cloud.positions[index].cast<double>() - centre;
    m[kCount] += 1;
    m[kX] += p.x(), m[kY] += p.y(), m[kZ] += p.z();
    m[kXX] += p.x() * p.x(), m[kXY] += p.x() * p.y(), m[kXZ] += p.x() * p.z();
    m[kYY] += p.y() * p.y(), m[kYZ] += p.y() * p.z(), m[kZZ] += p.z() * p.z();
  }

  // The 3 × 3 × 3 neighbourhood of each cell, in key order: its 9 rows (dy, dz) are runs of keys
  // key + dy·n0 + dz·n0·n1 + {−1, 0, 1}, which grow with the cell's key, so each row has a
  // cursor that only moves forward (a search a neighbour cost 27 binary searches a cell, 36% of
  // a frame of autzen at level of detail 0.5).
  std::array<std::size_t, 9> cursor{};
  std::vector<Vec3f> points, normals;
  std::vector<std::uint32_t> ids;
  const float r2 = r * r;
  const auto row = static_cast<std::uint64_t>(n[0]), plane = static_cast<std::uint64_t>(n[0] * n[1]);
  for (std::size_t c = 0; c < keys.size(); ++c) {
    const auto& own_moments = moments[c];
    const Vec3f point = (Eigen::Vector3d(own_moments[kX], own_moments[kY], own_moments[kZ]) / own_moments[kCount] + centre)
                            .cast<float>();
    if (own.squaredExteriorDistance(point) > r2) continue;
    const std::uint64_t key = keys[c];
    const auto gx = static_cast<std::int64_t>(key % row);
    const auto gy = static_cast<std::int64_t>((key / row) % static_cast<std::uint64_t>(n[1]));
    const auto gz = static_cast<std::int64_t>(key / plane);
    std::array<double, kMoments> sum{};
    for (int dz = -1; dz <= 1; ++dz) {
      for (int dy = -1; dy <= 1; ++dy) {
        std::size_t& at = cursor[static_cast<std::size_t>((dz + 1) * 3 + dy + 1)];
        if (gy + dy < 0 || gy + dy >= n[1] || gz + dz < 0 || gz + dz >= n[2]) continue;
        const std::uint64_t centre_key = static_cast<std::uint64_t>(
            gx + n[0] * ((gy + dy) + n[1] * (gz + dz)));
        const std::uint64_t first = gx > 0 ? centre_key - 1 : centre_key;
        const std::uint64_t last = gx + 1 < n[0] ? centre_key + 1 : centre_key;
        while (at < keys.size() && keys[at] < first) ++at;
        for (std::size_t j = at; j < keys.size() && keys[j] <= last; ++j) {
          for (std::size_t k = 0; k < kMoments; ++k) sum[k] += moments[j][k];
        }
      }
    }
    if (sum[kCount] < 3) continue;  // no plane through fewer than 3 points
    const Eigen::Vector3d mean = Eigen::Vector3d(sum[kX], sum[kY], sum[kZ]) / sum[kCount];
    Eigen::Matrix3d covariance;
    covariance << sum[kXX], sum[kXY], sum[kXZ], sum[kXY], sum[kYY], sum[kYZ], sum[kXZ], sum[kYZ], sum[kZZ];
    covariance = covariance / sum[kCount] - mean * mean.transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
    solver.computeDirect(covariance);
    const Eigen::Vector3d normal = solver.eigenvectors().col(0);  // the least eigenvalue's
    if (!normal.allFinite() || !(normal.norm() > 0.5)) continue;
    points.push_back(point);
    normals.push_back(normal.normalized().cast<float>());
    ids.push_back(first_id[c]);
  }
  auto surface = std::make_shared<render::MlsSurface>(points, normals, h, 0.0f, ids);
  surface->end_within(r_);
  return SurfacePtr(std::move(surface));
}

}  // namespace

namespace render {

StatusOr<std::optional<double>> exact_decoded_spacing(const CompressedModel& model, float margin) {
  SSPC_ASSIGN_OR_RETURN(const std::optional<DecodedSampling> sampling, exact_sampling(model, margin));
  if (!sampling) return std::optional<double>();
  return std::optional(sampling->spacing);
}

StatusOr<std::optional<PointCloud>> decode_within(const CompressedModel& model, std::uint64_t max_points) {
  const std::size_t patches = model.patch_count();
  std::vector<PointCloud> parts(patches);
  std::vector<Status> failed(patches);
  std::atomic<std::uint64_t> decoded{0};
  std::atomic<bool> over{false};
  parallel_for(0, patches, 1, [&](std::size_t k) {
    if (over.load(std::memory_order_relaxed)) return;
    auto part = model.decode_patch(k);
    if (!part.ok()) {
      failed[k] = part.status();
      return;
    }
    if (decoded.fetch_add(part->size(), std::memory_order_relaxed) + part->size() > max_points) {
      over.store(true, std::memory_order_relaxed);
      return;
    }
    parts[k] = std::move(part).value();
  });
  if (over.load()) return std::optional<PointCloud>();
  for (const Status& s : failed) SSPC_RETURN_IF_ERROR(s);
  return std::optional(PointCloud::concatenate(std::move(parts)));
}

}  // namespace render

StatusOr<std::unique_ptr<RenderScene>> RenderScene::from_compressed(std::shared_ptr<const CompressedModel> model,
                                                                    const SceneOptions& options) {
  if (model == nullptr) return invalid_argument("from_compressed: no model");
  SSPC_RETURN_IF_ERROR(render::check_scene(options));
  auto scene = std::make_unique<CompressedScene>();
  SSPC_RETURN_IF_ERROR(
      scene->build(std::move(model), options.bandwidth, options.memory_budget_bytes, options.progress));
  return std::unique_ptr<RenderScene>(std::move(scene));
}

StatusOr<Image> render_compressed(const CompressedModel& model, const FrameOptions& frame,
                                  const SceneOptions& scene_options, RenderStats* stats) {
  SSPC_RETURN_IF_ERROR(render::check_frame(frame));
  // The scene lives only for this call, within the caller's model: a pointer that owns nothing.
  std::shared_ptr<const CompressedModel> borrowed(&model, [](const CompressedModel*) {});
  SSPC_ASSIGN_OR_RETURN(auto scene, RenderScene::from_compressed(std::move(borrowed), scene_options));
  return scene->render(frame, stats);
}

}  // namespace sspc
