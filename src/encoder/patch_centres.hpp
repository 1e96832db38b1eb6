// Patch centres (Hubo et al. 2007, §4.1): centres spread evenly over the surface,
// drawn to features, and covering every input point.
//
// 1. A deterministic Poisson-disk subset of the points (a seeded random order; a point becomes
//    a centre unless one is already within spread·R, see CentreOptions::spread). This gives
//    the even spread Turk's repulsion aims at in one linear pass.
// 2. Rounds of Turk/Pauly repulsion (centres closer than spread·R push each other apart) and feature
//    attraction (c := Σ C_p p / Σ C_p over the points of the patch, C_p the standard deviation
//    of n_p·n_q over p's neighbours q), each followed by projection onto the tangent plane of
//    the nearest input point. The rounds are Jacobi steps: new positions from old ones only,
//    so the result does not depend on the thread count.
// 3. Coverage repair: moving centres can open gaps, so every point farther than R from all
//    centres is covered by new centres (greedily, in index order). After it, every input point
//    lies within R of a centre — the guarantee the decoder's regions rely on.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "sspc/neighbours.hpp"
#include "sspc/point_cloud.hpp"
#include "sspc/progress.hpp"

namespace sspc::codec {

struct CentreOptions {
  float coverage_radius = 0;  // R: every point ends within R of a centre
  // The Poisson-disk start and the repulsion keep centres this many R apart. At 1 (a disk of
  // radius R) random sequential placement packs about 1.8 times the centres an optimal covering
  // needs; at 1.3 the coverage repair fills the gaps it leaves and the total is 12% lower
  // (dragon_scans, bunny), with the same PSNR. Above 1.5 the repair adds more than it saves.
  float spread = 1.3f;
  int repulsion_rounds = 2;
  int attraction_rounds = 1;
  std::uint64_t seed = 1;
  Progress* progress = nullptr;
  // C_p of every point when the caller has it (feature_strength from the normals' own k-NN
  // table); empty: searched here.
  std::span<const float> strength;
  // Step 1's centres when the caller has them (poisson_disk_start with coverage_radius · spread
  // and this seed); empty: drawn here.
  std::span<const Vec3f> start;
};

struct CentreStats {
  std::size_t initial = 0;   // Poisson-disk centres
  std::size_t repaired = 0;  // added by the coverage repair
};

// Step 1 alone: a point becomes a centre unless one is already within `spread` (the points in
// a random order from `seed`). Positions only; advances `progress` by one a point.
std::vector<Vec3f> poisson_disk_start(std::span<const Vec3f> positions, float spread, std::uint64_t seed,
                                      Progress* progress);

// `points_tree` indexes `cloud.positions`; `cloud` must have unit normals. The centres come back
// in a spatial (Morton) order. Requires coverage_radius > 0.
std::vector<Vec3f> choose_patch_centres(const PointCloud& cloud, const KdTree3& points_tree,
                                        const CentreOptions& options, CentreStats* stats);

// C_p for every point (the attraction's weight): the standard deviation of n_p.n_q over p's
// kFeatureNeighbours nearest other points q, taken from `neighbours`, a table of the cloud's own
// points whose rows hold at least kFeatureNeighbours + 1 (the point itself may be among them,
// and is passed over): the normals' search serves, and gives what choose_patch_centres would
// search for itself, bit for bit.
constexpr std::size_t kFeatureNeighbours = 8;
// Written to `strength` (one a point).
void feature_strength(const PointCloud& cloud, const KnnTable& neighbours, std::span<float> strength);

// Every point's distance to its nearest centre, maximum: for tests and statistics.
double max_distance_to_centres(std::span<const Vec3f> points, std::span<const Vec3f> centres);

}  // namespace sspc::codec
