// sspc::encode: normals, the model builder, the container writer.
#include "sspc/encoder.hpp"
#include "sspc/tiled_encoder.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <numeric>
#include <string>

#include "core/stopwatch.hpp"
#include "encoder/container_writer.hpp"
#include "encoder/levels.hpp"
#include "encoder/model_builder.hpp"
#include "encoder/patch_centres.hpp"
#include "encoder/spatial_order.hpp"
#include "encoder/tile_job.hpp"
#include "encoder/tiling.hpp"
#include "format/container_format.hpp"
#include "format/quantise.hpp"
#include "sspc/neighbours.hpp"
#include "sspc/normals.hpp"

namespace sspc {

namespace {


Status check_options(const EncodeOptions& o) {
  if (o.level < codec::kMinLevel || o.level > codec::kMaxLevel) {
    return invalid_argument("level must be 0..9, got " + std::to_string(o.level));
  }
  if (o.patch_points && (*o.patch_points < 8 || *o.patch_points > 65536)) {
    return invalid_argument("patch points must be 8..65536, got " + std::to_string(*o.patch_points));
  }
  if (o.epsilon && !(*o.epsilon > 0 && *o.epsilon <= 1e3f)) {
    return invalid_argument("epsilon must be in (0, 1000], got " + std::to_string(*o.epsilon));
  }
  if (o.tau && !(*o.tau > 0 && *o.tau <= 1e3f)) {
    return invalid_argument("tau must be in (0, 1000] spacings, got " + std::to_string(*o.tau));
  }
  if (o.step && !(*o.step > 0 && *o.step <= 1e3f)) {
    return invalid_argument("step must be in (0, 1000] spacings, got " + std::to_string(*o.step));
  }
  if (o.position_bits && (*o.position_bits < 4 || *o.position_bits > 16)) {
    return invalid_argument("position bits must be 4..16, got " + std::to_string(*o.position_bits));
  }
  if (o.colour_quality < 0 || o.colour_quality > 100) {
    return invalid_argument("colour quality must be 0..100, got " + std::to_string(o.colour_quality));
  }
  if (o.intensity_step < 1 || o.intensity_step > codec::kMaxIntensityStep) {
    return invalid_argument("intensity step must be 1..4096, got " + std::to_string(o.intensity_step));
  }
  if ((o.attributes & ~kAllAttributes) != 0) return invalid_argument("unknown attribute bits");
  return Status();
}

// Weighted median of (value, weight) pairs: the value where the weights' running sum first
// reaches half their total.
double weighted_median(std::vector<std::pair<double, std::size_t>> v) {
  std::sort(v.begin(), v.end());
  std::size_t total = 0;
  for (const auto& [value, weight] : v) total += weight;
  std::size_t sum = 0;
  for (const auto& [value, weight] : v) {
    sum += weight;
    if (2 * sum >= total) return value;
  }
  return v.empty() ? 0.0 : v.back().first;
}

// The points `indices` of `cloud` (positions, and normals when it has them).
PointCloud gather(const PointCloud& cloud, std::span<const std::uint32_t> indices) {
  PointCloud out;
  out.positions.reserve(indices.size());
  for (std::uint32_t i : indices) out.positions.push_back(cloud.positions[i]);
  if (cloud.has_normals()) {
    out.normals.reserve(indices.size());
    for (std::uint32_t i : indices) out.normals.push_back(cloud.normals[i]);
  }
  return out;
}

}  // namespace

static_assert(kAttributeColour == codec::kChannelColour && kAttributeIntensity == codec::kChannelIntensity &&
              kAttributeClassification == codec::kChannelClassification &&
              kAttributeReturns == codec::kChannelReturns);

int colour_step_for_quality(int quality) {
  const int q = std::clamp(quality, 0, 100);
  return static_cast<int>(std::lround(std::exp2(static_cast<double>(100 - q) * 6.0 / 100.0)));
}

namespace {

Status check_cloud(const PointCloud& cloud) {
  SSPC_RETURN_IF_ERROR(cloud.validate());
  if (cloud.size() < 16) {
    return invalid_argument("the cloud has " + std::to_string(cloud.size()) +
                            " points; sspc encode needs at least 16");
  }
  if (cloud.size() >= 0xFFFFFFFFu) return resource_exhausted("sspc encode handles fewer than 2^32 points");
  if (!(bounding_box_diagonal(cloud) > 0)) return invalid_argument("all points coincide");
  return Status();
}

codec::BuildOptions build_options(const EncodeOptions& options) {
  codec::BuildOptions build;
  build.level = codec::level_params(options.level);
  if (options.patch_points) build.level.patch_points = *options.patch_points;
  if (options.epsilon) build.level.epsilon = *options.epsilon;
  if (options.tau) build.level.tau = *options.tau;
  if (options.step) build.level.position_step = *options.step;
  build.seed = options.seed;
  build.progress = options.progress;
  return build;
}

// From a built model to the file: attributes, quantisation, the writer, the statistics.
StatusOr<EncodeStats> write_model(const PointCloud& cloud, codec::EncodedModel model,
                                  const codec::BuildStats& build_stats, const codec::BuildOptions& build,
                                  const EncodeOptions& options, EncodeStats stats,
                                  const std::filesystem::path& output) {
  model.has_normals = model.has_normals && options.store_normals;
  // Attributes are coded per patch, never per code word (a code word's colours would show on
  // every instance of it).
  model.has_colours = false;
  codec::AttributeParams attributes;
  attributes.channels = static_cast<std::uint8_t>(codec::channels_present(cloud) & options.attributes);
  attributes.colour_step = colour_step_for_quality(options.colour_quality);
  attributes.intensity_step = options.intensity_step;
  // Positions are coded as they are, local to the cloud's origin; the file keeps the origin.
  model.metadata.origin = cloud.origin;
  model.metadata.cloud = cloud.metadata;
  model.metadata.cloud.extra_bytes_records.clear();  // the extra bytes themselves are not coded
  stats.seconds_centres = build_stats.seconds_centres;
  stats.seconds_codebook = build_stats.seconds_codebook;
  stats.seconds_descriptors = build_stats.codebook.seconds_descriptors;

  const auto start = std::chrono::steady_clock::now();
  codec::QuantOptions quant;
  // The level's step in spacings, exactly (the writer sizes the grid to it), unless the bits are
  // given.
  const auto radius = static_cast<float>(build_stats.patch_radius);
  float step = 0;
  if (options.position_bits) {
    quant.position_bits = *options.position_bits;
    step = codec::position_step(radius, quant.position_bits);
  } else {
    step = static_cast<float>(static_cast<double>(build.level.position_step) * build_stats.spacing);
    quant.position_step = step;
    quant.position_bits = codec::position_bits_for_step(radius, step);
  }
  quant.trim_unclaimed = !options.full_spheres;
  quant.keep_duplicates = options.keep_duplicates;
  quant.attributes = attributes;
  quant.attribute_source = &cloud;
  // The transforms' grids follow the code words' grid: a rotation error at the patch radius
  // below half its step (the worst case measured in QuantiseTest is about 3.7·R / 2^bits, so
  // two bits more than the positions), and translations on half its step.
  quant.rotation_bits = std::clamp(quant.position_bits + 2, codec::kMinRotationBits, codec::kMaxRotationBits);
  // The translation grid must span the model in |v| < 2^24 steps.
  const float extent = (cloud.bounding_box().max() - cloud.bounding_box().min()).maxCoeff();
  quant.translation_step = std::max(step / 2, extent / static_cast<float>(1 << 23));
  progress_begin(options.progress, "writing", 1, "files");
  SSPC_ASSIGN_OR_RETURN(const codec::ContainerStats written, codec::write_container(model, quant, output));
  progress_advance(options.progress, 1);
  progress_end(options.progress);
  stats.seconds_writing = seconds_since(start);

  stats.patches = model.patches.size();
  stats.codewords = model.codebook.size();
  stats.codebook_ratio = stats.codewords > 0 ? static_cast<double>(stats.patches) / static_cast<double>(stats.codewords) : 0.0;
  stats.untrimmed_codeword_points = build_stats.codebook.codeword_points;
  stats.codeword_points = written.codeword_points;
  stats.position_bits = quant.position_bits;
  stats.position_step = static_cast<double>(step);
  stats.spacing = build_stats.spacing;
  stats.patch_radius = build_stats.patch_radius;
  stats.coverage_radius = build_stats.coverage_radius;
  // Over the instances' final origins, whose cells the decoder emits (the centres may have
  // moved in matching).
  std::vector<Vec3f> origins;
  for (const codec::PatchInstance& p : model.patches) origins.push_back(p.region_centre());
  stats.max_coverage_distance = codec::max_distance_to_centres(cloud.positions, origins);
  stats.candidates_tested = build_stats.codebook.candidates_tested;
  stats.file_bytes = written.file_bytes;
  stats.codebook_bytes = written.codebook_bytes;
  stats.patch_bytes = written.patch_bytes;
  stats.attribute_bytes = written.attribute_bytes;
  stats.colour_bytes = written.channel_bytes[0];
  stats.intensity_bytes = written.channel_bytes[1];
  stats.classification_bytes = written.channel_bytes[2];
  stats.returns_bytes = written.channel_bytes[3];
  stats.attributes = attributes.channels;
  stats.colour_step = (attributes.channels & codec::kChannelColour) ? attributes.colour_step : 0;
  stats.bits_per_point = 8.0 * static_cast<double>(written.file_bytes) / static_cast<double>(stats.points);
  return stats;
}


// The tiles' models joined: code-word indices offset, one spatial order over all patches,
// code words numbered by first use, as an untiled build leaves them.
codec::EncodedModel join_tiles(std::vector<codec::TileResult>& tiles, const PointCloud& cloud,
                               const codec::BuildOptions& build, codec::BuildStats* stats) {
  codec::EncodedModel model;
  model.patch_radius = build.patch_radius;
  model.coverage_radius = build.patch_radius / codec::kPatchOverCoverage;
  model.spacing = static_cast<float>(build.spacing);
  model.source_points = cloud.size();
  model.has_normals = true;
  model.bounds = cloud.bounding_box();
  stats->spacing = build.spacing;
  stats->patch_radius = build.patch_radius;
  stats->coverage_radius = model.coverage_radius;
  for (codec::TileResult& tile : tiles) {
    const auto offset = static_cast<std::uint32_t>(model.codebook.size());
    for (codec::Codeword& w : tile.model.codebook) model.codebook.push_back(std::move(w));
    for (codec::PatchInstance p : tile.model.patches) {
      p.codeword += offset;
      model.patches.push_back(p);
    }
    stats->codebook.candidates_tested += tile.stats.codebook.candidates_tested;
    stats->codebook.codeword_points += tile.stats.codebook.codeword_points;
    tile = codec::TileResult();
  }
  std::vector<Vec3f> origins;
  origins.reserve(model.patches.size());
  for (const codec::PatchInstance& p : model.patches) origins.push_back(p.region_centre());
  std::vector<codec::PatchInstance> sorted;
  sorted.reserve(model.patches.size());
  for (std::uint32_t k : codec::spatial_order(origins, model.bounds)) sorted.push_back(model.patches[k]);
  model.patches = std::move(sorted);
  codec::number_codewords_by_first_use(model);
  return model;
}

}  // namespace

struct TiledEncoder::Impl {
  PointCloud cloud;
  EncodeOptions options;
  codec::TilePlan plan;
  codec::BuildOptions build;  // spacing and patch radius set
  NormalOptions normals;
  float margin = 0;
  double seconds_planning = 0;

  // The tile's own points first, then its neighbours' within `reach` of its box.
  std::vector<std::uint32_t> with_margin(std::size_t t, float reach) const {
    std::vector<std::uint32_t> indices = plan.points[t];
    const Box3f box(plan.boxes[t].min() - Vec3f::Constant(reach), plan.boxes[t].max() + Vec3f::Constant(reach));
    for (std::size_t u = 0; u < plan.boxes.size(); ++u) {
      if (u == t || !box.intersects(plan.boxes[u])) continue;
      for (std::uint32_t i : plan.points[u]) {
        if (box.contains(cloud.positions[i])) indices.push_back(i);
      }
    }
    return indices;
  }
};

TiledEncoder::TiledEncoder(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
TiledEncoder::TiledEncoder(TiledEncoder&&) noexcept = default;
TiledEncoder& TiledEncoder::operator=(TiledEncoder&&) noexcept = default;
TiledEncoder::~TiledEncoder() = default;

StatusOr<TiledEncoder> TiledEncoder::plan(PointCloud cloud, const EncodeOptions& options) {
  SSPC_RETURN_IF_ERROR(check_options(options));
  SSPC_RETURN_IF_ERROR(check_cloud(cloud));
  if (options.tile_points == 0) return invalid_argument("a tiled encode needs tile_points > 0");
  const auto start = std::chrono::steady_clock::now();
  auto impl = std::make_unique<Impl>();
  Impl& m = *impl;
  m.cloud = std::move(cloud);
  m.options = options;
  m.options.progress = nullptr;
  m.build = build_options(options);
  m.build.progress = nullptr;
  m.normals = options.normals;
  m.normals.progress = nullptr;
  m.plan = codec::plan_tiles(m.cloud.positions, options.tile_points);
  // The spacing over a tile and a margin of 8 of its own spacings (a point at the tile's
  // border has its nearest neighbour across it: the tile alone read bunny's spacing 4% long),
  // and the radius from spheres about the tiles' own points counted over a margin of three
  // times a flat sampling's radius; both the weighted medians over the tiles.
  // Measured on the eight largest tiles (ties to the first): enough for a median, and planning
  // stays a small serial part of a distributed encode (dragon_scans in 32 tiles: 2.1 s over all
  // of them, against 1.9 s for all the jobs on one core).
  std::vector<std::size_t> sampled(m.plan.boxes.size());
  std::iota(sampled.begin(), sampled.end(), std::size_t{0});
  std::stable_sort(sampled.begin(), sampled.end(), [&](std::size_t a, std::size_t b) {
    return m.plan.points[a].size() > m.plan.points[b].size();
  });
  sampled.resize(std::min<std::size_t>(sampled.size(), 8));
  std::sort(sampled.begin(), sampled.end());
  std::vector<std::pair<double, std::size_t>> spacings, radii;
  for (const std::size_t t : sampled) {
    if (m.plan.points[t].size() < 16) continue;
    const double own = nominal_spacing(KdTree3(gather(m.cloud, m.plan.points[t]).positions));
    if (!(own > 0)) continue;
    const PointCloud near = gather(m.cloud, m.with_margin(t, static_cast<float>(8 * own)));
    const double spacing = nominal_spacing(KdTree3(near.positions));
    if (spacing > 0) spacings.emplace_back(spacing, m.plan.points[t].size());
  }
  if (spacings.empty()) return invalid_argument("no tile has 16 distinct points; use larger tiles");
  m.build.spacing = weighted_median(spacings);
  const double guess =
      3 * m.build.spacing * std::sqrt(static_cast<double>(m.build.level.patch_points) / std::numbers::pi);
  for (const std::size_t t : sampled) {
    if (m.plan.points[t].size() < 16) continue;
    const PointCloud part = gather(m.cloud, m.with_margin(t, static_cast<float>(guess)));
    const KdTree3 tree(part.positions);
    radii.emplace_back(codec::radius_for_patch_points(part, tree, m.build.spacing, m.build.level.patch_points,
                                                      m.plan.points[t].size()),
                       m.plan.points[t].size());
  }
  m.build.patch_radius = static_cast<float>(std::min(weighted_median(radii), bounding_box_diagonal(m.cloud)));
  m.margin = static_cast<float>(1.5 * double{m.build.patch_radius} + 8 * m.build.spacing);
  m.seconds_planning = seconds_since(start);
  return TiledEncoder(std::move(impl));
}

std::size_t TiledEncoder::tile_count() const { return impl_->plan.boxes.size(); }
int TiledEncoder::level() const { return impl_->options.level; }
std::size_t TiledEncoder::tile_points(std::size_t t) const { return impl_->plan.points.at(t).size(); }

std::string TiledEncoder::job(std::size_t t) const {
  codec::TileJob job;
  job.part = gather(impl_->cloud, impl_->with_margin(t, impl_->margin));
  job.build = impl_->build;
  job.build.core_points = impl_->plan.points.at(t).size();
  job.normals = impl_->normals;
  return codec::serialise_tile_job(job);
}

StatusOr<EncodeStats> TiledEncoder::write(const std::filesystem::path& output, std::span<const std::string> results) {
  Impl& m = *impl_;
  if (results.size() != m.plan.boxes.size()) {
    return invalid_argument("tiled encode: " + std::to_string(results.size()) + " results for " +
                            std::to_string(m.plan.boxes.size()) + " tiles");
  }
  std::vector<codec::TileResult> tiles;
  tiles.reserve(results.size());
  for (std::size_t t = 0; t < results.size(); ++t) {
    auto tile = codec::parse_tile_result(results[t]);
    if (!tile.ok()) return invalid_argument("tile " + std::to_string(t) + ": " + tile.status().message());
    tiles.push_back(std::move(*tile));
  }
  codec::BuildStats build_stats;
  codec::EncodedModel model = join_tiles(tiles, m.cloud, m.build, &build_stats);
  EncodeStats stats;
  stats.points = m.cloud.size();
  stats.tiles = m.plan.boxes.size();
  EncodeOptions options = m.options;
  return write_model(m.cloud, std::move(model), build_stats, m.build, options, stats, output);
}

StatusOr<std::string> run_tile_job(std::string_view bytes) {
  SSPC_ASSIGN_OR_RETURN(codec::TileJob job, codec::parse_tile_job(bytes));
  if (!job.part.has_normals()) SSPC_RETURN_IF_ERROR(ensure_normals(job.part, job.normals));
  codec::TileResult result;
  SSPC_ASSIGN_OR_RETURN(result.model, codec::build_model(job.part, job.build, &result.stats));
  return codec::serialise_tile_result(result);
}

StatusOr<EncodeStats> encode(PointCloud cloud, const std::filesystem::path& output,
                             const EncodeOptions& options) {
  if (options.tile_points > 0 && cloud.size() > options.tile_points) {
    // The jobs run here one after the other, each in parallel inside: the same bytes as on Dask.
    // TiledEncoder::plan checks the options and the cloud.
    const auto start = std::chrono::steady_clock::now();
    SSPC_ASSIGN_OR_RETURN(TiledEncoder tiled, TiledEncoder::plan(std::move(cloud), options));
    std::vector<std::string> results;
    progress_begin(options.progress, "tiles", tiled.tile_count(), "tiles");
    for (std::size_t t = 0; t < tiled.tile_count(); ++t) {
      SSPC_ASSIGN_OR_RETURN(std::string result, run_tile_job(tiled.job(t)));
      results.push_back(std::move(result));
      progress_advance(options.progress, 1);
    }
    progress_end(options.progress);
    const double seconds_tiles = seconds_since(start);
    auto stats = tiled.write(output, results);
    if (stats.ok()) stats->seconds_codebook = seconds_tiles;  // normals, centres and code books
    return stats;
  }
  SSPC_RETURN_IF_ERROR(check_options(options));
  SSPC_RETURN_IF_ERROR(check_cloud(cloud));
  EncodeStats stats;
  stats.points = cloud.size();
  auto start = std::chrono::steady_clock::now();
  NormalOptions normal_options = options.normals;
  normal_options.progress = options.progress;
  SSPC_RETURN_IF_ERROR(ensure_normals(cloud, normal_options));
  stats.seconds_normals = seconds_since(start);
  const codec::BuildOptions build = build_options(options);
  codec::BuildStats build_stats;
  SSPC_ASSIGN_OR_RETURN(codec::EncodedModel model, codec::build_model(cloud, build, &build_stats));
  return write_model(cloud, std::move(model), build_stats, build, options, stats, output);
}

}  // namespace sspc
