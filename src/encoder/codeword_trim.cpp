#include "encoder/codeword_trim.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "core/parallel.hpp"
#include "format/quantise.hpp"
#include "format/region_decoder.hpp"
#include "sspc/neighbours.hpp"

namespace sspc::codec {

namespace {

// A code word's points as a reader decodes them, and |q|² computed as the reader computes it.
struct DecodedPoints {
  std::vector<Vec3f> points;
  std::vector<float> norm2;
  float radius = 0;
};

DecodedPoints decode_positions(const Codeword& w, float step, int bits) {
  DecodedPoints d;
  d.points.reserve(w.points.size());
  d.norm2.reserve(w.points.size());
  float max_norm2 = 0;
  for (const Vec3f& p : w.points) {
    float xyz[3];
    for (int a = 0; a < 3; ++a) {
      xyz[a] = dequantise_coordinate(quantise_coordinate(p[a], step, bits), step, bits);
    }
    d.points.emplace_back(xyz[0], xyz[1], xyz[2]);
    d.norm2.push_back(xyz[0] * xyz[0] + xyz[1] * xyz[1] + xyz[2] * xyz[2]);
    max_norm2 = std::max(max_norm2, d.norm2.back());
  }
  d.radius = std::sqrt(max_norm2);
  return d;
}

// A copy of `model` with everything but the code book.
EncodedModel without_codebook(const EncodedModel& model) {
  EncodedModel out;
  out.patch_radius = model.patch_radius;
  out.coverage_radius = model.coverage_radius;
  out.spacing = model.spacing;
  out.source_points = model.source_points;
  out.has_normals = model.has_normals;
  out.has_colours = model.has_colours;
  out.bounds = model.bounds;
  out.metadata = model.metadata;
  out.patches = model.patches;
  return out;
}

// A normal as the merge leaves a cell's only point's: normalised (up to an ulp from unit).
Vec3f merged_normal(const Vec3f& sum, const Vec3f& first) {
  return sum.norm() > 1e-6f ? Vec3f(sum.normalized()) : first;
}

// Merges the points of `w` that share a cell of the grid, in place.
void merge_cells(Codeword& w, float step, int bits) {
  const std::size_t n = w.points.size();
  std::vector<std::pair<std::uint64_t, std::uint32_t>> cells;
  cells.reserve(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    const Vec3f& p = w.points[i];
    const std::uint64_t x = quantise_coordinate(p.x(), step, bits), y = quantise_coordinate(p.y(), step, bits),
                        z = quantise_coordinate(p.z(), step, bits);
    cells.emplace_back(x << 32 | y << 16 | z, i);
  }
  // By cell, then by index: each run starts with the cell's first point.
  std::sort(cells.begin(), cells.end());
  const bool shared = std::adjacent_find(cells.begin(), cells.end(), [](const auto& a, const auto& b) {
                        return a.first == b.first;
                      }) != cells.end();
  if (!shared) {  // one point a cell: the code word as it is, its normals normalised as below
    for (Vec3f& normal : w.normals) normal = merged_normal(normal, normal);
    return;
  }
  // The output keeps the code word's order of first points: each run found from its first
  // point's index in one pass (a second sort of the runs cost about as much as the first).
  // Written in place: the j-th kept point goes to index j, at most its first point's index, and
  // every index of a run is at least its first's, so a run is read before anything overwrites
  // it. (A second code word built beside the first made merging the encoder's peak on
  // dragon_scans: 56 of 159 MB, the new vectors' growth included.)
  constexpr auto kNone = static_cast<std::uint32_t>(-1);
  std::vector<std::uint32_t> run_at(n, kNone);  // a first point's index -> its run's start in `cells`
  for (std::size_t b = 0; b < n;) {
    std::size_t e = b + 1;
    while (e < n && cells[e].first == cells[b].first) ++e;
    run_at[cells[b].second] = static_cast<std::uint32_t>(b);
    b = e;
  }
  std::size_t kept = 0;
  for (std::uint32_t first = 0; first < n; ++first) {
    if (run_at[first] == kNone) continue;
    const std::size_t begin = run_at[first];
    std::size_t end = begin + 1;
    while (end < n && cells[end].first == cells[begin].first) ++end;
    w.points[kept] = w.points[first];
    if (!w.normals.empty()) {
      Vec3f sum = Vec3f::Zero();
      for (std::size_t k = begin; k < end; ++k) sum += w.normals[cells[k].second];
      w.normals[kept] = merged_normal(sum, w.normals[first]);
    }
    if (!w.colours.empty()) {
      std::array<std::uint32_t, 3> sum{0, 0, 0};
      for (std::size_t k = begin; k < end; ++k) {
        const Rgb8& c = w.colours[cells[k].second];
        sum[0] += c.r;
        sum[1] += c.g;
        sum[2] += c.b;
      }
      const auto count = static_cast<std::uint32_t>(end - begin);
      const auto mean = [count](std::uint32_t s) { return static_cast<std::uint8_t>((s + count / 2) / count); };
      w.colours[kept] = Rgb8{mean(sum[0]), mean(sum[1]), mean(sum[2])};
    }
    ++kept;
  }
  const auto shrink = [kept](auto& v) {
    if (v.empty()) return;
    v.resize(kept);
    v.shrink_to_fit();
  };
  shrink(w.points);
  shrink(w.normals);
  shrink(w.colours);
}

}  // namespace

void express_in_decoded_frames(EncodedModel& model, const ContainerHeader& h) {
  constexpr auto kNone = static_cast<std::size_t>(-1);
  std::vector<std::size_t> representative(model.codebook.size(), kNone);
  for (std::size_t k = 0; k < model.patches.size(); ++k) {
    const PatchInstance& p = model.patches[k];
    if (p.representative && representative[p.codeword] == kNone) representative[p.codeword] = k;
  }
  // codeword_new_from_old per code word: decoded⁻¹ ∘ exact.
  std::vector<RigidTransform> moved(model.codebook.size());
  parallel_for(0, model.codebook.size(), 64, [&](std::size_t c) {
    if (representative[c] == kNone) return;
    const RigidTransform& exact = model.patches[representative[c]].world_from_codeword;
    RigidTransform decoded;
    decoded.rotation = decode_rotation(encode_rotation(exact.rotation, h.rotation_bits), h.rotation_bits);
    std::array<std::int32_t, 3> grid{};
    // Off the grid the writer refuses the patch block later; leave the code word as it is.
    if (!quantise_translation(exact.translation, h.bounds_min, h.translation_step, grid)) return;
    decoded.translation = dequantise_translation(grid, h.bounds_min, h.translation_step);
    moved[c] = decoded.inverse() * exact;
    Codeword& w = model.codebook[c];
    for (Vec3f& q : w.points) q = moved[c].apply(q);
    for (Vec3f& n : w.normals) n = moved[c].apply_vector(n);
  });
  for (PatchInstance& p : model.patches) {
    p.world_from_codeword = p.world_from_codeword * moved[p.codeword].inverse();
  }
}

void merge_duplicate_cells(EncodedModel& model, const ContainerHeader& h) {
  const float step = position_step(h.patch_radius, h.position_bits);
  parallel_for(0, model.codebook.size(), 16,
               [&](std::size_t c) { merge_cells(model.codebook[c], step, h.position_bits); });
}

EncodedModel trim_unclaimed_points(const EncodedModel& model, const ContainerHeader& h,
                                   TrimStats* stats, std::span<const IndexedPatch> others,
                                   std::uint32_t first_index) {
  const std::size_t n = model.patches.size();
  const std::size_t all = n + others.size();
  auto patch = [&](std::size_t k) -> const PatchInstance& {
    return k < n ? model.patches[k] : others[k - n].patch;
  };
  // Index in the whole model, which ties are broken by.
  auto index = [&](std::size_t k) {
    return k < n ? first_index + static_cast<std::uint32_t>(k) : others[k - n].index;
  };
  // The transforms as a reader decodes them.
  std::vector<Eigen::Matrix3f> rotation(n);
  std::vector<Vec3f> centre(all);
  parallel_for(0, all, 1024, [&](std::size_t k) {
    const RigidTransform& t = patch(k).world_from_codeword;
    if (k < n) rotation[k] = decode_rotation(encode_rotation(t.rotation, h.rotation_bits), h.rotation_bits);
    std::array<std::int32_t, 3> grid{};
    // Off the grid, the writer refuses the patch block (encode_patch_block) after trimming;
    // until then the centre stays where the encoder put it.
    centre[k] = quantise_translation(t.translation, h.bounds_min, h.translation_step, grid)
                    ? dequantise_translation(grid, h.bounds_min, h.translation_step)
                    : t.translation;
  });
  const float step = position_step(h.patch_radius, h.position_bits);

  // Which points some instance claims, and the trimmed code word. Each patch marks its own code
  // word's points; patches sharing a code word write `true` to the same bytes, which is
  // idempotent, but a data race all the same: group the patches by code word and let one task
  // own each code word. A code word's decoded points live only in its task (held for the whole
  // code book at once they were a third of autzen's peak: 1.2 of 3.6 GB).
  std::vector<std::vector<std::uint32_t>> instances(model.codebook.size());
  for (std::size_t k = 0; k < n; ++k) instances[model.patches[k].codeword].push_back(static_cast<std::uint32_t>(k));
  const KdTree3 centre_tree(centre);
  EncodedModel out = without_codebook(model);
  out.codebook.resize(model.codebook.size());
  parallel_for(0, model.codebook.size(), 8, [&](std::size_t c) {
    const Codeword& w = model.codebook[c];
    const DecodedPoints d = decode_positions(w, step, h.position_bits);
    std::vector<bool> keep(d.points.size(), false);
    RegionTest region;
    std::vector<Neighbour> near;
    std::vector<NeighbourInstance> neighbours;
    const float threshold2 = neighbour_threshold2(d.radius);
    for (const std::uint32_t k : instances[c]) {
      // A slightly larger query, then the reader's exact test, so that N_k is exactly its N_k.
      centre_tree.radius(centre[k], 1.001f * std::sqrt(threshold2), near, false);
      neighbours.clear();
      for (const Neighbour& nb : near) {
        if (nb.index != k && centre_distance2(centre[nb.index], centre[k]) <= threshold2) {
          neighbours.push_back({index(nb.index), centre[nb.index]});
        }
      }
      region.reset(index(k), rotation[k], centre[k], neighbours);
      for (std::size_t i = 0; i < d.points.size(); ++i) {
        if (!keep[i] && region.claims(d.points[i], d.norm2[i])) keep[i] = true;
      }
    }
    const auto count = static_cast<std::size_t>(std::count(keep.begin(), keep.end(), true));
    Codeword& t = out.codebook[c];
    t.points.reserve(count);
    if (!w.normals.empty()) t.normals.reserve(count);
    if (!w.colours.empty()) t.colours.reserve(count);
    for (std::size_t i = 0; i < w.points.size(); ++i) {
      if (!keep[i]) continue;
      t.points.push_back(w.points[i]);
      if (i < w.normals.size()) t.normals.push_back(w.normals[i]);
      if (i < w.colours.size()) t.colours.push_back(w.colours[i]);
    }
  });
  std::uint64_t before = 0, after = 0;
  for (std::size_t c = 0; c < model.codebook.size(); ++c) {
    before += model.codebook[c].points.size();
    after += out.codebook[c].points.size();
  }
  if (stats != nullptr) {
    stats->points_before = before;
    stats->points_after = after;
  }
  return out;
}

}  // namespace sspc::codec
