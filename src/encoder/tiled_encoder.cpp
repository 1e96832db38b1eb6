// The tiled encoder (include/sspc/tiled_encoder.hpp): a plan over a tile store
// (encoder/tile_store.hpp), the tiles' jobs, and the streamed writer.
#include "sspc/tiled_encoder.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <numbers>
#include <numeric>
#include <optional>
#include <system_error>
#include <variant>

#include "core/atomic_file.hpp"
#include "core/mapped_file.hpp"
#include "core/parallel.hpp"
#include "core/resident_watch.hpp"
#include "core/stopwatch.hpp"
#include "encoder/encode_steps.hpp"
#include "encoder/patch_centres.hpp"
#include "encoder/spatial_order.hpp"
#include "encoder/tile_job.hpp"
#include "encoder/tile_store.hpp"
#include "format/attribute_coder.hpp"
#include "sspc/allocator.hpp"
#include "sspc/neighbours.hpp"
#include "sspc/normals.hpp"

namespace sspc {

using namespace encoding;

struct TiledEncoder::Impl {
  std::unique_ptr<codec::TileStore> store;
  EncodeOptions options;
  codec::BuildOptions build;  // spacing and patch radius set
  NormalOptions normals;
  float margin = 0;
  double seconds_planning = 0;
  // Each tile's job digest (codec::tile_job_digest), recorded when its job is made: a result
  // must quote it. job() may be called from several threads (the Python bindings release the GIL).
  mutable std::mutex digests_mutex;
  mutable std::vector<std::optional<std::uint32_t>> digests;

  // Writing.
  std::optional<codec::ContainerStreamWriter> writer;
  ContainerChoice choice;
  std::size_t next = 0;  // the next tile to write
  // Results that came before their turn: bytes, or a file's path (add_file).
  using Result = std::variant<std::string, std::filesystem::path>;
  std::map<std::size_t, Result> waiting;
  codec::BuildStats build_stats;
  std::uint64_t patches = 0, codewords = 0;
  double max_coverage_distance = 0;
  std::chrono::steady_clock::time_point begun;

  const codec::TilePlan& plan() const { return store->plan(); }
  Status measure();
  StatusOr<std::string> job(std::size_t t) const;
  StatusOr<std::uint32_t> job_digest(std::size_t t) const;
  Status check_identity(std::size_t t, const codec::TileResult& tile) const;
  Status accept(std::size_t t, Result result);
  Status write_waiting();
  void stop_writing() {
    writer.reset();
    next = 0;
    waiting.clear();
    build_stats = codec::BuildStats();
    patches = codewords = 0;
    max_coverage_distance = 0;
  }

  static std::unique_ptr<Impl> make(const EncodeOptions& options) {
    auto impl = std::make_unique<Impl>();
    impl->options = options;
    impl->options.progress = nullptr;
    impl->build = build_options(options, 0);  // the level's row for the whole model: measure()
    impl->build.progress = nullptr;
    impl->normals = options.normals;
    impl->normals.progress = nullptr;
    return impl;
  }
};

// The spacing and patch radius every tile shares, measured as an untiled encode measures them
// (the median distance to the nearest distinct neighbour over 10,000 points; the radius whose
// spheres hold patch_points points on average). The spacing: every tile sampled in proportion to
// its points, over its own points alone (a search is exact for a point whose distance to the
// tile's faces is at least the search's radius, since every other tile's points lie outside
// them), the samples pooled into one median. (A weighted median of each tile's own median read
// autzen's spacing 2.5% long, a grid 2.5% coarser, 0.27 dB below the untiled encode; sampling
// the eight largest of 16 tiles read it 3.6% short, 0.29 dB above.) The radius: the weighted
// median over the eight largest tiles (ties to the first), each with a margin.
Status TiledEncoder::Impl::measure() {
  constexpr std::size_t kSpacingSamples = 10000;
  const codec::TilePlan& p = plan();
  std::vector<std::size_t> all(p.size());
  std::iota(all.begin(), all.end(), std::size_t{0});
  std::vector<std::size_t> sampled = all;
  std::stable_sort(sampled.begin(), sampled.end(),
                   [&](std::size_t a, std::size_t b) { return p.points[a] > p.points[b]; });
  sampled.resize(std::min<std::size_t>(sampled.size(), 8));
  std::sort(sampled.begin(), sampled.end());
  const std::uint64_t total = store->input().points;
  // The patch size follows the whole model's points, as an untiled encode's does.
  build.level = build_options(options, total).level;
  // A tile smaller than half a patch carries a margin (a patch radius and more) that holds many
  // times its own points, and the encode's time explodes (docs/RESULTS.md, "Tile margins").
  std::uint64_t tile_size = options.tile_points;
  if (tile_size == 0) {
    SSPC_ASSIGN_OR_RETURN(tile_size, tile_points_for_memory(options.memory_limit, total));
  }
  const auto least = static_cast<std::uint64_t>(build.level.patch_points) / 2;
  if (tile_size < least) {
    return invalid_argument((options.tile_points > 0 ? "tiles of " + std::to_string(tile_size) + " points"
                                                     : "the memory limit's tiles of " + std::to_string(tile_size) +
                                                           " points") +
                            " are smaller than half a patch (" + std::to_string(build.level.patch_points) +
                            " points at level " + std::to_string(options.level) +
                            "): each tile carries a margin of a patch radius, which would hold many times its own "
                            "points; use tiles of at least " + std::to_string(least) + " points");
  }

  // A tile's own points, each with its distance to the tile's faces, one tile at a time.
  struct Own {
    PointCloud cloud;
    std::vector<float> inside;
  };
  auto load_own = [&](std::size_t t) -> StatusOr<Own> {
    Own own;
    SSPC_ASSIGN_OR_RETURN(own.cloud, store->load(t, -1));
    const Box3f& box = p.boxes[t];
    for (const Vec3f& q : own.cloud.positions) {
      own.inside.push_back(std::min((q - box.min()).minCoeff(), (box.max() - q).minCoeff()));
    }
    return own;
  };
  // Per sample: the distance to its nearest distinct neighbour among the tile's points, and to
  // the tile's faces. The tiles in parallel, each into its own list, joined in tile order (a
  // search tree over each tile's points: 16 of 1M on autzen, 2.4 s on one thread).
  std::vector<std::vector<std::pair<float, float>>> per_tile(p.size());
  std::vector<Status> loaded(p.size());
  parallel_for(0, p.size(), 1, [&](std::size_t t) {
    auto tile = load_own(t);
    if (!tile.ok()) {
      loaded[t] = tile.status();
      return;
    }
    const KdTree3 tree(tile->cloud.positions);
    const std::size_t n = tile->cloud.size();
    const std::size_t count = std::min<std::size_t>(
        n, std::max<std::size_t>(1, static_cast<std::size_t>(kSpacingSamples * p.points[t] / std::max<std::uint64_t>(total, 1))));
    for (std::size_t s = 0; s < count && n >= 2; ++s) {
      const std::size_t i = s * n / count;
      // The nearest distinct position: the first non-zero of a few nearest (coincident points
      // would read a spacing of 0).
      std::uint32_t idx[8];
      float d2[8];
      const std::size_t found = tree.knn(tile->cloud.positions[i], 8, idx, d2);
      for (std::size_t j = 1; j < found; ++j) {
        if (d2[j] > 0) {
          per_tile[t].emplace_back(std::sqrt(d2[j]), tile->inside[i]);
          break;
        }
      }
    }
  });
  std::vector<std::pair<float, float>> nearest;
  for (std::size_t t = 0; t < p.size(); ++t) {
    SSPC_RETURN_IF_ERROR(loaded[t]);
    nearest.insert(nearest.end(), per_tile[t].begin(), per_tile[t].end());
  }
  // The median over the samples at least four spacings inside their tile, whose nearest
  // neighbour is then in the tile: chosen by place, not by their own distance (keeping those
  // whose distance is below their depth would favour short ones near the faces: 9% short on a
  // torus cut in tiles of 1,600 points). A first median over those sure to be exact sets the
  // depth.
  auto median_of = [&nearest](float depth, bool exact) {
    std::vector<float> d;
    for (const auto& [distance, inside] : nearest) {
      if (inside >= depth && (!exact || distance <= inside)) d.push_back(distance);
    }
    if (d.empty()) return 0.0f;
    auto mid = d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2);
    std::nth_element(d.begin(), mid, d.end());
    return *mid;
  };
  const float first = median_of(0, true);
  float spacing = median_of(4 * first, false);
  if (!(spacing > 0)) spacing = first;  // tiles too small to hold anything four spacings deep
  if (!(spacing > 0)) return invalid_argument("no tile has two distinct points; use larger tiles");
  build.spacing = static_cast<double>(spacing);

  const double guess = build.spacing * std::sqrt(static_cast<double>(build.level.patch_points) / std::numbers::pi);
  // The sampled tiles in parallel, each radius in its tile's slot.
  std::vector<double> radius_of(sampled.size(), -1);
  std::vector<Status> measured(sampled.size());
  parallel_for(0, sampled.size(), 1, [&](std::size_t k) {
    const std::size_t t = sampled[k];
    const std::uint64_t points = p.points[t];
    if (points < 16) return;
    // Sampled among the tile's own points, counted over them and a margin of its neighbours'
    // as deep as the spheres reach: at first three times a flat sampling's radius, then, while
    // the radius found reaches past four fifths of that, twice the radius found. (Sampling only
    // the points whose spheres stay inside the tile, with no margin, read autzen's radius 26%
    // long: the points near a tile's faces, the scan's edges among them, are not like the rest.)
    double depth = 3 * guess, radius = 0;
    for (int round = 0; round < 3; ++round) {
      auto part = store->load(t, static_cast<float>(depth));
      if (!part.ok()) {
        measured[k] = part.status();
        return;
      }
      const KdTree3 tree(part->positions);
      radius = static_cast<double>(codec::radius_for_patch_points(
          *part, tree, build.spacing, build.level.patch_points, static_cast<std::size_t>(points)));
      if (radius <= 0.8 * depth) break;
      depth = 2 * radius;
    }
    radius_of[k] = radius;
  });
  std::vector<std::pair<double, std::size_t>> radii;
  for (std::size_t k = 0; k < sampled.size(); ++k) {
    SSPC_RETURN_IF_ERROR(measured[k]);
    if (radius_of[k] >= 0) radii.emplace_back(radius_of[k], p.points[sampled[k]]);
  }
  if (radii.empty()) return invalid_argument("no tile has 16 points; use larger tiles");
  const Box3f& b = store->input().bounds;
  build.patch_radius = static_cast<float>(std::min(weighted_median(radii), (b.max().cast<double>() - b.min().cast<double>()).norm()));
  // A patch gathers the points within one patch radius of its centre, an own point of the tile;
  // the normals of those see their 16 nearest, within a few spacings (tiling.hpp).
  margin = static_cast<float>(static_cast<double>(build.patch_radius) + 8 * build.spacing);
  return Status();
}

TiledEncoder::TiledEncoder(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
TiledEncoder::TiledEncoder(TiledEncoder&&) noexcept = default;
TiledEncoder& TiledEncoder::operator=(TiledEncoder&&) noexcept = default;
TiledEncoder::~TiledEncoder() = default;

StatusOr<TiledEncoder> TiledEncoder::plan(PointCloud cloud, const EncodeOptions& options) {
  SSPC_RETURN_IF_ERROR(check_options(options));
  SSPC_RETURN_IF_ERROR(cloud.validate());
  SSPC_RETURN_IF_ERROR(check_size(cloud.size(), cloud.bounding_box()));
  if (options.tile_points == 0) return invalid_argument("a tiled encode needs tile_points > 0");
  const auto start = std::chrono::steady_clock::now();
  auto impl = Impl::make(options);
  impl->store = codec::TileStore::in_memory(std::move(cloud), options.tile_points,
                                            static_cast<std::uint8_t>(options.attributes));
  SSPC_RETURN_IF_ERROR(impl->measure());
  impl->seconds_planning = seconds_since(start);
  return TiledEncoder(std::move(impl));
}

StatusOr<TiledEncoder> TiledEncoder::plan_file(const std::filesystem::path& input, const EncodeOptions& options,
                                               const ReadOptions& read, const std::filesystem::path& work_dir) {
  return plan_files(std::span(&input, 1), options, read, work_dir);
}

StatusOr<TiledEncoder> TiledEncoder::plan_files(std::span<const std::filesystem::path> inputs,
                                                const EncodeOptions& options, const ReadOptions& read,
                                                const std::filesystem::path& work_dir) {
  if (inputs.empty()) return invalid_argument("no input file");
  SSPC_RETURN_IF_ERROR(check_options(options));
  if (options.tile_points == 0 && options.memory_limit == 0) {
    return invalid_argument("a tiled encode needs tile_points or memory_limit > 0");
  }
  const auto start = std::chrono::steady_clock::now();
  remove_stale_temporaries(work_dir);  // a killed run's staged tiles, about 1.8 times its input
  auto impl = Impl::make(options);
  SSPC_ASSIGN_OR_RETURN(impl->store, codec::TileStore::spilled(inputs, read, {options.tile_points, options.memory_limit},
                                                               static_cast<std::uint8_t>(options.attributes), work_dir));
  const codec::TileInput& in = impl->store->input();
  if (Status size = check_size(in.points, in.bounds); !size.ok()) {
    return Status(size.code(), inputs.front().string() + (inputs.size() > 1 ? " and the files after it" : "") + ": " +
                                   size.message());
  }
  SSPC_RETURN_IF_ERROR(impl->measure());
  impl->seconds_planning = seconds_since(start);
  return TiledEncoder(std::move(impl));
}

std::size_t TiledEncoder::tile_count() const { return impl_->plan().size(); }
int TiledEncoder::level() const { return impl_->options.level; }
std::uint64_t TiledEncoder::points() const { return impl_->store->input().points; }
const std::string& TiledEncoder::dropped_fields() const { return impl_->store->input().dropped; }
std::size_t TiledEncoder::tile_points(std::size_t t) const {
  return static_cast<std::size_t>(impl_->plan().points.at(t));
}

StatusOr<std::string> TiledEncoder::Impl::job(std::size_t t) const {
  if (t >= plan().size()) return invalid_argument("tiled encode: no tile " + std::to_string(t));
  codec::TileJob job;
  job.tile = t;
  SSPC_ASSIGN_OR_RETURN(job.part, store->load(t, margin));
  job.part.colours.clear();
  job.part.las.clear();
  job.build = build;
  job.build.core_points = static_cast<std::size_t>(plan().points[t]);
  job.normals = normals;
  std::string bytes = codec::serialise_tile_job(job);
  const std::uint32_t digest = codec::tile_job_digest(bytes);
  const std::lock_guard lock(digests_mutex);
  digests.resize(plan().size());
  digests[t] = digest;
  return bytes;
}

// The digest of tile t's job, made again when this encoder has not made the job (a result
// kept from an earlier run of the same plan).
StatusOr<std::uint32_t> TiledEncoder::Impl::job_digest(std::size_t t) const {
  {
    const std::lock_guard lock(digests_mutex);
    if (t < digests.size() && digests[t]) return *digests[t];
  }
  SSPC_ASSIGN_OR_RETURN(const std::string bytes, job(t));
  return codec::tile_job_digest(bytes);
}

// A result is tile t's when it names tile t, quotes the digest of tile t's job, carries the
// plan's radius and spacing, and places its patches' centres in the tile (its own points, within
// a patch radius of its box): anything else was mis-routed, replayed from another plan, or made
// by another build.
Status TiledEncoder::Impl::check_identity(std::size_t t, const codec::TileResult& tile) const {
  if (tile.tile != t) {
    return invalid_argument("the result of tile " + std::to_string(tile.tile) + " given for tile " + std::to_string(t));
  }
  SSPC_ASSIGN_OR_RETURN(const std::uint32_t digest, job_digest(t));
  if (tile.job_digest != digest) {
    return invalid_argument("the result is of another job for tile " + std::to_string(t) +
                            " (another input, options or plan)");
  }
  if (tile.model.patch_radius != build.patch_radius || tile.model.spacing != static_cast<float>(build.spacing)) {
    return invalid_argument("the result's patch radius or spacing is not the plan's");
  }
  const Box3f& box = plan().boxes[t];
  const Vec3f reach = Vec3f::Constant(build.patch_radius);
  const Box3f allowed(box.min() - reach, box.max() + reach);
  for (const codec::PatchInstance& p : tile.model.patches) {
    if (!allowed.contains(p.region_centre())) {
      return invalid_argument("the result has a patch centred outside tile " + std::to_string(t));
    }
  }
  return Status();
}

StatusOr<std::string> TiledEncoder::job(std::size_t t) const { return impl_->job(t); }

namespace {

Status write_bytes(const std::filesystem::path& path, std::string_view bytes) {
  return write_file_atomically(path, std::as_bytes(std::span(bytes.data(), bytes.size())));
}

std::string_view view(const MappedFile& file) {
  const std::span<const std::byte> bytes = file.bytes();
  return {reinterpret_cast<const char*>(bytes.data()), bytes.size()};
}

}  // namespace

Status TiledEncoder::write_job(std::size_t t, const std::filesystem::path& path) const {
  SSPC_ASSIGN_OR_RETURN(const std::string bytes, job(t));
  return write_bytes(path, bytes);
}

Status TiledEncoder::begin(const std::filesystem::path& output) {
  Impl& m = *impl_;
  if (m.writer) return invalid_argument("tiled encode: begin() twice");
  m.stop_writing();  // after a finish(): the same encoder writes the model again
  const codec::TileInput& in = m.store->input();
  codec::BuildStats& bs = m.build_stats;
  bs.spacing = m.build.spacing;
  bs.patch_radius = static_cast<double>(m.build.patch_radius);
  bs.coverage_radius = static_cast<double>(m.build.patch_radius / codec::kPatchOverCoverage);
  codec::EncodedModel shared;
  shared.patch_radius = m.build.patch_radius;
  shared.coverage_radius = static_cast<float>(bs.coverage_radius);
  shared.spacing = static_cast<float>(m.build.spacing);
  shared.source_points = in.points;
  shared.has_normals = true;
  shared.bounds = in.bounds;
  set_model_fields(shared, m.options, in.origin, in.metadata);
  m.choice = container_options(m.options, m.build, bs, in.bounds, in.channels);
  SSPC_ASSIGN_OR_RETURN(codec::ContainerStreamWriter writer,
                        codec::ContainerStreamWriter::to_file(shared, m.choice.quant, output, true));
  writer.expect_tiles(m.plan().boxes);  // a tile's patch centres are its own points
  m.writer.emplace(std::move(writer));
  m.begun = std::chrono::steady_clock::now();
  return Status();
}

Status TiledEncoder::Impl::write_waiting() {
  for (auto it = waiting.find(next); it != waiting.end(); it = waiting.find(next)) {
    const Result held = std::move(it->second);
    waiting.erase(it);  // a bad result may be given again
    StatusOr<codec::TileResult> tile = internal_error("no result");
    std::string where = "tile " + std::to_string(next);
    const auto* path = std::get_if<std::filesystem::path>(&held);
    if (path == nullptr) {
      tile = codec::parse_tile_result(std::get<std::string>(held));
    } else {
      where = path->string();
      auto file = MappedFile::open(*path);
      tile = file.ok() ? codec::parse_tile_result(view(*file)) : StatusOr<codec::TileResult>(file.status());
    }
    if (!tile.ok()) return invalid_argument(where + ": " + tile.status().message());
    if (Status own = check_identity(next, *tile); !own.ok()) return invalid_argument(where + ": " + own.message());
    if (path != nullptr) {
      std::error_code ignored;
      std::filesystem::remove(*path, ignored);
    }
    patches += tile->model.patches.size();
    codewords += tile->model.codebook.size();
    build_stats.codebook.candidates_tested += tile->stats.codebook.candidates_tested;
    build_stats.codebook.codeword_points += tile->stats.codebook.codeword_points;
    max_coverage_distance = std::max(max_coverage_distance, tile->max_coverage_distance);
    SSPC_RETURN_IF_ERROR(writer->add_tile(std::move(tile->model)));
    ++next;
  }
  return Status();
}

Status TiledEncoder::Impl::accept(std::size_t t, Result result) {
  if (!writer) return invalid_argument("tiled encode: a result added before begin()");
  if (t >= plan().size() || t < next || waiting.contains(t)) {
    return invalid_argument("tiled encode: a result for tile " + std::to_string(t) + " given twice or out of range");
  }
  waiting.emplace(t, std::move(result));
  return write_waiting();
}

Status TiledEncoder::add(std::size_t t, std::string result) { return impl_->accept(t, std::move(result)); }

Status TiledEncoder::add_file(std::size_t t, const std::filesystem::path& result) { return impl_->accept(t, result); }

StatusOr<EncodeStats> TiledEncoder::finish() {
  Impl& m = *impl_;
  if (!m.writer) return invalid_argument("tiled encode: finish() before begin()");
  if (m.next != tile_count()) {
    return invalid_argument("tiled encode: " + std::to_string(m.next) + " results for " +
                            std::to_string(tile_count()) + " tiles");
  }
  const auto start = std::chrono::steady_clock::now();
  SSPC_ASSIGN_OR_RETURN(const codec::ContainerStats written,
                        m.writer->finish([&m](std::size_t t, std::shared_ptr<const PointCloud>& out) -> Status {
                          SSPC_ASSIGN_OR_RETURN(PointCloud part, m.store->load(t, m.margin));
                          out = std::make_shared<const PointCloud>(std::move(part));
                          return Status();
                        }));
  m.writer.reset();
  EncodeStats stats;
  stats.points = m.store->input().points;
  stats.tiles = tile_count();
  record_written(stats, written, m.choice, m.build_stats, m.patches, m.codewords);
  stats.max_coverage_distance = m.max_coverage_distance;
  stats.seconds_writing = seconds_since(start);
  return stats;
}

StatusOr<EncodeStats> TiledEncoder::write(const std::filesystem::path& output, std::span<const std::string> results) {
  if (results.size() != tile_count()) {
    return invalid_argument("tiled encode: " + std::to_string(results.size()) + " results for " +
                            std::to_string(tile_count()) + " tiles");
  }
  SSPC_RETURN_IF_ERROR(begin(output));
  Status added;
  for (std::size_t t = 0; t < results.size() && added.ok(); ++t) added = add(t, results[t]);
  auto stats = added.ok() ? finish() : StatusOr<EncodeStats>(added);
  if (!stats.ok()) impl_->stop_writing();  // the temporary file removed; write() may be called again
  return stats;
}

// What a tile's encode holds per point of the tile (its job and margin, normals, the search
// tree, patches, code book and the result's bytes), with the freed memory the sspc CLI keeps for
// reuse (sspc/allocator.hpp): measured at level 5 under a 2 GiB limit, autzen in 2 tiles of 5.3M
// peaked at 1,926 MB (337 bytes a point of a tile), 100M generated points in 26 tiles of at most
// 5.75M at 2,467 MB (at least 407); 470 leaves room for a tile whose margin is relatively larger.
// (Without kept memory 100M peaked at 1,847 MB, but ran at 98k points/s instead of 126k.)
// Those figures predate the encoder's memory changes (CHANGELOG, "Encoding holds a third of the
// memory"), which left 470 conservative: 1B points at level 5 under 2 GiB then peaked at
// 1,005 MiB (docs/RESULTS.md, "Scale"). Larger tiles would cost fewer margins; to be re-measured.
// What the writer holds for the whole model grows with the cloud: a patch record (56 bytes) per
// patch until the model is written, twice that while its array grows. A level's patches hold
// some 900 points each (1B generated points made 1.1M patches at level 5), so one per 512 points
// is the bound: 0.22 bytes a point, 220 MB of a 2 GiB limit at 1B points.
StatusOr<std::uint64_t> tile_points_for_memory(std::uint64_t memory_limit_bytes, std::uint64_t points) {
  constexpr std::uint64_t kFixed = 128ull << 20;  // the plan's grid, the read chunks
  constexpr std::uint64_t kPerPoint = 470;
  constexpr std::uint64_t kLeast = 1u << 16;
  const std::uint64_t model = points / 512 * 2 * sizeof(codec::PatchInstance);
  const std::uint64_t reserved = kFixed + model;
  if (memory_limit_bytes < reserved + kLeast * kPerPoint) {
    return invalid_argument("a memory limit of " + std::to_string(memory_limit_bytes >> 20) + " MiB is too small for " +
                            std::to_string(points) + " points: at least " +
                            std::to_string(((reserved + kLeast * kPerPoint) >> 20) + 1) + " MiB");
  }
  return (memory_limit_bytes - reserved) / kPerPoint;
}

namespace {

StatusOr<std::string> run_parsed_tile_job(codec::TileJob job, std::uint32_t digest) {
  // The tile's points and then its margin's, each in the order sspc::encode takes a cloud's
  // points in (codec::point_order).
  const std::size_t core =
      job.build.core_points == 0 ? job.part.size() : std::min<std::size_t>(job.build.core_points, job.part.size());
  std::vector<std::uint32_t> order = codec::point_order(std::span(job.part.positions).first(core));
  for (std::uint32_t i : codec::point_order(std::span(job.part.positions).subspan(core))) {
    order.push_back(static_cast<std::uint32_t>(core + i));
  }
  job.part = job.part.select(order);
  if (!job.part.has_normals()) SSPC_RETURN_IF_ERROR(ensure_normals(job.part, job.normals));
  codec::TileResult result;
  result.tile = job.tile;
  result.job_digest = digest;
  SSPC_ASSIGN_OR_RETURN(result.model, codec::build_model(job.part, job.build, &result.stats));
  std::vector<Vec3f> origins;
  origins.reserve(result.model.patches.size());
  for (const codec::PatchInstance& p : result.model.patches) origins.push_back(p.region_centre());
  result.max_coverage_distance = codec::max_distance_to_centres(
      std::span(job.part.positions).first(job.build.core_points), origins);
  if (Status made = codec::check_tile_result(result); !made.ok()) {
    return invalid_argument("tile job " + std::to_string(job.tile) + ": its points make no valid model (" +
                            made.message() + ")");
  }
  return codec::serialise_tile_result(result);
}

// What earlier tiles freed is kept for reuse (sspc/allocator.hpp) until it holds the process
// within `headroom` of the limit; then it is given back, before the next step that allocates much.
void release_near_limit(std::uint64_t limit, std::uint64_t headroom) {
  if (limit > 0 && resident_bytes() > limit - headroom) release_freed_memory();
}

}  // namespace

StatusOr<std::string> run_tile_job(std::string_view bytes) {
  SSPC_ASSIGN_OR_RETURN(codec::TileJob job, codec::parse_tile_job(bytes));
  return run_parsed_tile_job(std::move(job), codec::tile_job_digest(bytes));
}

Status run_tile_job_file(const std::filesystem::path& job, const std::filesystem::path& result) {
  SSPC_ASSIGN_OR_RETURN(const MappedFile file, MappedFile::open(job));
  auto bytes = run_tile_job(view(file));
  if (!bytes.ok()) return Status(bytes.status().code(), job.string() + ": " + bytes.status().message());
  return write_bytes(result, *bytes);
}

StatusOr<EncodeStats> TiledEncoder::run(const std::filesystem::path& output, Progress* progress) {
  const auto start = std::chrono::steady_clock::now();
  SSPC_RETURN_IF_ERROR(begin(output));
  progress_begin(progress, "tiles", tile_count(), "tiles");
  ResidentWatch watch(impl_->options.memory_limit);
  const auto stop = [this](Status status) {
    impl_->stop_writing();  // the temporary file removed
    return status;
  };
  for (std::size_t t = 0; t < tile_count(); ++t) {
    // The job's bytes are freed once parsed, and its points once encoded, so that neither is
    // held while the result is added beside the model's growing records.
    StatusOr<codec::TileJob> job = internal_error("no job");
    std::uint32_t digest = 0;
    {
      SSPC_ASSIGN_OR_RETURN(const std::string bytes, this->job(t));
      job = codec::parse_tile_job(bytes);
      digest = codec::tile_job_digest(bytes);
    }
    if (!job.ok()) return job.status();
    SSPC_ASSIGN_OR_RETURN(std::string result, run_parsed_tile_job(std::move(*job), digest));
    const std::uint64_t limit = impl_->options.memory_limit;
    // add() parses the result and trims and writes the tiles it completes, their code books read
    // back from disk: at 1B points under 2 GiB it took up to 180 MB more while the process held
    // 1.8 GB it had freed, a peak 6% under the limit a fifth of the way in, with the model's
    // records still to grow. A quarter of the limit is left for it; after it, an eighth.
    release_near_limit(limit, limit / 4);
    SSPC_RETURN_IF_ERROR(add(t, std::move(result)));
    release_near_limit(limit, limit / 8);
    if (Status held = watch.check("tile " + std::to_string(t + 1) + " of " + std::to_string(tile_count())); !held.ok()) {
      return stop(held);
    }
    progress_advance(progress, 1);
  }
  progress_end(progress);
  const double seconds_tiles = seconds_since(start);
  auto stats = finish();
  if (!stats.ok()) impl_->stop_writing();
  if (stats.ok()) stats->seconds_codebook = seconds_tiles;  // normals, centres and code books
  return stats;
}

StatusOr<EncodeStats> encode_file(const std::filesystem::path& input, const std::filesystem::path& output,
                                  const EncodeOptions& options, const ReadOptions& read) {
  return encode_files(std::span(&input, 1), output, options, read);
}

StatusOr<EncodeStats> encode_files(std::span<const std::filesystem::path> inputs, const std::filesystem::path& output,
                                   const EncodeOptions& options, const ReadOptions& read) {
  if (options.memory_limit == 0) {
    SSPC_ASSIGN_OR_RETURN(PointCloud cloud, read_point_clouds(inputs, read));
    return encode(std::move(cloud), output, options);
  }
  const std::filesystem::path dir = output.parent_path().empty() ? std::filesystem::path(".") : output.parent_path();
  SSPC_ASSIGN_OR_RETURN(TiledEncoder tiled, TiledEncoder::plan_files(inputs, options, read, dir));
  return tiled.run(output, options.progress);
}

}  // namespace sspc
