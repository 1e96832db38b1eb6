// sspc::encode: normals, the model builder, the container writer.
#include "sspc/encoder.hpp"
#include "sspc/tiled_encoder.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <numeric>
#include <optional>
#include <string>

#include "core/format_number.hpp"
#include "core/stopwatch.hpp"
#include "encoder/container_writer.hpp"
#include "encoder/levels.hpp"
#include "encoder/model_builder.hpp"
#include "encoder/patch_centres.hpp"
#include "encoder/spatial_order.hpp"
#include "encoder/encode_steps.hpp"
#include "format/container_format.hpp"
#include "format/quantise.hpp"
#include "geometry/normals_steps.hpp"
#include "sspc/allocator.hpp"
#include "sspc/neighbours.hpp"
#include "sspc/normals.hpp"

namespace sspc {

static_assert(kAttributeColour == codec::kChannelColour && kAttributeIntensity == codec::kChannelIntensity &&
              kAttributeClassification == codec::kChannelClassification &&
              kAttributeReturns == codec::kChannelReturns);

int colour_step_for_quality(int quality) {
  const int q = std::clamp(quality, 0, 100);
  return static_cast<int>(std::lround(std::exp2(static_cast<double>(100 - q) * 6.0 / 100.0)));
}

// drop_unkept_attributes (sspc/encoder.hpp).
std::string drop_unkept_attributes(PointCloud& cloud, unsigned keep) {
  LasPointAttributes dropped = std::move(cloud.las);
  cloud.las = LasPointAttributes();
  auto take = [](auto& from, auto& to) { to = std::move(from), from = {}; };
  if (keep & kAttributeIntensity) take(dropped.intensity, cloud.las.intensity);
  if (keep & kAttributeClassification) take(dropped.classification, cloud.las.classification);
  if (keep & kAttributeReturns) {
    take(dropped.return_number, cloud.las.return_number);
    take(dropped.number_of_returns, cloud.las.number_of_returns);
  }
  // Colours are kept at 8 bits a channel (the reader's PointCloud::colours): LAS's 16-bit RGB
  // loses only what its low bytes held.
  bool low_rgb_bits = false;
  if ((keep & kAttributeColour) != 0 && cloud.has_colours()) {
    bool wide = false;
    for (const auto& c : dropped.rgb) wide = wide || std::max({c[0], c[1], c[2]}) > 255;
    for (const auto& c : dropped.rgb) {
      low_rgb_bits = low_rgb_bits || (wide && ((c[0] | c[1] | c[2]) & 0xFF) != 0);
    }
    dropped.rgb = {};
  }
  std::string names = dropped.empty() ? std::string() : dropped.names();
  if (low_rgb_bits) names = names.empty() ? "RGB's low 8 bits" : names + ", RGB's low 8 bits";
  if (cloud.has_colours() && (keep & kAttributeColour) == 0) {
    cloud.colours = {};
    names = names.empty() ? "colours" : "colours, " + names;
  }
  return names;
}

namespace encoding {

Status check_options(const EncodeOptions& o) {
  if (o.level < codec::kMinLevel || o.level > codec::kMaxLevel) {
    return invalid_argument("level must be 0..9, got " + std::to_string(o.level));
  }
  if (o.patch_points && (*o.patch_points < 8 || *o.patch_points > kMaxPatchPoints)) {
    return invalid_argument("patch points must be 8.." + std::to_string(kMaxPatchPoints) + ", got " +
                            std::to_string(*o.patch_points));
  }
  if (o.epsilon && !(*o.epsilon > 0 && *o.epsilon <= 1e3f)) {
    return invalid_argument("epsilon must be in (0, 1000], got " + format_number(double{*o.epsilon}));
  }
  if (o.tau && !(*o.tau > 0 && *o.tau <= 1e3f)) {
    return invalid_argument("tau must be in (0, 1000] spacings, got " + format_number(double{*o.tau}));
  }
  if (o.step && !(*o.step > 0 && *o.step <= 1e3f)) {
    return invalid_argument("step must be in (0, 1000] spacings, got " + format_number(double{*o.step}));
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

Status check_size(std::uint64_t points, const Box3f& bounds) {
  if (points < 16) {
    return invalid_argument("the cloud has " + std::to_string(points) + (points == 1 ? " point" : " points") +
                            "; sspc encode needs at least 16");
  }
  if (points >= 0xFFFFFFFFu) return resource_exhausted("sspc encode handles fewer than 2^32 points");
  if (bounds.isEmpty() || !((bounds.max().cast<double>() - bounds.min().cast<double>()).norm() > 0)) {
    return invalid_argument("all points coincide");
  }
  return Status();
}

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

codec::BuildOptions build_options(const EncodeOptions& options, std::uint64_t points) {
  codec::BuildOptions build;
  build.level = codec::level_params(options.level, points);
  if (options.patch_points) build.level.patch_points = *options.patch_points;
  if (options.epsilon) build.level.epsilon = *options.epsilon;
  if (options.tau) build.level.tau = *options.tau;
  if (options.step) build.level.position_step = *options.step;
  build.seed = options.seed;
  build.codeword_normals = options.store_normals;
  build.progress = options.progress;
  return build;
}

ContainerChoice container_options(const EncodeOptions& options, const codec::BuildOptions& build,
                                  const codec::BuildStats& build_stats, const Box3f& bounds, std::uint8_t channels) {
  ContainerChoice choice;
  codec::QuantOptions& quant = choice.quant;
  // The level's step in spacings, exactly (the writer sizes the grid to it), unless the bits are
  // given.
  const auto radius = static_cast<float>(build_stats.patch_radius);
  if (options.position_bits) {
    quant.position_bits = *options.position_bits;
    choice.step = codec::position_step(radius, quant.position_bits);
  } else {
    // At most an eighth of the patch radius, the grid of the format's fewest bits (4) across a
    // patch: a step of the patch's size puts every cell's centre far from the patch's centre,
    // and each point decodes outside its patch's region, which the trim then drops. The spacing
    // is a median over the distinct positions, which a few far outliers can set: 27 points at one
    // place, one 0.05 away and two some 3.4 away took a spacing of 3.3 and, at level 7, a step
    // of 5.6 for patches of radius 4.1, and decoded to no point at all (the encode round trip's
    // fuzzer). Every level of the real scans lies far below it (bunny level 9: 0.045 of the
    // patch radius), and their files are unchanged.
    const double level_step = static_cast<double>(build.level.position_step) * build_stats.spacing;
    const auto coarsest = static_cast<double>(codec::position_step(radius, codec::kMinPositionBits));
    choice.step = static_cast<float>(std::min(level_step, coarsest));
    quant.position_step = choice.step;
    quant.position_bits = codec::position_bits_for_step(static_cast<double>(radius), static_cast<double>(choice.step));
  }
  quant.trim_unclaimed = !options.full_spheres;
  quant.keep_duplicates = options.keep_duplicates;
  quant.resample = options.resample;
  quant.attributes.channels = channels;
  quant.attributes.colour_step = colour_step_for_quality(options.colour_quality);
  quant.attributes.intensity_step = options.intensity_step;
  // The transforms' grids follow the code words' grid: a rotation error at the patch radius
  // below half its step (the worst case measured in QuantiseTest is about 3.7·R / 2^bits, so
  // two bits more than the positions), and translations on half its step.
  quant.rotation_bits = std::clamp(quant.position_bits + 2, codec::kMinRotationBits, codec::kMaxRotationBits);
  // The translation grid must span the model in |v| < 2^24 steps.
  const float extent = (bounds.max() - bounds.min()).maxCoeff();
  quant.translation_step = std::max(choice.step / 2, extent / static_cast<float>(1 << 23));
  return choice;
}

void set_model_fields(codec::EncodedModel& model, const EncodeOptions& options, const Vec3d& origin,
                      const CloudMetadata& metadata) {
  model.has_normals = model.has_normals && options.store_normals;
  // Attributes are coded per patch, never per code word (a code word's colours would show on
  // every instance of it).
  model.has_colours = false;
  // Positions are coded as they are, local to the cloud's origin; the file keeps the origin.
  model.metadata.origin = origin;
  model.metadata.cloud = metadata;
  model.metadata.cloud.extra_bytes_records.clear();  // the extra bytes themselves are not coded
}

void record_written(EncodeStats& stats, const codec::ContainerStats& written, const ContainerChoice& choice,
                    const codec::BuildStats& build_stats, std::uint64_t patches, std::uint64_t codewords) {
  const codec::AttributeParams& attributes = choice.quant.attributes;
  stats.seconds_centres = build_stats.seconds_centres;
  stats.seconds_codebook = build_stats.seconds_codebook;
  stats.seconds_descriptors = build_stats.codebook.seconds_descriptors;
  stats.patches = patches;
  stats.codewords = codewords;
  stats.codebook_ratio = codewords > 0 ? static_cast<double>(patches) / static_cast<double>(codewords) : 0.0;
  stats.untrimmed_codeword_points = build_stats.codebook.codeword_points;
  stats.codeword_points = written.codeword_points;
  stats.position_bits = choice.quant.position_bits;
  stats.position_step = static_cast<double>(choice.step);
  stats.resample = written.resample;
  stats.spacing = build_stats.spacing;
  stats.patch_radius = build_stats.patch_radius;
  stats.coverage_radius = build_stats.coverage_radius;
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
}

}  // namespace encoding

namespace {

using namespace encoding;

// From a built model to the file: attributes, quantisation, the writer, the statistics.
StatusOr<EncodeStats> write_model(const PointCloud& cloud, codec::EncodedModel model,
                                  const codec::BuildStats& build_stats, const codec::BuildOptions& build,
                                  const EncodeOptions& options, EncodeStats stats,
                                  const std::filesystem::path& output) {
  set_model_fields(model, options, cloud.origin, cloud.metadata);
  const auto channels = static_cast<std::uint8_t>(codec::channels_present(cloud) & options.attributes);
  ContainerChoice choice = container_options(options, build, build_stats, cloud.bounding_box(), channels);
  choice.quant.attribute_source = &cloud;
  const auto start = std::chrono::steady_clock::now();
  progress_begin(options.progress, "writing", 1, "files");
  // Over the instances' final origins, whose cells the decoder emits (the centres may have
  // moved in matching).
  std::vector<Vec3f> origins;
  for (const codec::PatchInstance& p : model.patches) origins.push_back(p.region_centre());
  const std::size_t patches = model.patches.size(), codewords = model.codebook.size();
  // The model moves into the writer, which trims its code words: passed by reference, the
  // writer's copy and this one held the untrimmed code book twice (autzen level 5: 41M points,
  // 493 MB each) and the encode's peak was at the writing, 149-151 bytes a point.
  SSPC_ASSIGN_OR_RETURN(const codec::ContainerStats written,
                        codec::write_container(std::move(model), choice.quant, output));
  progress_advance(options.progress, 1);
  progress_end(options.progress);
  stats.seconds_writing = seconds_since(start);
  record_written(stats, written, choice, build_stats, patches, codewords);
  stats.max_coverage_distance = codec::max_distance_to_centres(cloud.positions, origins);
  return stats;
}

}  // namespace

StatusOr<EncodeStats> encode(PointCloud cloud, const std::filesystem::path& output,
                             const EncodeOptions& options) {
  if (options.tile_points > 0 && cloud.size() > options.tile_points) {
    // The jobs run here one after the other, each in parallel inside: the same bytes as on Dask.
    // TiledEncoder::plan checks the options and the cloud.
    SSPC_ASSIGN_OR_RETURN(TiledEncoder tiled, TiledEncoder::plan(std::move(cloud), options));
    return tiled.run(output, options.progress);
  }
  SSPC_RETURN_IF_ERROR(check_options(options));
  SSPC_RETURN_IF_ERROR(cloud.validate());
  SSPC_RETURN_IF_ERROR(check_size(cloud.size(), cloud.bounding_box()));
  EncodeStats stats;
  stats.points = cloud.size();
  auto start = std::chrono::steady_clock::now();
  // The points in Morton order (timed with the normals): every step after this one (the k-NN
  // searches, the orientation's tree, the centres, the code book) visits a point's neighbours,
  // and in this order they lie near it in memory. A file's order need not be spatial: autzen's
  // encode 38.0 -> 35.0 s when its points came sorted. And the same points in another order
  // give the same file.
  cloud = cloud.select(codec::point_order(cloud.positions));
  NormalOptions normal_options = options.normals;
  normal_options.progress = options.progress;
  // The normals' k-NN search gives the centres' feature strength too, when it was made and
  // holds enough neighbours a point (autzen: the centres' step 7.4 -> 2.9 s); the table itself
  // goes before the model is built. The strengths are allocated first, below the table on the
  // heap: allocated after, they kept the freed table's pages from the later steps (autzen's
  // peak 1.39 -> 1.73 GB).
  std::vector<float> strength(cloud.size());
  // One k-d tree over the points serves the normals' search and the model's (nanoflann builds
  // it on one core: 1.7 s of autzen's encode, paid twice before); it goes before the writing.
  // Leaves of 24 points, not KdTree3's 10: built in 1.0 s instead of 1.7, searched as fast
  // (k = 16 over autzen: 8.4 s either way), 55 MB smaller; autzen's encode 36.5-38.6 ->
  // 34.6-36.1 s (two interleaved runs), the same bytes.
  constexpr std::size_t kLeafPoints = 24;
  std::optional<KdTree3> tree(std::in_place, cloud.positions, kLeafPoints);
  codec::BuildOptions build = build_options(options, cloud.size());
  // What the model derives from the positions alone (spacing, patch radius, the centres'
  // Poisson-disk start), derived while the normals are oriented, on the core Prim's sequential
  // algorithm leaves idle: autzen 34.4-35.4 -> 33.3-33.5 s (two interleaved runs), same bytes.
  StatusOr<codec::ModelGeometry> geometry = Status(internal_error("model geometry not derived"));
  const auto derive_geometry = [&] { geometry = codec::model_geometry(cloud, *tree, build); };
  {
    KnnTable searched;
    SSPC_RETURN_IF_ERROR(detail::ensure_normals(cloud, normal_options, &searched, &*tree, derive_geometry));
    if (searched.k > codec::kFeatureNeighbours && searched.count.size() == cloud.size()) {
      codec::feature_strength(cloud, searched, strength);
    } else {
      strength = {};
    }
  }
  SSPC_RETURN_IF_ERROR(geometry.status());
  // The table and the orientation's arrays, about 1 GB on autzen, lie freed below blocks still
  // in use, where the kept-memory policy (sspc/allocator.hpp) would hold them resident through
  // the writing: given back here, autzen's peak is 1.44-1.47 GB, not 1.93.
  release_freed_memory();
  stats.seconds_normals = seconds_since(start);
  build.feature_strength = strength;
  build.points_tree = &*tree;
  build.geometry = &*geometry;
  codec::BuildStats build_stats;
  SSPC_ASSIGN_OR_RETURN(codec::EncodedModel model, codec::build_model(cloud, build, &build_stats));
  build.points_tree = nullptr;
  build.feature_strength = {};
  build.geometry = nullptr;
  tree.reset();
  strength = {};
  return write_model(cloud, std::move(model), build_stats, build, options, stats, output);
}

}  // namespace sspc
