// The encoder's geometry pipeline (Hubo et al. 2007, §4.1–4.3) from a cloud with normals to the in-memory
// compressed model: patch size from the point density, centres, patches, code book.
#pragma once

#include <cstdint>
#include <vector>

#include "encoder/codebook_builder.hpp"
#include "encoder/levels.hpp"
#include "encoder/patch_centres.hpp"
#include "format/encoded_model.hpp"
#include "sspc/point_cloud.hpp"
#include "sspc/progress.hpp"

namespace sspc::codec {

// Code words hold the points within patch_radius of a centre; centres cover every point within
// coverage_radius = patch_radius / kPatchOverCoverage (after matching, the coverage repair in
// codebook_builder restores that for the instances' final origins). The margin lets a code word
// reach past the region of an instance whose origin a match moved (up to half a coverage
// radius), and the writer trims what no instance decodes.
inline constexpr float kPatchOverCoverage = 1.25f;

// What build_model derives from the positions alone, before it needs any normal: the spacing,
// the patch radius, and the centres' Poisson-disk start (CentreOptions::start). The encoder
// derives it on one core while the other orients the normals (model_geometry), build_model
// when it is not given.
struct ModelGeometry {
  double spacing = 0;
  float patch_radius = 0;
  std::vector<Vec3f> start;  // empty with core_points: the centres are the core's own
};

struct BuildOptions {
  LevelParams level;
  // A tile of a tiled encode (encoder/tiling.hpp): the whole model's spacing and patch radius
  // instead of the cloud's own (0: measure them), and centres chosen to cover the first
  // `core_points` points only (0: all), the rest being the tile's margin.
  double spacing = 0;
  float patch_radius = 0;
  std::size_t core_points = 0;
  // The code words keep their points' normals (CodebookOptions::keep_normals): only when the
  // file stores them.
  bool codeword_normals = true;
  // C_p of every point, when the normals' search gave it (CentreOptions::strength); not used
  // with core_points, whose centres see only the core.
  std::span<const float> feature_strength;
  // A tree over the cloud's positions the caller built already (for the normals), or null.
  const KdTree3* points_tree = nullptr;
  // model_geometry(cloud, tree, these options)'s result, derived already, or null.
  const ModelGeometry* geometry = nullptr;
  std::uint64_t seed = 1;
  Progress* progress = nullptr;
};

struct BuildStats {
  double spacing = 0;
  double patch_radius = 0;
  double coverage_radius = 0;
  CentreStats centres;
  CodebookStats codebook;
  double seconds_centres = 0;
  double seconds_codebook = 0;
};

// Reads cloud.positions only (not the normals): it may run while they are being written.
StatusOr<ModelGeometry> model_geometry(const PointCloud& cloud, const KdTree3& tree, const BuildOptions& options);

// `cloud` must have unit normals and at least 2 distinct points.
StatusOr<EncodedModel> build_model(const PointCloud& cloud, const BuildOptions& options, BuildStats* stats);

// Renumbers the code words in the order patches (in file order, which is spatial) first use
// them. The greedy builder numbers them by curvature, so neighbouring patches' indices were far
// apart; in first-use order most patches of a sparse code book refer to the next new code word,
// and a patch block's index deltas cost zstd almost nothing. Code-book blocks then also follow
// the patches' spatial order, so a region decode touches fewer of them.
void number_codewords_by_first_use(EncodedModel& model);

// The radius whose sphere holds `patch_points` points on average, measured on a deterministic
// sample of the cloud (the nominal spacing alone misjudges the area per point on noisy or
// layered scans). With `sample_from` > 0 the sample is drawn from the first `sample_from`
// points only (a tile's own, the rest being its margin, so that spheres are not cut at its
// border).
float radius_for_patch_points(const PointCloud& cloud, const KdTree3& tree, double spacing, int patch_points,
                              std::size_t sample_from = 0);

}  // namespace sspc::codec
