// Greedy code-book construction (Hubo et al. 2007, §4.3).
#include "encoder/codebook_builder.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <memory>
#include <numeric>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "core/parallel.hpp"
#include "encoder/canonical_frame.hpp"
#include "encoder/codeword_surface.hpp"
#include "encoder/patch_match.hpp"
#include "encoder/spatial_order.hpp"

namespace sspc::codec {

namespace {

// Patches as compressed rows of point indices.
struct Patches {
  std::vector<std::uint64_t> offsets;  // patches + 1
  std::vector<std::uint32_t> indices;
  std::span<const std::uint32_t> operator[](std::size_t k) const {
    return {indices.data() + offsets[k], static_cast<std::size_t>(offsets[k + 1] - offsets[k])};
  }
  std::size_t size() const { return offsets.size() - 1; }
};

Patches gather_patches(const KdTree3& tree, std::span<const Vec3f> centres, float radius) {
  std::vector<std::vector<std::uint32_t>> rows(centres.size());
  parallel_for_ranges(0, centres.size(), 64, [&](std::size_t begin, std::size_t end) {
    std::vector<Neighbour> near;
    for (std::size_t k = begin; k < end; ++k) {
      tree.radius(centres[k], radius, near, false);
      rows[k].reserve(near.size());
      for (const Neighbour& nb : near) rows[k].push_back(nb.index);
      std::sort(rows[k].begin(), rows[k].end());
    }
  });
  Patches patches;
  patches.offsets.resize(centres.size() + 1, 0);
  for (std::size_t k = 0; k < rows.size(); ++k) patches.offsets[k + 1] = patches.offsets[k] + rows[k].size();
  patches.indices.resize(patches.offsets.back());
  parallel_for(0, rows.size(), 256, [&](std::size_t k) {
    std::copy(rows[k].begin(), rows[k].end(), patches.indices.begin() + static_cast<std::ptrdiff_t>(patches.offsets[k]));
  });
  return patches;
}

// Surface variation λ0 / (λ0 + λ1 + λ2) of the patch's points (Pauly et al. 2002): 0 on a plane,
// up to 1/3 for isotropic scatter. The greedy selection takes the flattest patches first.
float surface_variation(std::span<const Vec3f> positions, std::span<const std::uint32_t> indices) {
  if (indices.size() < 3) return 0;
  Vec3d mean = Vec3d::Zero();
  for (std::uint32_t i : indices) mean += positions[i].cast<double>();
  mean /= static_cast<double>(indices.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (std::uint32_t i : indices) {
    const Vec3d d = positions[i].cast<double>() - mean;
    cov += d * d.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
  solver.computeDirect(cov, Eigen::EigenvaluesOnly);
  const Vec3d l = solver.eigenvalues().cwiseMax(0.0);
  const double sum = l.sum();
  return sum > 0 ? static_cast<float>(l(0) / sum) : 0.0f;
}

struct PatchFrames {
  std::vector<RigidTransform> world_from_canonical;
  std::vector<float> curvature;
  std::vector<float> descriptors;  // patches × dimension
};

PatchFrames describe_patches(const PointCloud& cloud, const Patches& patches, const DescriptorParams& params) {
  PatchFrames f;
  const std::size_t n = patches.size();
  const auto dim = static_cast<std::size_t>(params.dimension());
  f.world_from_canonical.resize(n);
  f.curvature.resize(n);
  f.descriptors.resize(n * dim);
  parallel_for_ranges(0, n, 64, [&](std::size_t begin, std::size_t end) {
    std::vector<Vec3f> canonical_normals;
    for (std::size_t k = begin; k < end; ++k) {
      const auto idx = patches[k];
      const CanonicalFrame frame = canonical_frame(cloud.positions, cloud.normals, idx);
      f.world_from_canonical[k] = frame.world_from_canonical;
      const Eigen::Matrix3f canonical_from_world = frame.world_from_canonical.rotation.transpose();
      canonical_normals.clear();
      for (std::uint32_t i : idx) canonical_normals.push_back(canonical_from_world * cloud.normals[i]);
      compute_descriptor(canonical_normals, params, std::span<float>(f.descriptors.data() + k * dim, dim));
      f.curvature[k] = surface_variation(cloud.positions, idx);
    }
  });
  return f;
}

// A code word's frame: the canonical rotation of its patch turned about the normal so that the
// frame's x and y axes follow the directions of the scan's sampling lattice, where the patch has
// one. The columns (format/column_coder.hpp) code occupancy in rows of the frame's grid; a
// lattice at an angle to them lays its points in a pattern the ten-cell context learns poorly.
// The lattice's direction is the 4-fold mean of the directions to each sampled point's nearest
// neighbour, in the tangent plane.
Eigen::Matrix3f lattice_aligned(const Eigen::Matrix3f& world_from_canonical, const PointCloud& cloud,
                                const KdTree3& tree, std::span<const std::uint32_t> idx) {
  // 256 directions, the first quarter of them (every fourth) asked first: a patch whose 64
  // show no order (autzen's, whose flight lines overlap) stops there. The mean resultant length
  // of 64 random directions is about 1/8; the k-NN queries of all 256 cost autzen's level-5
  // encode about 1 s, and 64 alone lost bunny 0.6% at level 5 (a less certain angle).
  constexpr std::size_t kSamples = 256;
  constexpr std::size_t kFirst = 4;  // every kFirst-th sample first
  constexpr double kMinOrder = 0.3;
  constexpr double kNoOrder = 0.2;   // of the first ones: no lattice
  const std::size_t stride = std::max<std::size_t>(1, idx.size() / kSamples);
  const std::size_t samples = (idx.size() + stride - 1) / stride;
  const Vec3f ex = world_from_canonical.col(0), ey = world_from_canonical.col(1);
  // Each sample's 4-fold direction (cos 4φ, sin 4φ), or nothing where its nearest neighbour
  // lies at its own position; summed in sample order, whichever pass asked.
  std::vector<std::array<double, 2>> direction(samples);
  std::vector<bool> found(samples, false);
  const auto ask = [&](std::size_t s) {
    const Vec3f& p = cloud.positions[idx[s * stride]];
    std::uint32_t near[2];
    float d2[2];
    if (tree.knn(p, 2, near, d2) < 2 || !(d2[1] > 0)) return;
    const Vec3f d = cloud.positions[near[1]] - p;
    const double phi = std::atan2(static_cast<double>(d.dot(ey)), static_cast<double>(d.dot(ex)));
    direction[s] = {std::cos(4 * phi), std::sin(4 * phi)};
    found[s] = true;
  };
  const auto order = [&](double& c4, double& s4, std::size_t& count) {
    c4 = s4 = 0;
    count = 0;
    for (std::size_t s = 0; s < samples; ++s) {
      if (!found[s]) continue;
      c4 += direction[s][0];
      s4 += direction[s][1];
      ++count;
    }
  };
  double c4 = 0, s4 = 0;
  std::size_t count = 0;
  for (std::size_t s = 0; s < samples; s += kFirst) ask(s);
  order(c4, s4, count);
  if (count == 0 || std::hypot(c4, s4) < kNoOrder * static_cast<double>(count)) return world_from_canonical;
  for (std::size_t s = 0; s < samples; ++s) {
    if (s % kFirst != 0) ask(s);
  }
  order(c4, s4, count);
  if (count == 0 || std::hypot(c4, s4) < kMinOrder * static_cast<double>(count)) return world_from_canonical;
  const double theta = std::atan2(s4, c4) / 4;
  const Eigen::Matrix3f turn =
      Eigen::AngleAxisf(static_cast<float>(theta), Vec3f::UnitZ()).toRotationMatrix();
  return world_from_canonical * turn;
}

// The code word taken from patch `rep`: its points in the frame with origin at the centre and
// the canonical rotation.
Codeword make_codeword(const PointCloud& cloud, std::span<const std::uint32_t> idx,
                       const RigidTransform& world_from_codeword) {
  const RigidTransform codeword_from_world = world_from_codeword.inverse();
  Codeword cw;
  cw.points.reserve(idx.size());
  for (std::uint32_t i : idx) cw.points.push_back(codeword_from_world.apply(cloud.positions[i]));
  if (cloud.has_normals()) {
    cw.normals.reserve(idx.size());
    for (std::uint32_t i : idx) cw.normals.push_back(codeword_from_world.apply_vector(cloud.normals[i]));
  }
  if (cloud.has_colours()) {
    cw.colours.reserve(idx.size());
    for (std::uint32_t i : idx) cw.colours.push_back(cloud.colours[i]);
  }
  return cw;
}

// A matched code word's normals given back, when the file will store none.
void drop_normals(Codeword& w) {
  w.normals.clear();
  w.normals.shrink_to_fit();
}

// The descriptors of the patches still in the pool, indexed for L1 k-NN queries. The pool only
// shrinks, so the tree is rebuilt over the eligible patches once a quarter of its items have
// left: queries then touch few stale items, and the rebuilds cost O(n log n) in all.
struct DescriptorPool {
  std::vector<std::uint32_t> ids;  // pool item → patch
  std::vector<float> data;
  std::unique_ptr<KdTreeL1> tree;

  template <typename Eligible>
  void rebuild(const std::vector<float>& descriptors, std::size_t dim, std::size_t n, Eligible eligible) {
    tree.reset();
    ids.clear();
    data.clear();
    for (std::uint32_t k = 0; k < n; ++k) {
      if (!eligible(k)) continue;
      ids.push_back(k);
      data.insert(data.end(), descriptors.begin() + static_cast<std::ptrdiff_t>(k * dim),
                  descriptors.begin() + static_cast<std::ptrdiff_t>((k + 1) * dim));
    }
    if (!ids.empty()) tree = std::make_unique<KdTreeL1>(data, dim);
  }
};

// Matches may move an instance's origin (see try_match), and the decoder's regions are the cells
// of the origins: every point must lie within the coverage radius of one, or its cell's code
// word need not reach it. Points left uncovered get new patches of their own, greedily in index
// order, each its own code word. Then the patches are put back in spatial order.
std::size_t repair_coverage(const PointCloud& cloud, const KdTree3& points_tree, const CodebookOptions& o,
                            EncodedModel& model) {
  std::vector<Vec3f> origins;
  origins.reserve(model.patches.size());
  for (const PatchInstance& p : model.patches) origins.push_back(p.region_centre());
  const std::size_t to_cover = o.covered_points == 0 ? cloud.size() : std::min(o.covered_points, cloud.size());
  std::vector<std::uint8_t> uncovered(to_cover, 0);
  {
    const KdTree3 origin_tree(origins);
    const float r2 = o.coverage_radius * o.coverage_radius;
    parallel_for(0, to_cover, 4096, [&](std::size_t i) {
      float d2 = 0;
      origin_tree.nearest(cloud.positions[i], &d2);
      uncovered[i] = d2 > r2 ? 1 : 0;
    });
  }
  std::vector<Vec3f> added;
  const float r2 = o.coverage_radius * o.coverage_radius;
  for (std::size_t i = 0; i < to_cover; ++i) {
    if (uncovered[i] == 0) continue;
    const Vec3f& p = cloud.positions[i];
    bool near_added = false;
    for (const Vec3f& c : added) {
      if ((c - p).squaredNorm() <= r2) {
        near_added = true;
        break;
      }
    }
    if (!near_added) added.push_back(p);
  }
  std::vector<Neighbour> near;
  std::vector<std::uint32_t> idx;
  for (const Vec3f& c : added) {
    points_tree.radius(c, o.patch_radius, near, false);
    idx.clear();
    for (const Neighbour& nb : near) idx.push_back(nb.index);
    std::sort(idx.begin(), idx.end());
    RigidTransform world_from_codeword;
    world_from_codeword.rotation = canonical_frame(cloud.positions, cloud.normals, idx).world_from_canonical.rotation;
    if (o.align_to_lattice) world_from_codeword.rotation = lattice_aligned(world_from_codeword.rotation, cloud, points_tree, idx);
    world_from_codeword.translation = c;
    model.patches.push_back({static_cast<std::uint32_t>(model.codebook.size()), world_from_codeword, true});
    model.codebook.push_back(make_codeword(cloud, idx, world_from_codeword));
    if (!o.keep_normals) drop_normals(model.codebook.back());
  }
  if (!added.empty()) {
    std::vector<Vec3f> all;
    for (const PatchInstance& p : model.patches) all.push_back(p.region_centre());
    const std::vector<std::uint32_t> order = spatial_order(all, cloud.bounding_box());
    std::vector<PatchInstance> sorted;
    sorted.reserve(order.size());
    for (std::uint32_t k : order) sorted.push_back(model.patches[k]);
    model.patches = std::move(sorted);
  }
  return added.size();
}

}  // namespace

EncodedModel build_codebook(const PointCloud& cloud, const KdTree3& points_tree,
                            std::span<const Vec3f> centres, const CodebookOptions& o,
                            CodebookStats* stats) {
  Progress* progress = o.progress;
  EncodedModel model;
  model.patch_radius = o.patch_radius;
  model.coverage_radius = o.coverage_radius;
  model.spacing = o.spacing;
  model.source_points = cloud.size();
  model.has_normals = cloud.has_normals();
  model.has_colours = cloud.has_colours();
  model.bounds = cloud.bounding_box();
  const std::size_t n = centres.size();

  progress_begin(progress, "patches: gather, frames, descriptors", n, "patches");
  const auto describe_start = std::chrono::steady_clock::now();
  const Patches patches = gather_patches(points_tree, centres, o.patch_radius);
  const PatchFrames frames = describe_patches(cloud, patches, o.descriptor);
  progress_advance(progress, n);
  progress_end(progress);
  if (stats != nullptr) {
    stats->seconds_descriptors = std::chrono::duration<double>(std::chrono::steady_clock::now() - describe_start).count();
  }

  const auto dim = static_cast<std::size_t>(o.descriptor.dimension());
  std::vector<std::uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    return frames.curvature[a] < frames.curvature[b] || (frames.curvature[a] == frames.curvature[b] && a < b);
  });

  constexpr std::uint32_t kUnassigned = 0xFFFFFFFFu;
  std::vector<std::uint32_t> assigned(n, kUnassigned);
  // A rejected candidate returns to the pool (paper §4.3), but with a wide ε the same patch
  // would be aligned again by every later representative near it in descriptor space: the
  // encoder turned quadratic on dragon_scans. After kMaxAttempts failed alignments a patch waits
  // to become a code word itself.
  constexpr std::uint8_t kMaxAttempts = 4;
  std::vector<std::uint8_t> attempts(n, 0);
  model.patches.resize(n);
  std::size_t tested = 0, accepted = 0, done = 0;
  // Speculative batches: the greedy loop is sequential by nature (each representative removes
  // patches from the pool), and on autzen most representatives have one or two candidates, so
  // parallelising one representative's alignments left a core idle. Instead the next kBatch
  // unassigned representatives in curvature order are aligned with their candidates in
  // parallel, against the state at the batch's start; then the greedy loop is replayed over the
  // batch sequentially with the current state, taking the precomputed alignments (an alignment
  // depends only on the two patches). The state only grows (assigned stays assigned, attempts
  // only increase), so every candidate the replay accepts was aligned in the parallel phase, and
  // the result is exactly the sequential loop's, on any number of threads. Work is wasted only
  // when a member is absorbed by an earlier one or a candidate is taken first.
  constexpr std::size_t kBatch = 64;
  // A representative aligns at most its kMaxCandidates nearest pool patches in descriptor space
  // (those within ε). The paper aligns every patch within ε; on terrain (autzen) nearly all
  // patches are flat and within ε of each other, and the radius queries alone made the loop
  // quadratic (142 patches/s).
  constexpr std::size_t kMaxCandidates = 48;
  struct Speculation {
    Codeword codeword;
    RigidTransform world_from_codeword;
    std::vector<std::uint32_t> candidates;
    std::vector<Match> matches;
  };
  std::vector<std::uint32_t> batch;
  std::vector<Speculation> speculation(kBatch);
  std::size_t next = 0;
  const auto eligible = [&](std::uint32_t k) { return assigned[k] == kUnassigned && attempts[k] < kMaxAttempts; };
  DescriptorPool pool;
  std::size_t retired = 0;  // pool items no longer eligible since the pool was built
  progress_begin(progress, "code book: greedy clustering", n, "patches");
  while (next < order.size()) {
    if (pool.ids.empty() || retired * 4 >= pool.ids.size()) {
      pool.rebuild(frames.descriptors, dim, n, eligible);
      retired = 0;
    }
    const std::size_t done_before = done;
    batch.clear();
    while (next < order.size() && batch.size() < kBatch) {
      const std::uint32_t r = order[next++];
      if (assigned[r] == kUnassigned) batch.push_back(r);
    }
    parallel_for(0, batch.size(), 1, [&](std::size_t b) {
      const std::uint32_t rep = batch[b];
      Speculation& sp = speculation[b];
      // The code word's frame: the representative's canonical rotation about its centre.
      sp.world_from_codeword.rotation = frames.world_from_canonical[rep].rotation;
      if (o.align_to_lattice) {
        sp.world_from_codeword.rotation = lattice_aligned(sp.world_from_codeword.rotation, cloud, points_tree, patches[rep]);
      }
      sp.world_from_codeword.translation = centres[rep];
      sp.codeword = make_codeword(cloud, patches[rep], sp.world_from_codeword);
      std::vector<L1Neighbour> near;
      sp.candidates.clear();
      if (pool.tree) {
        pool.tree->knn(std::span<const float>(frames.descriptors.data() + rep * dim, dim), kMaxCandidates, near);
      }
      for (const L1Neighbour& nb : near) {
        const std::uint32_t k = pool.ids[nb.index];
        if (nb.distance > o.epsilon || k == rep || !eligible(k)) continue;
        // The match test keeps the region's point count within 10%; patches whose spheres'
        // counts differ by more than a quarter practically never pass it, and skipping their
        // alignment saved a third of autzen's clustering time.
        const std::size_t mine = patches[k].size(), theirs = patches[rep].size();
        if (4 * mine > 5 * theirs || 4 * theirs > 5 * mine) continue;
        sp.candidates.push_back(k);
      }
      sp.matches.assign(sp.candidates.size(), Match{});
      if (sp.candidates.empty()) return;
      const CodewordSurface surface(sp.codeword.points, sp.codeword.normals);
      const RigidTransform codeword_from_rep_canonical =
          sp.world_from_codeword.inverse() * frames.world_from_canonical[rep];
      for (std::size_t c = 0; c < sp.candidates.size(); ++c) {
        const std::uint32_t k = sp.candidates[c];
        sp.matches[c] = try_match(cloud, points_tree, patches[k], centres[k], frames.world_from_canonical[k],
                                  codeword_from_rep_canonical, surface, o);
      }
    });
    for (std::size_t b = 0; b < batch.size(); ++b) {
      const std::uint32_t rep = batch[b];
      if (assigned[rep] != kUnassigned) continue;  // absorbed by an earlier member
      Speculation& sp = speculation[b];
      const auto cw_index = static_cast<std::uint32_t>(model.codebook.size());
      model.codebook.push_back(std::move(sp.codeword));
      if (!o.keep_normals) drop_normals(model.codebook.back());
      model.patches[rep] = {cw_index, sp.world_from_codeword, true};
      if (attempts[rep] < kMaxAttempts) ++retired;
      assigned[rep] = cw_index;
      ++done;
      // As the sequential loop: first the candidate list under the current state (counting
      // the attempts), then the accepted ones.
      std::size_t kept = 0;
      for (std::size_t c = 0; c < sp.candidates.size(); ++c) {
        const std::uint32_t k = sp.candidates[c];
        if (!eligible(k)) continue;
        if (++attempts[k] == kMaxAttempts) ++retired;
        sp.candidates[kept] = k;
        sp.matches[kept] = sp.matches[c];
        ++kept;
      }
      tested += kept;
      for (std::size_t c = 0; c < kept; ++c) {
        if (!sp.matches[c].accepted) continue;
        const std::uint32_t k = sp.candidates[c];
        if (attempts[k] < kMaxAttempts) ++retired;  // else it retired when it ran out of attempts
        assigned[k] = cw_index;
        model.patches[k] = {cw_index, sp.matches[c].world_from_codeword, false};
        ++accepted;
        ++done;
      }
    }
    progress_advance(progress, done - done_before);
  }
  progress_end(progress);
  const std::size_t repaired = repair_coverage(cloud, points_tree, o, model);

  if (stats != nullptr) {
    stats->patches = n;
    stats->codewords = model.codebook.size();
    stats->candidates_tested = tested;
    stats->accepted = accepted;
    stats->repaired = repaired;
    stats->mean_patch_points = n > 0 ? static_cast<double>(patches.indices.size()) / static_cast<double>(n) : 0.0;
    std::size_t points = 0;
    for (const Codeword& cw : model.codebook) points += cw.points.size();
    stats->codeword_points = points;
  }
  return model;
}

}  // namespace sspc::codec
