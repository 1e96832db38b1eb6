// The point cloud model: float32 positions, optional unit normals, optional 8-bit RGB colours.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "sspc/status.hpp"

namespace sspc {

using Vec3f = Eigen::Vector3f;
using Vec3d = Eigen::Vector3d;
using Box3f = Eigen::AlignedBox3f;

struct Rgb8 {
  std::uint8_t r = 0, g = 0, b = 0;
  friend bool operator==(const Rgb8&, const Rgb8&) = default;
};

// Structure of arrays: `normals` and `colors` are either empty or exactly as long as `positions`.
struct PointCloud {
  std::vector<Vec3f> positions;
  std::vector<Vec3f> normals;
  std::vector<Rgb8> colors;

  std::size_t size() const { return positions.size(); }
  bool empty() const { return positions.empty(); }
  bool has_normals() const { return !normals.empty(); }
  bool has_colors() const { return !colors.empty(); }

  void reserve(std::size_t n, bool with_normals, bool with_colors);

  // Axis-aligned bounds of the positions; an empty box for an empty cloud.
  Box3f bounding_box() const;

  // Checks the invariants every consumer relies on: attribute arrays sized like the positions,
  // every coordinate finite. Readers call it before returning a cloud.
  Status validate() const;
};

// Length of the bounding-box diagonal (the paper's d_B); 0 for fewer than two distinct points.
double bounding_box_diagonal(const PointCloud& cloud);

}  // namespace sspc
