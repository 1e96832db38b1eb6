// The MLS surface of a point set and its intersection with rays (Adamson & Alexa 2003,
// "Approximating and intersecting surfaces from points"; paper §5).
//
// f(x) = n(x) · (x − a(x)), where a(x) is the average of the points near x weighted by the
// Gaussian exp(−|x − p|² / h²), lowered by its value at the support radius r = 2.5h so that it
// reaches 0 there (the weights stay continuous as points enter and leave the support; e^−6.25
// is 0.2% of the peak), and n(x) is the principal axis of the weighted normals' tensor
// Σ w nnᵀ rather than their mean: it does not depend on which way each normal points. A
// cloud's orientation is a heuristic (a minimum spanning tree's propagation, Hoppe et al. 1992)
// that fails on thin parts and between scans, and with the mean normal a flip cancels the
// normals around it; rendering one cloud with two orientations scored 26.2 dB (image PSNR over
// the hit pixels, dragon_scans decoded, MST against a viewpoint). The sign of n along a ray is
// kept by continuity from the first sample, which faces the ray's origin. The surface is f = 0 where some point is
// within r (or, on request, where the support Σ w is at least a given fraction of its median at
// the points); elsewhere it is undefined, which is what ends it at the edge of a scan or a patch.
//
// Neighbours come from a uniform grid of cells at least r wide, its points stored cell by cell
// in x-major rows: the support of any x meets at most 3 × 3 rows of 3 cells, each a contiguous
// run of points, scanned without a tree walk or a heap. That is ours rather than nanoflann's
// k-d tree because a 16-nearest query was 60% of the compressed renderer's time (perf, dragon
// at 1024²) and a radius query over contiguous runs is several times cheaper; the same grid
// marks the cells near no point, which a ray crosses in one step (and blocks of 4³ and 16³ such
// cells, each in one step too).
//
// A ray is intersected by marching (render/mls_march.hpp): across cells near no point in one
// step each, near points in steps of at least h/2 watching the sign of f, and once f changes
// sign, by regula falsi on f inside that bracket: the first crossing along the ray is found
// unless two lie closer than h/2.
//
// The class is the one surface every scene uses: over a whole cloud, or over one brick's points
// (render/brick_scene.hpp).
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <span>
#include <vector>

#include "render/mls_march.hpp"
#include "sspc/point_cloud.hpp"

namespace sspc::render {

class MlsSurface {
 public:
  // Copies `points` and `normals` (unit, same length). `bandwidth` is h > 0. With
  // `edge_support` > 0 the surface ends where its support Σ w falls below that fraction of the
  // median support at the points, rather than where the last point leaves the support radius.
  // `ids`, when not empty, holds an id per point (the compressed scene's code word of each
  // point), which nearest_id() returns.
  MlsSurface(std::span<const Vec3f> points, std::span<const Vec3f> normals, float bandwidth,
             float edge_support = 0, std::span<const std::uint32_t> ids = {});

  // Ends the surface where its support Σ w falls below the weight of one point at distance
  // `reach` (< r), rather than where the last point leaves r: a coarse level of detail's
  // surface (render/brick_scene.hpp), whose bandwidth is 2^l or more times level 0's, ends about
  // where level 0's does instead of that much farther from the points.
  void end_within(float reach);

  // The first intersection with o + t·d (|d| = 1) for t in [t_min, t_max], if any; adds the MLS
  // evaluations made, hit or miss, to *evaluations when given.
  std::optional<SurfaceHit> intersect(const Vec3f& o, const Vec3f& d, float t_min, float t_max,
                                      std::uint64_t* evaluations = nullptr) const;

  // For march_ray (render/mls_march.hpp): where o + t·d lies in a cell near no point, a t just
  // past the ray's exit from that cell, else t; and how far along the ray the surface stays
  // undefined from t, from clearance().
  float empty_until(const Vec3f& o, const Vec3f& d, float t, float t_max) const;
  float skip_until(const Vec3f& o, const Vec3f& d, float t, float /*t_max*/) const {
    return t + std::max(clearance(o + t * d) - radius_, 0.0f);
  }

  // a(x), n(x) (unit; its sign is that of `facing`·n, or arbitrary when `facing` is zero) and
  // Σ weights; false where the surface is undefined (too little support).
  bool evaluate(const Vec3f& x, const Vec3f& facing, Vec3f& a, Vec3f& n, float& support) const;

  // A lower bound on the distance from x to every point: the nearest point in the 3 × 3 × 3
  // cells around x's, at most one cell edge, beyond which lie the cells not searched. Where it exceeds r, the surface is undefined for that much
  // further along any ray, which the march then skips in one step.
  float clearance(const Vec3f& x) const;

  // The id of the point nearest to x among those in the cells next to x's; 0 without ids or
  // points there.
  std::uint32_t nearest_id(const Vec3f& x) const;

  // The grid's box, the points' widened by r: intersect() clips rays to it, so every hit lies
  // inside. Empty without points.
  Box3f box() const;
  float bandwidth() const { return h_; }
  float support_radius() const { return radius_; }
  std::size_t size() const { return size_; }
  // Bytes held: points, normals and the grid.
  std::size_t memory_bytes() const;

 private:
  std::size_t cell_index(int ix, int iy, int iz) const {
    return static_cast<std::size_t>(ix) +
           static_cast<std::size_t>(dims_[0]) * (static_cast<std::size_t>(iy) +
                                                 static_cast<std::size_t>(dims_[1]) * static_cast<std::size_t>(iz));
  }
  // The cell holding coordinate v along an axis, clamped to the grid.
  int cell_coordinate(float v, int axis) const {
    const float c = (v - origin_[axis]) * inv_cell_[axis];
    // Compared as floats first: a coordinate far outside the grid must not overflow an int.
    if (!(c > 0)) return 0;
    if (c >= last_[axis]) return dims_[axis] - 1;
    return static_cast<int>(c);
  }
  std::uint32_t cell_begin(std::size_t c) const { return start_[c]; }
  bool near(std::size_t c) const { return ((near_[c >> 6] >> (c & 63)) & 1) != 0; }
  // Whether some cell of a block of level 0 (4³ cells: 2^kBlockShift a side) or 1 (16³) is
  // near a point.
  bool block_near(int level, int bx, int by, int bz) const {
    const auto& dims = block_dims_[level];
    const std::size_t b = static_cast<std::size_t>(bx) +
                          static_cast<std::size_t>(dims[0]) * (static_cast<std::size_t>(by) +
                                                               static_cast<std::size_t>(dims[1]) * static_cast<std::size_t>(bz));
    return ((block_near_[level][b >> 6] >> (b & 63)) & 1) != 0;
  }
  Vec3f cell_corner(int ix, int iy, int iz) const {
    return origin_ + Vec3f(static_cast<float>(ix) * cell_[0], static_cast<float>(iy) * cell_[1],
                           static_cast<float>(iz) * cell_[2]);
  }
  // Calls visit(j, position) for every point, cell by cell.
  template <typename Visit>
  void for_each_point(Visit&& visit) const;
  // Calls visit(j, position) for every point in the 3 × 3 × 3 cells around x's.
  template <typename Visit>
  void for_each_point_near(const Vec3f& x, Visit&& visit) const;

  static constexpr std::size_t kTable = 256;
  // Blocks of 2^kBlockShift cells a side, and blocks of those, marked where some cell inside is
  // near a point: a ray crosses an empty block in one step of the march rather than a step a
  // cell. Most rays of a frame miss (85% of dragon_scans' at 1024²), and walking them through
  // the grid cell by cell was most of march_ray's 33% of an uncompressed render (perf). With
  // the blocks, dragon_scans' frame took 0.57 s instead of 0.74 (1024², 2 threads), the same
  // image: the march restarts on its lattice after a skip, wherever the skip ends.
  static constexpr int kBlockShift = 2;

  float h_;
  float radius_;    // support radius r
  float inv_h2_;    // 1 / h²
  float floor_w_;   // exp(−r²/h²), subtracted from every weight
  float min_support_ = 0;  // where the surface ends
  float weight_table_[kTable + 2];  // weight at d² = r²·k/kTable (one more for rounding)
  std::size_t size_ = 0;
  float cell_[3];       // grid cell edges: ≥ r
  float inv_cell_[3];
  float last_[3] = {0, 0, 0};  // dims − 1, as floats
  Vec3f origin_;    // the grid's lower corner
  int dims_[3] = {1, 1, 1};
  std::vector<std::uint32_t> start_;    // per cell, its first point; one more at the end
  std::vector<std::uint64_t> near_;     // per cell, a bit: some point within r of the cell
  std::vector<std::uint64_t> block_near_[2];  // per block of each level, a bit: some cell near
  int block_dims_[2][3] = {{1, 1, 1}, {1, 1, 1}};
  std::vector<float> x_, y_, z_, nx_, ny_, nz_;          // points and normals, cell by cell
  std::vector<std::uint32_t> ids_;                       // per point, cell by cell, when given
};

// Per sample of every march: inline, as the march's loop was before it became a template
// (out of line it cost about 5% of an uncompressed render of dragon_scans).
inline float MlsSurface::empty_until(const Vec3f& o, const Vec3f& d, float t, float t_max) const {
  if (size_ == 0) return std::numeric_limits<float>::infinity();
  const Vec3f x = o + t * d;
  int c[3];
  bool inside = true;
  for (int k = 0; k < 3; ++k) {
    const float u = (x[k] - origin_[k]) * inv_cell_[k];
    inside = inside && u >= 0 && u < static_cast<float>(dims_[k]);
    c[k] = inside ? std::min(static_cast<int>(u), dims_[k] - 1) : 0;
  }
  if (!inside) {
    // Outside the grid no point is within reach: on to where the ray enters it, if it does (a
    // brick's surface, marched along a ray that crosses the brick's empty corners).
    float enter = -std::numeric_limits<float>::infinity(), leave = std::numeric_limits<float>::infinity();
    const Vec3f far_corner = cell_corner(dims_[0], dims_[1], dims_[2]);
    if (!clip_to_box(origin_, far_corner, o, d, enter, leave) || t >= leave) {
      return std::numeric_limits<float>::infinity();
    }
    return t < enter ? enter : t;
  }
  if (near(cell_index(c[0], c[1], c[2]))) return t;
  // Out of the largest empty block that holds the cell: its block of 16³ cells, or of 4³, when
  // no cell of it is near a point.
  int lo[3] = {c[0], c[1], c[2]}, span = 1;
  for (int level = 1; level >= 0; --level) {
    const int shift = kBlockShift * (level + 1);
    if (!block_near(level, c[0] >> shift, c[1] >> shift, c[2] >> shift)) {
      for (int k = 0; k < 3; ++k) lo[k] = (c[k] >> shift) << shift;
      span = 1 << shift;
      break;
    }
  }
  const float exit = exit_from_box(cell_corner(lo[0], lo[1], lo[2]),
                                   cell_corner(std::min(lo[0] + span, dims_[0]), std::min(lo[1] + span, dims_[1]),
                                               std::min(lo[2] + span, dims_[2])),
                                   o, d, t_max);
  // Just past the cell's face, so that the next sample is in the next cell.
  return std::max(exit, t) + 1e-3f * radius_;
}

}  // namespace sspc::render
