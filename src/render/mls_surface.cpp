#include "render/mls_surface.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace sspc::render {

namespace {

// Support radius in bandwidths: the Gaussian is e^−6.25 ≈ 0.2% of its peak there.
constexpr float kSupport = 2.5f;
constexpr std::size_t kSupportSamples = 64;
// The grid never has more cells than this many per point (plus a few for tiny sets): cells grow
// beyond the support radius for sparse, spread-out points instead, which costs more candidates
// per query but bounds the memory.
constexpr double kMaxCellsPerPoint = 4;
constexpr double kMinCells = 64;

}  // namespace

MlsSurface::MlsSurface(std::span<const Vec3f> points, std::span<const Vec3f> normals, float bandwidth,
                       float edge_support, std::span<const std::uint32_t> ids)
    : h_(bandwidth),
      radius_(kSupport * bandwidth),
      inv_h2_(1.0f / (bandwidth * bandwidth)),
      floor_w_(std::exp(-kSupport * kSupport)),
      size_(points.size()),
      cell_{kSupport * bandwidth, kSupport * bandwidth, kSupport * bandwidth},
      inv_cell_{1, 1, 1},
      origin_(Vec3f::Zero()) {
  // The weight as a function of d²/r², tabulated: exp costs more than the rest of a neighbour's
  // share of an evaluation, and 256 linear pieces follow the Gaussian to within 2·10⁻⁵.
  for (std::size_t k = 0; k <= kTable; ++k) {
    const float u = static_cast<float>(k) / static_cast<float>(kTable);
    weight_table_[k] = std::max(std::exp(-u * kSupport * kSupport) - floor_w_, 0.0f);
  }
  weight_table_[kTable + 1] = 0;
  const std::size_t n = points.size();
  if (n == 0) {
    start_.assign(2, 0);
    near_.assign(1, 0);
    for (int a = 0; a < 3; ++a) inv_cell_[a] = 1.0f / cell_[a];
    return;
  }
  Box3f box;
  for (const Vec3f& p : points) box.extend(p);
  origin_ = box.min() - Vec3f::Constant(radius_);
  const Vec3f extent = box.max() - box.min() + Vec3f::Constant(2 * radius_);
  const double budget = std::max(kMaxCellsPerPoint * static_cast<double>(n), kMinCells);
  // Cells grow until they fit the budget: 1.25^400 spans float32's whole range, so the bound
  // only stops a loop that a cell edge of 0 (a bandwidth of 0) would never end.
  for (int grow = 0; grow < 400; ++grow) {
    double cells = 1;
    for (int a = 0; a < 3; ++a) cells *= std::max(1.0, std::ceil(static_cast<double>(extent[a] / cell_[a])));
    if (cells <= budget) break;
    for (int a = 0; a < 3; ++a) cell_[a] = std::max(cell_[a] * 1.25f, std::numeric_limits<float>::min());
  }
  for (int a = 0; a < 3; ++a) {
    dims_[a] = std::max(1, static_cast<int>(std::ceil(extent[a] / cell_[a])));
    last_[a] = static_cast<float>(dims_[a] - 1);
    inv_cell_[a] = 1.0f / cell_[a];
  }
  const auto total = static_cast<std::size_t>(dims_[0]) * static_cast<std::size_t>(dims_[1]) *
                     static_cast<std::size_t>(dims_[2]);

  // Counting sort of the points by cell, stable: the same input gives the same order.
  std::vector<std::uint32_t> cell_of(n);
  start_.assign(total + 1, 0);
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3f& p = points[i];
    const auto c = static_cast<std::uint32_t>(
        cell_index(cell_coordinate(p.x(), 0), cell_coordinate(p.y(), 1), cell_coordinate(p.z(), 2)));
    cell_of[i] = c;
    ++start_[c + 1];
  }
  for (std::size_t c = 0; c < total; ++c) start_[c + 1] += start_[c];
  std::vector<std::uint32_t> next(start_.begin(), start_.end() - 1);
  x_.resize(n), y_.resize(n), z_.resize(n), nx_.resize(n), ny_.resize(n), nz_.resize(n);
  if (!ids.empty()) ids_.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t j = next[cell_of[i]]++;
    if (!ids.empty()) ids_[j] = ids[i];
    const Vec3f& p = points[i];
    const Vec3f& nn = normals[i];
    x_[j] = p.x(), y_[j] = p.y(), z_[j] = p.z();
    nx_[j] = nn.x(), ny_[j] = nn.y(), nz_[j] = nn.z();
  }

  // A cell is near when some point lies within r of its box: only there can the surface be.
  // Such points are in the cell or in cells that the point's r-box overlaps.
  near_.assign(total / 64 + 1, 0);
  const float r2 = radius_ * radius_;
  for_each_point([&](std::uint32_t, const Vec3f& p) {
    int lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      lo[a] = cell_coordinate(p[a] - radius_, a);
      hi[a] = cell_coordinate(p[a] + radius_, a);
    }
    for (int iz = lo[2]; iz <= hi[2]; ++iz) {
      for (int iy = lo[1]; iy <= hi[1]; ++iy) {
        for (int ix = lo[0]; ix <= hi[0]; ++ix) {
          const Vec3f below = cell_corner(ix, iy, iz) - p;
          const Vec3f above = p - cell_corner(ix + 1, iy + 1, iz + 1);
          const float d2 = below.cwiseMax(above).cwiseMax(0.0f).squaredNorm();  // p to the cell's box
          if (d2 < r2) {
            const std::size_t c = cell_index(ix, iy, iz);
            near_[c >> 6] |= std::uint64_t{1} << (c & 63);
          }
        }
      }
    }
  });

  for (int level = 0; level < 2; ++level) {
    const int shift = kBlockShift * (level + 1);
    std::size_t blocks = 1;
    for (int a = 0; a < 3; ++a) {
      block_dims_[level][a] = ((dims_[a] - 1) >> shift) + 1;
      blocks *= static_cast<std::size_t>(block_dims_[level][a]);
    }
    block_near_[level].assign(blocks / 64 + 1, 0);
  }
  for (int iz = 0; iz < dims_[2]; ++iz) {
    for (int iy = 0; iy < dims_[1]; ++iy) {
      for (int ix = 0; ix < dims_[0]; ++ix) {
        if (!near(cell_index(ix, iy, iz))) continue;
        for (int level = 0; level < 2; ++level) {
          const int shift = kBlockShift * (level + 1);
          const auto& bd = block_dims_[level];
          const std::size_t b = static_cast<std::size_t>(ix >> shift) +
                                static_cast<std::size_t>(bd[0]) * (static_cast<std::size_t>(iy >> shift) +
                                                                   static_cast<std::size_t>(bd[1]) *
                                                                       static_cast<std::size_t>(iz >> shift));
          block_near_[level][b >> 6] |= std::uint64_t{1} << (b & 63);
        }
      }
    }
  }

  // The support at the points themselves, on a sample of them: its median is what the interior
  // of the surface rests on, and a fraction of it is where the surface ends.
  if (!(edge_support > 0)) return;
  const std::size_t stride = std::max<std::size_t>(1, n / kSupportSamples);
  std::vector<float> samples;
  for_each_point([&](std::uint32_t j, const Vec3f& p) {
    if (j % stride != 0) return;
    Vec3f a, nn;
    float support = 0;
    if (evaluate(p, Vec3f::Zero(), a, nn, support)) samples.push_back(support);
  });
  if (!samples.empty()) {
    std::nth_element(samples.begin(), samples.begin() + static_cast<std::ptrdiff_t>(samples.size() / 2), samples.end());
    min_support_ = edge_support * samples[samples.size() / 2];
  }
}

void MlsSurface::end_within(float reach) {
  min_support_ = std::max(min_support_, std::exp(-reach * reach * inv_h2_) - floor_w_);
}

template <typename Visit>
void MlsSurface::for_each_point(Visit&& visit) const {
  for (int iz = 0; iz < dims_[2]; ++iz) {
    for (int iy = 0; iy < dims_[1]; ++iy) {
      for (int ix = 0; ix < dims_[0]; ++ix) {
        const std::size_t c = cell_index(ix, iy, iz);
        for (std::uint32_t j = cell_begin(c); j < cell_begin(c + 1); ++j) visit(j, Vec3f(x_[j], y_[j], z_[j]));
      }
    }
  }
}

Box3f MlsSurface::box() const {
  if (size_ == 0) return Box3f();
  return {origin_, origin_ + Vec3f(static_cast<float>(dims_[0]) * cell_[0], static_cast<float>(dims_[1]) * cell_[1],
                                   static_cast<float>(dims_[2]) * cell_[2])};
}

std::size_t MlsSurface::memory_bytes() const {
  return 6 * size_ * sizeof(float) + ids_.size() * sizeof(std::uint32_t) + start_.size() * sizeof(std::uint32_t) +
         (near_.size() + block_near_[0].size() + block_near_[1].size()) * sizeof(std::uint64_t);
}

bool MlsSurface::evaluate(const Vec3f& x, const Vec3f& facing, Vec3f& a, Vec3f& n, float& support) const {
  const float r2 = radius_ * radius_;
  const float to_table = static_cast<float>(kTable) / r2;
  const int x0 = cell_coordinate(x.x() - radius_, 0), x1 = cell_coordinate(x.x() + radius_, 0);
  const int y0 = cell_coordinate(x.y() - radius_, 1), y1 = cell_coordinate(x.y() + radius_, 1);
  const int z0 = cell_coordinate(x.z() - radius_, 2), z1 = cell_coordinate(x.z() + radius_, 2);
  // Σ w, Σ w (p − x) and the six entries of Σ w nnᵀ.
  float sw = 0, spx = 0, spy = 0, spz = 0;
  float txx = 0, txy = 0, txz = 0, tyy = 0, tyz = 0, tzz = 0;
  // The points scanned: first the squared distances, the indices of those within r gathered
  // without a branch (up to kRun at a time, across rows), then their weights and sums. A branch
  // point by point on d² < r², true for a third or so of the points scanned, mispredicted at
  // random; the sums are taken in the same order, so they are the same, and so are the images.
  // Warm frames (1024², 2 threads, three interleaved runs): autzen level 5 with --lod 0.5
  // 0.65-0.75 -> 0.53-0.63 s, dragon_scans level 5 0.39-0.48 -> 0.33-0.38 s (gathered row by
  // row, 0.56-0.60 and 0.34-0.40).
  constexpr std::uint32_t kRun = 64;
  std::uint32_t within[kRun];
  float within_d2[kRun];
  std::uint32_t m = 0;
  const auto weigh = [&] {
    for (std::uint32_t i = 0; i < m; ++i) {
      const std::uint32_t q = within[i];
      const float dx = x_[q] - x.x(), dy = y_[q] - x.y(), dz = z_[q] - x.z();
      // The weight at squared distance d2 < r², interpolated in the table of the lowered
      // Gaussian. Positions are summed relative to x, which keeps their precision.
      const float u = within_d2[i] * to_table;
      const auto k = static_cast<std::size_t>(u);
      const float w = weight_table_[k] + (u - static_cast<float>(k)) * (weight_table_[k + 1] - weight_table_[k]);
      sw += w;
      spx += w * dx, spy += w * dy, spz += w * dz;
      const float wx = w * nx_[q], wy = w * ny_[q], wz = w * nz_[q];
      txx += wx * nx_[q], txy += wx * ny_[q], txz += wx * nz_[q];
      tyy += wy * ny_[q], tyz += wy * nz_[q], tzz += wz * nz_[q];
    }
    m = 0;
  };
  for (int iz = z0; iz <= z1; ++iz) {
    for (int iy = y0; iy <= y1; ++iy) {
      // Cells x0..x1 of one row are one contiguous run of points.
      const std::uint32_t end = start_[cell_index(x1, iy, iz) + 1];
      for (std::uint32_t j = start_[cell_index(x0, iy, iz)]; j < end; ++j) {
        const float dx = x_[j] - x.x(), dy = y_[j] - x.y(), dz = z_[j] - x.z();
        const float d2 = dx * dx + dy * dy + dz * dz;
        within[m] = j;
        within_d2[m] = d2;
        m += d2 < r2 ? 1u : 0u;
        if (m == kRun) weigh();
      }
    }
  }
  weigh();
  if (!(sw > min_support_)) return false;
  a = x + Vec3f(spx, spy, spz) / sw;
  // The tensor's principal axis by power iteration from its largest column: where the normals
  // agree up to sign (the tensor is nearly rank one) four steps converge far below a degree.
  // The four steps are taken as (t²)(t²·v), on the tensor divided by its trace Σ w (its
  // eigenvalues then lie in [0, 1] and sum to 1, so nothing overflows, and the largest is at
  // least 1/3, so the axis's share does not vanish), normalised once at the end: normalising at
  // each step put a square root and a division on the chain of each of the four. Warm frames
  // (1024², 2 threads, three interleaved runs): dragon_scans level 5 0.43-0.45 -> 0.41-0.44 s,
  // the same PNG; autzen level 5 with --lod 0.5 0.73-0.78 -> 0.68-0.70 s, 96.8 dB against the
  // step-by-step image on the hit pixels, none hit in one only.
  Eigen::Matrix3f t;
  t << txx, txy, txz, txy, tyy, tyz, txz, tyz, tzz;
  int largest = 0;
  if (tyy > t(largest, largest)) largest = 1;
  if (tzz > t(largest, largest)) largest = 2;
  const float scale = 1.0f / (txx + tyy + tzz);
  const Eigen::Matrix3f t1 = t * scale;
  const Eigen::Matrix3f t2 = t1 * t1;
  const Vec3f v = t2 * (t2 * t1.col(largest));
  const float norm = v.norm();
  if (!(norm > 0) || !std::isfinite(norm)) return false;
  n = v / norm;
  if (n.dot(facing) < 0) n = -n;
  support = sw;
  return true;
}

template <typename Visit>
void MlsSurface::for_each_point_near(const Vec3f& x, Visit&& visit) const {
  int c[3];
  for (int k = 0; k < 3; ++k) c[k] = cell_coordinate(x[k], k);
  for (int iz = std::max(c[2] - 1, 0); iz <= std::min(c[2] + 1, dims_[2] - 1); ++iz) {
    for (int iy = std::max(c[1] - 1, 0); iy <= std::min(c[1] + 1, dims_[1] - 1); ++iy) {
      for (int ix = std::max(c[0] - 1, 0); ix <= std::min(c[0] + 1, dims_[0] - 1); ++ix) {
        const std::size_t cell = cell_index(ix, iy, iz);
        for (std::uint32_t j = cell_begin(cell); j < cell_begin(cell + 1); ++j) visit(j, Vec3f(x_[j], y_[j], z_[j]));
      }
    }
  }
}

float MlsSurface::clearance(const Vec3f& x) const {
  float nearest2 = std::numeric_limits<float>::infinity();
  for_each_point_near(x, [&](std::uint32_t, const Vec3f& p) { nearest2 = std::min(nearest2, (p - x).squaredNorm()); });
  const float edge = std::min({cell_[0], cell_[1], cell_[2]});
  return std::min(std::sqrt(nearest2), edge);
}

std::uint32_t MlsSurface::nearest_id(const Vec3f& x) const {
  if (ids_.empty()) return 0;
  float nearest2 = std::numeric_limits<float>::infinity();
  std::uint32_t id = 0;
  for_each_point_near(x, [&](std::uint32_t j, const Vec3f& p) {
    const float d2 = (p - x).squaredNorm();
    if (d2 < nearest2) {
      nearest2 = d2;
      id = ids_[j];
    }
  });
  return id;
}

std::optional<SurfaceHit> MlsSurface::intersect(const Vec3f& o, const Vec3f& d, float t_min, float t_max,
                                                std::uint64_t* evaluations) const {
  if (size_ == 0) return std::nullopt;
  // Clip to the grid: beyond it no point is within reach.
  for (int k = 0; k < 3; ++k) {
    const float lo = origin_[k], hi = origin_[k] + static_cast<float>(dims_[k]) * cell_[k];
    if (d[k] == 0) {
      if (o[k] < lo || o[k] > hi) return std::nullopt;
      continue;
    }
    const float inv = 1.0f / d[k];
    float near = (lo - o[k]) * inv, far = (hi - o[k]) * inv;
    if (near > far) std::swap(near, far);
    t_min = std::max(t_min, near);
    t_max = std::min(t_max, far);
  }
  if (!(t_min <= t_max)) return std::nullopt;
  return march_ray(*this, o, d, t_min, t_max, evaluations);
}

}  // namespace sspc::render
