// sspc::encode: normals, the model builder, the container writer.
#include "sspc/encoder.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>

#include "core/stopwatch.hpp"
#include "encoder/container_writer.hpp"
#include "encoder/levels.hpp"
#include "encoder/model_builder.hpp"
#include "encoder/patch_centres.hpp"
#include "format/container_format.hpp"
#include "format/quantise.hpp"

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

}  // namespace

static_assert(kAttributeColour == codec::kChannelColour && kAttributeIntensity == codec::kChannelIntensity &&
              kAttributeClassification == codec::kChannelClassification &&
              kAttributeReturns == codec::kChannelReturns);

int colour_step_for_quality(int quality) {
  const int q = std::clamp(quality, 0, 100);
  return static_cast<int>(std::lround(std::exp2(static_cast<double>(100 - q) * 6.0 / 100.0)));
}

StatusOr<EncodeStats> encode(PointCloud cloud, const std::filesystem::path& output,
                             const EncodeOptions& options) {
  SSPC_RETURN_IF_ERROR(check_options(options));
  SSPC_RETURN_IF_ERROR(cloud.validate());
  if (cloud.size() < 16) {
    return invalid_argument("the cloud has " + std::to_string(cloud.size()) +
                            " points; sspc encode needs at least 16");
  }
  if (cloud.size() >= 0xFFFFFFFFu) return resource_exhausted("sspc encode handles fewer than 2^32 points");
  if (!(bounding_box_diagonal(cloud) > 0)) return invalid_argument("all points coincide");

  EncodeStats stats;
  stats.points = cloud.size();
  auto start = std::chrono::steady_clock::now();
  NormalOptions normal_options = options.normals;
  normal_options.progress = options.progress;
  SSPC_RETURN_IF_ERROR(ensure_normals(cloud, normal_options));
  stats.seconds_normals = seconds_since(start);

  codec::BuildOptions build;
  build.level = codec::level_params(options.level);
  if (options.patch_points) build.level.patch_points = *options.patch_points;
  if (options.epsilon) build.level.epsilon = *options.epsilon;
  if (options.tau) build.level.tau = *options.tau;
  if (options.step) build.level.position_step = *options.step;
  build.seed = options.seed;
  build.progress = options.progress;
  codec::BuildStats build_stats;
  SSPC_ASSIGN_OR_RETURN(codec::EncodedModel model, codec::build_model(cloud, build, &build_stats));
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

  start = std::chrono::steady_clock::now();
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

}  // namespace sspc
