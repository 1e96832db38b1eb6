#include "render/mls_surface.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace sspc::render {

namespace {

// Support radius in bandwidths: the Gaussian is e^−6.25 ≈ 0.2% of its peak there.
constexpr float kSupport = 2.5f;
constexpr std::size_t kSupportSamples = 64;
// Refinement steps once a crossing is bracketed, and the precision they stop at, in
// bandwidths: far below a pixel's footprint at any useful zoom.
constexpr int kMaxIterations = 12;
constexpr float kTolerance = 1e-3f;
// The grid never has more cells than this many per point (plus a few for tiny sets): cells grow
// beyond the support radius for sparse, spread-out points instead, which costs more candidates
// per query but bounds the memory.
constexpr double kMaxCellsPerPoint = 4;
constexpr double kMinCells = 64;

}  // namespace

MlsSurface::MlsSurface(std::span<const Vec3f> points, std::span<const Vec3f> normals, float bandwidth,
                       float edge_support)
    : h_(bandwidth),
      radius_(kSupport * bandwidth),
      inv_h2_(1.0f / (bandwidth * bandwidth)),
      floor_w_(std::exp(-kSupport * kSupport)),
      cell_(kSupport * bandwidth),
      inv_cell_(1.0f / cell_),
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
    return;
  }
  Box3f box;
  for (const Vec3f& p : points) box.extend(p);
  origin_ = box.min() - Vec3f::Constant(radius_);
  const Vec3f extent = box.max() - box.min() + Vec3f::Constant(2 * radius_);
  const double budget = std::max(kMaxCellsPerPoint * static_cast<double>(n), kMinCells);
  double cells = 0;
  for (;;) {
    cells = 1;
    for (int a = 0; a < 3; ++a) cells *= std::max(1.0, std::ceil(static_cast<double>(extent[a] / cell_)));
    if (cells <= budget) break;
    cell_ *= 1.25f;
  }
  for (int a = 0; a < 3; ++a) {
    dims_[a] = std::max(1, static_cast<int>(std::ceil(extent[a] / cell_)));
    last_[a] = static_cast<float>(dims_[a] - 1);
  }
  inv_cell_ = 1.0f / cell_;
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
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t j = next[cell_of[i]]++;
    x_[j] = points[i].x(), y_[j] = points[i].y(), z_[j] = points[i].z();
    nx_[j] = normals[i].x(), ny_[j] = normals[i].y(), nz_[j] = normals[i].z();
  }

  // A cell is near when some point lies within r of its box: only there can the surface be.
  // Since cells are at least r wide, such points are in the cell or one of its 26 neighbours.
  near_.assign(total, 0);
  const float r2 = radius_ * radius_;
  for (std::size_t j = 0; j < n; ++j) {
    const Vec3f p(x_[j], y_[j], z_[j]);
    int lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      lo[a] = cell_coordinate(p[a] - radius_, a);
      hi[a] = cell_coordinate(p[a] + radius_, a);
    }
    for (int iz = lo[2]; iz <= hi[2]; ++iz) {
      for (int iy = lo[1]; iy <= hi[1]; ++iy) {
        for (int ix = lo[0]; ix <= hi[0]; ++ix) {
          const int c[3] = {ix, iy, iz};
          float d2 = 0;  // from p to the cell's box
          for (int a = 0; a < 3; ++a) {
            const float below = origin_[a] + static_cast<float>(c[a]) * cell_ - p[a];
            const float above = p[a] - (origin_[a] + static_cast<float>(c[a] + 1) * cell_);
            const float gap = std::max({below, above, 0.0f});
            d2 += gap * gap;
          }
          if (d2 < r2) near_[cell_index(ix, iy, iz)] = 1;
        }
      }
    }
  }

  // The support at the points themselves, on a sample of them: its median is what the interior
  // of the surface rests on, and a fraction of it is where the surface ends.
  if (!(edge_support > 0)) return;
  const std::size_t stride = std::max<std::size_t>(1, n / kSupportSamples);
  std::vector<float> samples;
  for (std::size_t j = 0; j < n; j += stride) {
    Vec3f a, nn;
    float support = 0;
    if (evaluate(Vec3f(x_[j], y_[j], z_[j]), a, nn, support)) samples.push_back(support);
  }
  if (!samples.empty()) {
    std::nth_element(samples.begin(), samples.begin() + static_cast<std::ptrdiff_t>(samples.size() / 2), samples.end());
    min_support_ = edge_support * samples[samples.size() / 2];
  }
}

std::size_t MlsSurface::memory_bytes() const {
  return 6 * x_.size() * sizeof(float) + start_.size() * sizeof(std::uint32_t) + near_.size();
}

bool MlsSurface::evaluate(const Vec3f& x, Vec3f& a, Vec3f& n, float& support) const {
  const float r2 = radius_ * radius_;
  const float to_table = static_cast<float>(kTable) / r2;
  const int x0 = cell_coordinate(x.x() - radius_, 0), x1 = cell_coordinate(x.x() + radius_, 0);
  const int y0 = cell_coordinate(x.y() - radius_, 1), y1 = cell_coordinate(x.y() + radius_, 1);
  const int z0 = cell_coordinate(x.z() - radius_, 2), z1 = cell_coordinate(x.z() + radius_, 2);
  float sw = 0, spx = 0, spy = 0, spz = 0, snx = 0, sny = 0, snz = 0;
  for (int iz = z0; iz <= z1; ++iz) {
    for (int iy = y0; iy <= y1; ++iy) {
      // Cells x0..x1 of one row are one contiguous run of points.
      const std::uint32_t begin = start_[cell_index(x0, iy, iz)];
      const std::uint32_t end = start_[cell_index(x1, iy, iz) + 1];
      for (std::uint32_t j = begin; j < end; ++j) {
        const float dx = x_[j] - x.x(), dy = y_[j] - x.y(), dz = z_[j] - x.z();
        const float d2 = dx * dx + dy * dy + dz * dz;
        if (d2 >= r2) continue;
        // The weight, interpolated in the table of the lowered Gaussian.
        const float u = d2 * to_table;
        const auto k = static_cast<std::size_t>(u);
        const float w = weight_table_[k] + (u - static_cast<float>(k)) * (weight_table_[k + 1] - weight_table_[k]);
        sw += w;
        spx += w * x_[j], spy += w * y_[j], spz += w * z_[j];
        snx += w * nx_[j], sny += w * ny_[j], snz += w * nz_[j];
      }
    }
  }
  if (!(sw > min_support_)) return false;
  a = Vec3f(spx, spy, spz) / sw;
  n = Vec3f(snx, sny, snz);
  support = sw;
  return n.squaredNorm() > 0;
}

std::optional<SurfaceHit> MlsSurface::intersect(const Vec3f& o, const Vec3f& d, float t_min,
                                                float t_max) const {
  if (x_.empty()) return std::nullopt;
  // Clip to the grid: beyond it no point is within reach.
  for (int k = 0; k < 3; ++k) {
    const float lo = origin_[k], hi = origin_[k] + static_cast<float>(dims_[k]) * cell_;
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

  SurfaceHit hit;
  Vec3f a, n;
  float support = 0;
  // The signed distance to the local plane, f(x) = n(x)·(x − a(x)), positive on the side the
  // normals face; false where the surface is undefined.
  const auto f_at = [&](float t, float& f) {
    ++hit.evaluations;
    const Vec3f x = o + t * d;
    if (!evaluate(x, a, n, support)) return false;
    n.normalize();
    f = n.dot(x - a);
    return true;
  };
  float t = t_min;
  bool have_previous = false;
  float t_previous = 0, f_previous = 0;
  while (t <= t_max) {
    const Vec3f x = o + t * d;
    int c[3];
    for (int k = 0; k < 3; ++k) c[k] = cell_coordinate(x[k], k);
    if (near_[cell_index(c[0], c[1], c[2])] == 0) {
      // No point within reach anywhere in this cell: leave it in one step.
      float exit = std::numeric_limits<float>::infinity();
      for (int k = 0; k < 3; ++k) {
        if (d[k] > 0) exit = std::min(exit, (origin_[k] + static_cast<float>(c[k] + 1) * cell_ - o[k]) / d[k]);
        if (d[k] < 0) exit = std::min(exit, (origin_[k] + static_cast<float>(c[k]) * cell_ - o[k]) / d[k]);
      }
      t = std::max(exit, t) + 1e-3f * cell_;
      have_previous = false;
      continue;
    }
    float f = 0;
    if (!f_at(t, f)) {
      t += 0.5f * h_;
      have_previous = false;
      continue;
    }
    if (have_previous && (f > 0) != (f_previous > 0)) {
      // f changed sign between the last two samples: the surface is in between. Regula falsi
      // with the Illinois rule (the end that stays is halved), a handful of evaluations.
      float lo = t_previous, f_lo = f_previous, hi = t, f_hi = f;
      float s = hi;
      bool at_s = true;  // a, n and support were last evaluated at s
      int kept = 0;      // which end stayed last: −1 lo, +1 hi
      for (int it = 0; it < kMaxIterations; ++it) {
        s = lo - f_lo * (hi - lo) / (f_hi - f_lo);
        float f_s = 0;
        at_s = f_at(s, f_s);
        if (!at_s) break;
        if (std::abs(f_s) < kTolerance * h_ || hi - lo < kTolerance * h_) break;
        if ((f_s > 0) == (f_lo > 0)) {
          lo = s;
          f_lo = f_s;
          if (kept == 1) f_hi *= 0.5f;
          kept = 1;
        } else {
          hi = s;
          f_hi = f_s;
          if (kept == -1) f_lo *= 0.5f;
          kept = -1;
        }
      }
      if (at_s && s >= t_min && s <= t_max) {
        hit.t = s;
        hit.normal = n.dot(d) > 0 ? Vec3f(-n) : n;
        hit.support = support;
        return hit;
      }
    }
    have_previous = true;
    t_previous = t;
    f_previous = f;
    // At least half the bandwidth, and up to 90% of the distance to the local plane (along the
    // ray the plane is at least that far): a surface is found unless two crossings lie closer
    // than the step. The last sample is at t_max, so a crossing just before it is not lost.
    t += std::max(0.5f * h_, 0.9f * std::abs(f));
    if (t > t_max && t_previous < t_max) t = t_max;
  }
  return std::nullopt;
}

}  // namespace sspc::render
