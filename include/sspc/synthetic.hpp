// Synthetic surfaces for tests and benchmarks: seeded, deterministic (the same seed gives the
// same bytes on every platform: the generators use their own integer RNG, not <random>'s
// distributions, whose output the standard leaves to the implementation).
#pragma once

#include <cstdint>

#include "sspc/point_cloud.hpp"

namespace sspc::synthetic {

struct Options {
  std::uint64_t seed = 1;
  bool normals = true;     // exact analytic normals
  double noise = 0.0;      // Gaussian noise sigma added along the normal, in model units
};

// Random points on the square [-size/2, size/2]² in the z = 0 plane, normal +z.
PointCloud plane(std::size_t points, double size, const Options& options = {});
// Uniform random points on a sphere about the origin, outward normals.
PointCloud sphere(std::size_t points, double radius, const Options& options = {});
// Points on a torus about the z axis (major radius R, minor r), area-uniform, outward normals.
PointCloud torus(std::size_t points, double major_radius, double minor_radius,
                 const Options& options = {});
// A size×size plane covered by a grid of `bumps_per_side`² identical Gaussian bumps of height
// `height`: a surface built to be self-similar. Sampled on a jittered grid so that spacing is
// even; normals from the height field's gradient.
PointCloud bumps(std::size_t points, double size, int bumps_per_side, double height,
                 const Options& options = {});

// A deterministic 64-bit generator (SplitMix64) with the few distributions sspc needs.
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next_u64();
  double uniform();           // [0, 1)
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  double gaussian();          // mean 0, sigma 1 (Box–Muller)

 private:
  std::uint64_t state_;
  bool has_spare_ = false;
  double spare_ = 0;
};

}  // namespace sspc::synthetic
