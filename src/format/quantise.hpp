// The quantisers of the .sspc format (docs/FORMAT.md, "Quantisation"): code-word positions on
// a grid relative to patch_radius, octahedral normals, smallest-three rotations, translations
// on an absolute grid. The writer and the reader both call these, so a value decodes to the same
// float wherever it is decoded; the arithmetic order is part of the format.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

#include <Eigen/Core>

#include "sspc/point_cloud.hpp"

namespace sspc::codec {

// --- Code-word positions: offset-binary values below 2^bits, cell midpoints on decode.

float position_step(float patch_radius, int bits);
// The fewest bits (within the format's 4..16) whose grid of `step` spans ±patch_radius: what the
// writer stores when it is given an exact step (QuantOptions::position_step).
int position_bits_for_step(double patch_radius, double step);
// The cell of x on the grid of `step` (cell k holds [k·step, (k + 1)·step)), as an offset-binary
// value clamped below 2^bits; the middle value 2^(bits−1) where x / step is not finite. Inline,
// the floor done by truncation: a call into the library (no SSE4.1 in the portable build), it
// was 1.6% of autzen's encode, three calls a code-word point.
inline std::uint32_t quantise_coordinate(float x, float step, int bits) {
  const double half = static_cast<double>(1u << (bits - 1));
  const double v = static_cast<double>(x) / static_cast<double>(step);
  if (!std::isfinite(v)) return static_cast<std::uint32_t>(half);
  // Clamped first, into a range where truncation is exact and the final clamp gives what it
  // would give for v itself; then floor = truncation, less one below 0 off the integers.
  const double bounded = std::clamp(v, -half - 1, half + 1);
  double cell = static_cast<double>(static_cast<std::int64_t>(bounded));
  if (cell > bounded) cell -= 1;
  cell = std::clamp(cell, -half, half - 1);
  return static_cast<std::uint32_t>(cell + half);
}
inline float dequantise_coordinate(std::uint32_t v, float step, int bits) {
  const auto half = static_cast<std::int32_t>(1u << (bits - 1));
  return (static_cast<float>(static_cast<std::int32_t>(v) - half) + 0.5f) * step;
}

// --- Normals: octahedral map (Meyer et al. 2010), `bits` per component.

std::array<std::uint32_t, 2> encode_normal(const Vec3f& n, int bits);
Vec3f decode_normal(std::uint32_t u, std::uint32_t v, int bits);

// --- Rotations: unit quaternion, smallest three.

struct PackedRotation {
  std::uint32_t index = 3;  // 0 = x … 3 = w: the dropped (largest) component
  std::array<std::uint32_t, 3> c{};
};

PackedRotation encode_rotation(const Eigen::Matrix3f& rotation, int bits);
// Always a rotation (orthonormal, det +1, to float precision), whatever `packed` holds.
Eigen::Matrix3f decode_rotation(const PackedRotation& packed, int bits);

// --- Translations: an i32 grid of `step` relative to `origin` (the bounds' minimum).

// False when a coordinate falls outside |v| < 2^24 (the writer reports it).
[[nodiscard]] bool quantise_translation(const Vec3f& t, const Vec3f& origin, float step,
                          std::array<std::int32_t, 3>& out);
Vec3f dequantise_translation(const std::array<std::int32_t, 3>& v, const Vec3f& origin, float step);

}  // namespace sspc::codec
