#include "encoder/model_builder.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <optional>

#include "core/parallel.hpp"
#include "core/stopwatch.hpp"
#include "sspc/neighbours.hpp"

namespace sspc::codec {

void number_codewords_by_first_use(EncodedModel& model) {
  constexpr std::uint32_t kUnused = 0xFFFFFFFFu;
  std::vector<std::uint32_t> new_index(model.codebook.size(), kUnused);
  std::vector<Codeword> codebook;
  codebook.reserve(model.codebook.size());
  for (PatchInstance& p : model.patches) {
    std::uint32_t& to = new_index[p.codeword];
    if (to == kUnused) {
      to = static_cast<std::uint32_t>(codebook.size());
      codebook.push_back(std::move(model.codebook[p.codeword]));
    }
    p.codeword = to;
  }
  model.codebook = std::move(codebook);  // a code word no patch uses is dropped
}

float radius_for_patch_points(const PointCloud& cloud, const KdTree3& tree, double spacing, int patch_points,
                              std::size_t sample_from) {
  const std::size_t pool = sample_from == 0 ? cloud.size() : std::min(sample_from, cloud.size());
  // First guess: a disc of area patch_points · spacing².
  double radius = spacing * std::sqrt(static_cast<double>(patch_points) / std::numbers::pi);
  const std::size_t samples = std::min<std::size_t>(pool, 2000);
  const std::size_t stride = pool / samples;
  // Two corrections: the count grows like r² on a surface.
  for (int round = 0; round < 2; ++round) {
    const auto r = static_cast<float>(radius);
    const double total = deterministic_sum<double>(0, samples, [&](std::size_t s) {
      return static_cast<double>(tree.radius_count(cloud.positions[s * stride], r));
    }, 64);
    const double mean = total / static_cast<double>(samples);
    if (mean <= 0) break;
    radius *= std::sqrt(static_cast<double>(patch_points) / mean);
  }
  // A cloud of fewer points than a patch would grow the radius without bound (every sphere
  // already holds all of it); no patch needs to be wider than the cloud.
  return static_cast<float>(std::min(radius, static_cast<double>(bounding_box_diagonal(cloud))));
}

StatusOr<ModelGeometry> model_geometry(const PointCloud& cloud, const KdTree3& tree, const BuildOptions& options) {
  ModelGeometry geometry;
  // Of the distinct positions: a radius of 0 would divide by zero downstream.
  geometry.spacing = options.spacing > 0 ? options.spacing : nominal_spacing(tree);
  SSPC_RETURN_IF_ERROR(check_geometry_range(cloud.positions, geometry.spacing));
  geometry.patch_radius = options.patch_radius > 0
                              ? options.patch_radius
                              : radius_for_patch_points(cloud, tree, geometry.spacing, options.level.patch_points);
  if (options.core_points == 0 || options.core_points >= cloud.size()) {
    const CentreOptions centre_options;
    geometry.start = poisson_disk_start(cloud.positions, geometry.patch_radius / kPatchOverCoverage * centre_options.spread,
                                        options.seed, nullptr);
  }
  return geometry;
}

StatusOr<EncodedModel> build_model(const PointCloud& cloud, const BuildOptions& options, BuildStats* stats) {
  std::optional<KdTree3> own_tree;
  if (options.points_tree == nullptr) own_tree.emplace(cloud.positions);
  const KdTree3& tree = options.points_tree != nullptr ? *options.points_tree : *own_tree;
  std::optional<ModelGeometry> own_geometry;
  if (options.geometry == nullptr) {
    SSPC_ASSIGN_OR_RETURN(own_geometry, model_geometry(cloud, tree, options));
  }
  const ModelGeometry& geometry = options.geometry != nullptr ? *options.geometry : *own_geometry;
  const double spacing = geometry.spacing;
  const float patch_radius = geometry.patch_radius;
  const float coverage_radius = patch_radius / kPatchOverCoverage;

  auto start = std::chrono::steady_clock::now();
  CentreOptions centre_options;
  centre_options.coverage_radius = coverage_radius;
  centre_options.seed = options.seed;
  centre_options.progress = options.progress;
  CentreStats centre_stats;
  std::vector<Vec3f> centres;
  if (options.core_points > 0 && options.core_points < cloud.size()) {
    PointCloud core;
    const auto end = static_cast<std::ptrdiff_t>(options.core_points);
    core.positions.assign(cloud.positions.begin(), cloud.positions.begin() + end);
    core.normals.assign(cloud.normals.begin(), cloud.normals.begin() + end);
    const KdTree3 core_tree(core.positions);
    centres = choose_patch_centres(core, core_tree, centre_options, &centre_stats);
  } else {
    centre_options.strength = options.feature_strength;
    centre_options.start = geometry.start;
    centres = choose_patch_centres(cloud, tree, centre_options, &centre_stats);
  }
  const double seconds_centres = seconds_since(start);

  start = std::chrono::steady_clock::now();
  CodebookOptions cb;
  cb.patch_radius = patch_radius;
  cb.coverage_radius = coverage_radius;
  cb.spacing = static_cast<float>(spacing);
  cb.epsilon = options.level.epsilon;
  cb.tau = options.level.tau;
  cb.covered_points = options.core_points;
  cb.keep_normals = options.codeword_normals;
  cb.align_to_lattice = options.level.position_step > 0 && options.level.position_step <= kLatticeAlignedStep;
  cb.progress = options.progress;
  CodebookStats codebook_stats;
  EncodedModel model = build_codebook(cloud, tree, centres, cb, &codebook_stats);
  number_codewords_by_first_use(model);
  if (stats != nullptr) {
    stats->spacing = spacing;
    stats->patch_radius = static_cast<double>(patch_radius);
    stats->coverage_radius = static_cast<double>(coverage_radius);
    stats->centres = centre_stats;
    stats->codebook = codebook_stats;
    stats->seconds_centres = seconds_centres;
    stats->seconds_codebook = seconds_since(start);
  }
  return model;
}

}  // namespace sspc::codec
