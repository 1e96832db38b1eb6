// The encoder's geometry pipeline on synthetic surfaces: coverage, valid transforms, and a
// self-similar surface collapsing to a small code book whose instances reproduce it.
#include "encoder/model_builder.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

#include "encoder/patch_centres.hpp"
#include "geometry/normals_steps.hpp"
#include "sspc/metrics.hpp"
#include "sspc/neighbours.hpp"
#include "sspc/synthetic.hpp"

namespace sspc::codec {
namespace {

// Every instance's whole sphere: the overlap decode, enough to measure the fit.
PointCloud expand_overlapping(const EncodedModel& model) {
  PointCloud out;
  for (const PatchInstance& patch : model.patches) {
    const Codeword& cw = model.codebook[patch.codeword];
    for (const Vec3f& p : cw.points) out.positions.push_back(patch.world_from_codeword.apply(p));
  }
  return out;
}

// A plane covered with exact copies of one sampled bump tile, the tile finer than a patch: the
// self-similarity the codec exists for, down to the samples. Every patch has an exact copy
// less than half a tile away from any other patch's position, so matched instances reproduce
// the points themselves.
PointCloud tiled_bumps(int tiles_per_side, std::size_t points_per_tile) {
  const double pitch = 1.0 / tiles_per_side;
  const PointCloud tile = synthetic::bumps(points_per_tile, pitch, 1, 0.3 * pitch);
  PointCloud cloud;
  for (int i = 0; i < tiles_per_side; ++i) {
    for (int j = 0; j < tiles_per_side; ++j) {
      const Vec3f offset(static_cast<float>(pitch * i), static_cast<float>(pitch * j), 0);
      for (std::size_t p = 0; p < tile.size(); ++p) {
        cloud.positions.push_back(tile.positions[p] + offset);
        cloud.normals.push_back(tile.normals[p]);
      }
    }
  }
  return cloud;
}

BuildOptions options_for_level(int level) {
  BuildOptions options;
  options.level = level_params(level);
  return options;
}

// Large models take larger patches (levels.cpp): the row's size up to 2^22 points (every scan of
// an object), twice it up to 2^23, four times it beyond (eight at levels 8 and 9), and the rest
// of the row as it is.
TEST(LevelParams, PatchSizeFollowsLargeModels) {
  for (int level = kMinLevel; level <= kMaxLevel; ++level) {
    const LevelParams row = level_params(level);
    EXPECT_EQ(level_params(level, 468479).patch_points, row.patch_points) << level;  // dragon_scans
    EXPECT_EQ(level_params(level, (1u << 22) - 1).patch_points, row.patch_points) << level;
    EXPECT_EQ(level_params(level, 1u << 22).patch_points, 2 * row.patch_points) << level;
    EXPECT_EQ(level_params(level, 5000000).patch_points, 2 * row.patch_points) << level;
    // Past 2^23 points, levels 8 and 9 (grids coarser than 2 spacings) eight times.
    const int beyond = level >= 8 ? 8 : 4;
    EXPECT_EQ(level_params(level, 10653336).patch_points, beyond * row.patch_points) << level;  // autzen
    EXPECT_EQ(level_params(level, 1ull << 40).patch_points, beyond * row.patch_points) << level;
    EXPECT_LE(level_params(level, 1ull << 40).patch_points, kMaxPatchPoints);  // what --patch-points allows
    int previous = row.patch_points;
    for (std::uint64_t points = 1u << 20; points <= (1u << 25); points += points / 3) {
      const int size = level_params(level, points).patch_points;
      EXPECT_GE(size, previous) << level << " " << points;
      previous = size;
    }
    const LevelParams big = level_params(level, 10653336);
    EXPECT_EQ(big.epsilon, row.epsilon);
    EXPECT_EQ(big.tau, row.tau);
    EXPECT_EQ(big.position_step, row.position_step);
  }
}

TEST(ModelBuilder, SelfSimilarBumpsShareFewCodewords) {
  const PointCloud cloud = tiled_bumps(36, 25);
  BuildStats stats;
  // The paper's regime: 64-point patches, whose copies lie within ICP's reach, and τ = 0.4
  // spacings (the default levels accept a match only within half their grid step, see
  // encoder/levels.cpp, and use far larger patches).
  BuildOptions options;
  options.level = {64, 0.5f, 0.4f, 0.1f};
  auto built = build_model(cloud, options, &stats);
  ASSERT_TRUE(built.ok()) << built.status().to_string();
  const EncodedModel& model = *built;
  ASSERT_GT(model.codebook.size(), 0u);
  const double ratio = static_cast<double>(model.patches.size()) / static_cast<double>(model.codebook.size());
  EXPECT_GE(ratio, 10.0) << model.patches.size() << " patches, " << model.codebook.size() << " code words";
  // Every input point within the coverage radius of a region centre, after matching moved some.
  std::vector<Vec3f> centres;
  for (const PatchInstance& p : model.patches) centres.push_back(p.region_centre());
  EXPECT_LE(max_distance_to_centres(cloud.positions, centres), stats.coverage_radius);
  for (const PatchInstance& p : model.patches) {
    ASSERT_TRUE(is_rotation(p.world_from_codeword.rotation));
    ASSERT_LT(p.codeword, model.codebook.size());
  }
  const auto report = evaluate(cloud, expand_overlapping(model));
  ASSERT_TRUE(report.ok());
  EXPECT_GE(report->psnr_paper, 70.0);
  std::printf("bumps: %zu patches, %zu code words (ratio %.1f), tested %zu, repaired %zu, psnr %.2f dB\n",
              model.patches.size(), model.codebook.size(), ratio, stats.codebook.candidates_tested,
              stats.codebook.repaired, report->psnr_paper);
}

TEST(ModelBuilder, DeterministicAcrossRuns) {
  const PointCloud cloud = synthetic::torus(20000, 1.0, 0.3);
  auto built_a = build_model(cloud, options_for_level(kDefaultLevel), nullptr);
  auto built_b = build_model(cloud, options_for_level(kDefaultLevel), nullptr);
  ASSERT_TRUE(built_a.ok() && built_b.ok());
  const EncodedModel& a = *built_a;
  const EncodedModel& b = *built_b;
  ASSERT_EQ(a.patches.size(), b.patches.size());
  ASSERT_EQ(a.codebook.size(), b.codebook.size());
  for (std::size_t k = 0; k < a.patches.size(); ++k) {
    EXPECT_EQ(a.patches[k].codeword, b.patches[k].codeword);
    EXPECT_EQ(a.patches[k].world_from_codeword.rotation, b.patches[k].world_from_codeword.rotation);
    EXPECT_EQ(a.patches[k].world_from_codeword.translation, b.patches[k].world_from_codeword.translation);
  }
}

// The encoder takes the centres' feature strength from the normals' own k-NN table (16 a point,
// itself included) instead of searching again: it must be what the centres would have searched
// for (8 others a point), also where points coincide and a point is not in its own row.
TEST(ModelBuilder, FeatureStrengthFromTheNormalsSearchIsTheCentresOwn) {
  PointCloud cloud = synthetic::torus(3000, 1.0, 0.3);
  cloud.normals.clear();
  for (std::uint32_t i = 0; i < 200; ++i) cloud.positions.push_back(cloud.positions[i]);
  for (int i = 0; i < 20; ++i) cloud.positions.push_back(cloud.positions[7]);  // 22 at one place
  NormalOptions options;
  options.mode = NormalMode::kEstimate;
  KnnTable searched;
  ASSERT_TRUE(detail::ensure_normals(cloud, options, &searched).ok());
  ASSERT_EQ(searched.k, 16u);
  ASSERT_EQ(searched.count.size(), cloud.size());

  std::vector<float> from_normals(cloud.size(), -1.0f), own(cloud.size(), -1.0f);
  feature_strength(cloud, searched, from_normals);
  const KnnTable eight = KdTree3(cloud.positions).knn_batch(cloud.positions, kFeatureNeighbours, true, nullptr, false);
  feature_strength(cloud, eight, own);
  EXPECT_EQ(from_normals, own);
  EXPECT_GT(*std::max_element(own.begin(), own.end()), 0.01f);  // the torus's normals do differ

  // And the model built with it is the model built without.
  BuildOptions with = options_for_level(kDefaultLevel);
  with.feature_strength = from_normals;
  auto a = build_model(cloud, with, nullptr);
  auto b = build_model(cloud, options_for_level(kDefaultLevel), nullptr);
  ASSERT_TRUE(a.ok() && b.ok());
  ASSERT_EQ(a->patches.size(), b->patches.size());
  for (std::size_t k = 0; k < a->patches.size(); ++k) {
    EXPECT_EQ(a->patches[k].world_from_codeword.translation, b->patches[k].world_from_codeword.translation);
  }
}

// The encoder derives the spacing, patch radius and Poisson-disk start ahead (model_geometry,
// while the normals are oriented); given to build_model, they must build the model it builds
// alone, and the start must be the centres' own step 1.
TEST(ModelBuilder, GeometryDerivedAheadBuildsTheSameModel) {
  const PointCloud cloud = synthetic::torus(20000, 1.0, 0.3);
  BuildOptions options = options_for_level(kDefaultLevel);
  const KdTree3 tree(cloud.positions);
  auto geometry = model_geometry(cloud, tree, options);
  ASSERT_TRUE(geometry.ok()) << geometry.status().to_string();
  EXPECT_GT(geometry->spacing, 0.0);
  EXPECT_GT(geometry->patch_radius, 0.0f);
  ASSERT_FALSE(geometry->start.empty());
  BuildStats alone_stats;
  auto alone = build_model(cloud, options, &alone_stats);
  options.geometry = &*geometry;
  options.points_tree = &tree;
  BuildStats ahead_stats;
  auto ahead = build_model(cloud, options, &ahead_stats);
  ASSERT_TRUE(alone.ok() && ahead.ok());
  EXPECT_EQ(alone_stats.spacing, ahead_stats.spacing);
  EXPECT_EQ(alone_stats.patch_radius, ahead_stats.patch_radius);
  EXPECT_EQ(alone_stats.centres.initial, geometry->start.size());
  EXPECT_EQ(ahead_stats.centres.initial, geometry->start.size());
  ASSERT_EQ(alone->patches.size(), ahead->patches.size());
  for (std::size_t k = 0; k < alone->patches.size(); ++k) {
    EXPECT_EQ(alone->patches[k].world_from_codeword.translation, ahead->patches[k].world_from_codeword.translation);
    EXPECT_EQ(alone->patches[k].codeword, ahead->patches[k].codeword);
  }
}

// A plane sampled on a square lattice turned 17° in its plane: at the fine levels every code
// word's frame turns about the normal to follow the lattice (its x axis at 17° modulo 90°), so
// that the columns' rows run along the samples' rows; at the coarse levels, where a cell holds
// several samples, the frame stays the canonical one.
TEST(ModelBuilder, FineCodewordsFollowTheScansLattice) {
  PointCloud cloud;
  const double turn = 17.0 * std::numbers::pi / 180.0;
  for (int i = 0; i < 120; ++i) {
    for (int j = 0; j < 120; ++j) {
      const double u = i, v = j;
      cloud.positions.emplace_back(static_cast<float>(u * std::cos(turn) - v * std::sin(turn)),
                                   static_cast<float>(u * std::sin(turn) + v * std::cos(turn)), 0.0f);
      cloud.normals.emplace_back(0.0f, 0.0f, 1.0f);
    }
  }
  const auto lattice_offset_degrees = [&](const PatchInstance& patch) {
    const Vec3f x = patch.world_from_codeword.rotation.col(0);
    const double angle = std::atan2(static_cast<double>(x.y()), static_cast<double>(x.x())) - turn;
    const double quarter = std::numbers::pi / 2;
    const double off = angle - quarter * std::round(angle / quarter);
    return std::abs(off) * 180.0 / std::numbers::pi;
  };
  auto fine = build_model(cloud, options_for_level(3), nullptr);
  ASSERT_TRUE(fine.ok()) << fine.status().to_string();
  ASSERT_GE(fine->patches.size(), 2u);
  for (const PatchInstance& patch : fine->patches) {
    EXPECT_NEAR(std::abs(patch.world_from_codeword.rotation(2, 2)), 1.0f, 1e-4f);
    EXPECT_LT(lattice_offset_degrees(patch), 1.0);
  }
  auto coarse = build_model(cloud, options_for_level(8), nullptr);
  ASSERT_TRUE(coarse.ok()) << coarse.status().to_string();
  bool all_aligned = true;
  for (const PatchInstance& patch : coarse->patches) all_aligned = all_aligned && lattice_offset_degrees(patch) < 1.0;
  EXPECT_FALSE(all_aligned) << "the canonical frame of a flat patch follows no lattice";
}

}  // namespace
}  // namespace sspc::codec
