// Synthetic surfaces with known normals, for tests and benchmarks.
//
// Every generator draws from one SplitMix64 stream (Steele, Lea, Flood: "Fast splittable
// pseudorandom number generators", OOPSLA 2014) in a fixed order, so a seed names one cloud
// byte for byte; <random>'s distributions would not, as the standard leaves their algorithms
// to the library. (The sphere, torus, bumps and Gaussian noise also go through libm's sin, cos,
// exp and log: identical across runs and thread counts, but another C library may round them
// differently in the last bit.)
#include "sspc/synthetic.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace sspc::synthetic {

std::uint64_t Rng::next_u64() {
  state_ += 0x9E3779B97F4A7C15ULL;
  std::uint64_t z = state_;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

double Rng::uniform() {
  // The top 53 bits fill a double's mantissa exactly: every value is k / 2^53.
  return static_cast<double>(next_u64() >> 11) * 0x1.0p-53;
}

double Rng::gaussian() {
  if (has_spare_) {
    has_spare_ = false;
    return spare_;
  }
  // Box–Muller; 1 - u lies in (0, 1], so the logarithm is finite.
  const double u1 = 1.0 - uniform();
  const double u2 = uniform();
  const double r = std::sqrt(-2.0 * std::log(u1));
  const double angle = 2.0 * std::numbers::pi * u2;
  spare_ = r * std::sin(angle);
  has_spare_ = true;
  return r * std::cos(angle);
}

namespace {

Vec3f to_float(const Vec3d& v) {
  return v.cast<float>();
}

// Appends one sample: the noise moves the point along its exact normal.
void emit(PointCloud& cloud, const Vec3d& position, const Vec3d& normal, const Options& options,
          Rng& rng) {
  Vec3d p = position;
  if (options.noise > 0) p += options.noise * rng.gaussian() * normal;
  cloud.positions.push_back(to_float(p));
  if (options.normals) cloud.normals.push_back(to_float(normal.normalized()));
}

PointCloud empty_cloud(std::size_t points, const Options& options) {
  PointCloud cloud;
  cloud.reserve(points, options.normals, false);
  return cloud;
}

}  // namespace

PointCloud plane(std::size_t points, double size, const Options& options) {
  PointCloud cloud = empty_cloud(points, options);
  Rng rng(options.seed);
  const double half = size / 2;
  for (std::size_t i = 0; i < points; ++i) {
    const double x = rng.uniform(-half, half);
    const double y = rng.uniform(-half, half);
    emit(cloud, Vec3d(x, y, 0), Vec3d::UnitZ(), options, rng);
  }
  return cloud;
}

PointCloud sphere(std::size_t points, double radius, const Options& options) {
  PointCloud cloud = empty_cloud(points, options);
  Rng rng(options.seed);
  for (std::size_t i = 0; i < points; ++i) {
    // Archimedes: z uniform on [-1, 1] and a uniform azimuth are uniform by area.
    const double z = rng.uniform(-1.0, 1.0);
    const double phi = rng.uniform(0.0, 2.0 * std::numbers::pi);
    const double s = std::sqrt(std::max(0.0, 1.0 - z * z));
    const Vec3d n(s * std::cos(phi), s * std::sin(phi), z);
    emit(cloud, radius * n, n, options, rng);
  }
  return cloud;
}

PointCloud torus(std::size_t points, double major_radius, double minor_radius,
                 const Options& options) {
  PointCloud cloud = empty_cloud(points, options);
  Rng rng(options.seed);
  const double two_pi = 2.0 * std::numbers::pi;
  for (std::size_t i = 0; i < points; ++i) {
    const double u = rng.uniform(0.0, two_pi);
    // The area element is r (R + r cos v) du dv: accept v with probability proportional to
    // R + r cos v, so the outer rim gets more points than the inner one, as it should.
    double v = 0;
    do {
      v = rng.uniform(0.0, two_pi);
    } while (rng.uniform() * (major_radius + minor_radius) >
             major_radius + minor_radius * std::cos(v));
    const Vec3d n(std::cos(v) * std::cos(u), std::cos(v) * std::sin(u), std::sin(v));
    const double ring = major_radius + minor_radius * std::cos(v);
    const Vec3d p(ring * std::cos(u), ring * std::sin(u), minor_radius * std::sin(v));
    emit(cloud, p, n, options, rng);
  }
  return cloud;
}

PointCloud bumps(std::size_t points, double size, int bumps_per_side, double height,
                 const Options& options) {
  PointCloud cloud = empty_cloud(points, options);
  if (points == 0) return cloud;
  Rng rng(options.seed);
  const int per_side = std::max(bumps_per_side, 1);
  const double pitch = size / per_side;
  const double sigma = pitch / 6;  // a bump fades to 1% of its height at its cell's border
  const double half = size / 2;

  // A jittered grid of cols × rows cells, at least `points` of them; the cells left over are
  // skipped evenly through the grid (Bresenham style) rather than as one empty strip.
  const auto cols = static_cast<std::size_t>(std::ceil(std::sqrt(static_cast<double>(points))));
  const std::size_t rows = (points + cols - 1) / cols;
  const std::size_t cells = cols * rows;
  const double cell_w = size / static_cast<double>(cols);
  const double cell_h = size / static_cast<double>(rows);

  for (std::size_t c = 0; c < cells; ++c) {
    if ((c + 1) * points / cells == c * points / cells) continue;
    const double x = -half + (static_cast<double>(c % cols) + rng.uniform()) * cell_w;
    const double y = -half + (static_cast<double>(c / cols) + rng.uniform()) * cell_h;
    // Only the 3×3 nearest bumps contribute: the next ring is ≥ 9 sigma away (e^-40), and
    // cutting it off keeps every bump exactly alike.
    const int bx = std::clamp(static_cast<int>(std::floor((x + half) / pitch)), 0, per_side - 1);
    const int by = std::clamp(static_cast<int>(std::floor((y + half) / pitch)), 0, per_side - 1);
    double z = 0, dzdx = 0, dzdy = 0;
    for (int j = std::max(by - 1, 0); j <= std::min(by + 1, per_side - 1); ++j) {
      for (int i = std::max(bx - 1, 0); i <= std::min(bx + 1, per_side - 1); ++i) {
        const double dx = x - (-half + (i + 0.5) * pitch);
        const double dy = y - (-half + (j + 0.5) * pitch);
        const double g = height * std::exp(-(dx * dx + dy * dy) / (2 * sigma * sigma));
        z += g;
        dzdx -= g * dx / (sigma * sigma);
        dzdy -= g * dy / (sigma * sigma);
      }
    }
    emit(cloud, Vec3d(x, y, z), Vec3d(-dzdx, -dzdy, 1.0).normalized(), options, rng);
  }
  return cloud;
}

}  // namespace sspc::synthetic
