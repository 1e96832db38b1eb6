// Quantisers of docs/FORMAT.md. Decoders here are total functions: any stored bits give a finite
// value (a unit normal, a rotation), so a corrupt block that slips past its CRC decodes to
// wrong but well-formed geometry, never to NaN.
#include "format/quantise.hpp"

#include "format/container_format.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

namespace sspc::codec {
namespace {

constexpr float kInvSqrt2 = 0.70710678118654752f;

std::uint32_t max_value(int bits) {
  return (1u << bits) - 1u;
}

float sign_not_zero(float x) {
  return x >= 0.0f ? 1.0f : -1.0f;
}

}  // namespace

float position_step(float patch_radius, int bits) {
  return 2.0f * patch_radius / static_cast<float>(1u << bits);
}

int position_bits_for_step(double patch_radius, double step) {
  if (!(step > 0) || !(patch_radius > 0)) return kMaxPositionBits;
  const double bits = std::ceil(std::log2(2.0 * patch_radius / step));
  return static_cast<int>(std::clamp(bits, double{kMinPositionBits}, double{kMaxPositionBits}));
}

std::array<std::uint32_t, 2> encode_normal(const Vec3f& n, int bits) {
  const float l1 = std::abs(n.x()) + std::abs(n.y()) + std::abs(n.z());
  float u = 0, v = 0;
  if (l1 > 0 && std::isfinite(l1)) {
    u = n.x() / l1;
    v = n.y() / l1;
    if (n.z() < 0) {
      const float fu = (1.0f - std::abs(v)) * sign_not_zero(u);
      const float fv = (1.0f - std::abs(u)) * sign_not_zero(v);
      u = fu;
      v = fv;
    }
  }
  const float m = static_cast<float>(max_value(bits));
  auto q = [m](float x) {
    return static_cast<std::uint32_t>(
        std::clamp(std::lround((x + 1.0f) * 0.5f * m), 0L, static_cast<long>(m)));
  };
  return {q(u), q(v)};
}

Vec3f decode_normal(std::uint32_t u, std::uint32_t v, int bits) {
  const float m = static_cast<float>(max_value(bits));
  const float x = static_cast<float>(u) / m * 2.0f - 1.0f;
  const float y = static_cast<float>(v) / m * 2.0f - 1.0f;
  Vec3f n(x, y, 1.0f - std::abs(x) - std::abs(y));
  const float t = std::max(-n.z(), 0.0f);
  n.x() += n.x() >= 0 ? -t : t;
  n.y() += n.y() >= 0 ? -t : t;
  return n.normalized();  // |n| ≥ 1/√3 on the octahedron, never zero
}

PackedRotation encode_rotation(const Eigen::Matrix3f& rotation, int bits) {
  Eigen::Quaterniond q(rotation.cast<double>());
  q.normalize();
  Eigen::Vector4d c = q.coeffs();  // x, y, z, w
  int largest = 0;
  for (int i = 1; i < 4; ++i) {
    if (std::abs(c[i]) > std::abs(c[largest])) largest = i;
  }
  if (c[largest] < 0) c = -c;
  const double m = static_cast<double>(max_value(bits));
  PackedRotation out;
  out.index = static_cast<std::uint32_t>(largest);
  int slot = 0;
  for (int i = 0; i < 4; ++i) {
    if (i == largest) continue;
    const double unit = (c[i] * std::sqrt(2.0) + 1.0) * 0.5;
    out.c[static_cast<std::size_t>(slot++)] = static_cast<std::uint32_t>(
        std::clamp(std::llround(unit * m), 0LL, static_cast<long long>(m)));
  }
  return out;
}

Eigen::Matrix3f decode_rotation(const PackedRotation& packed, int bits) {
  const float m = static_cast<float>(max_value(bits));
  float c[4] = {0, 0, 0, 0};
  const std::uint32_t largest = packed.index & 3u;
  float sum = 0;
  std::size_t slot = 0;
  for (std::uint32_t i = 0; i < 4; ++i) {
    if (i == largest) continue;
    const float x =
        (2.0f * static_cast<float>(std::min(packed.c[slot++], max_value(bits))) / m - 1.0f) *
        kInvSqrt2;
    c[i] = x;
    sum += x * x;
  }
  c[largest] = std::sqrt(std::max(0.0f, 1.0f - sum));
  // Eigen's constructor order is (w, x, y, z); the largest component is ≥ 1/2 before
  // normalising, so the norm is never zero.
  Eigen::Quaternionf q(c[3], c[0], c[1], c[2]);
  q.normalize();
  return q.toRotationMatrix();
}

bool quantise_translation(const Vec3f& t, const Vec3f& origin, float step,
                          std::array<std::int32_t, 3>& out) {
  for (int a = 0; a < 3; ++a) {
    const double v = std::round((static_cast<double>(t[a]) - static_cast<double>(origin[a])) /
                                static_cast<double>(step));
    if (!std::isfinite(v) || std::abs(v) >= static_cast<double>(1 << 24)) return false;
    out[static_cast<std::size_t>(a)] = static_cast<std::int32_t>(v);
  }
  return true;
}

Vec3f dequantise_translation(const std::array<std::int32_t, 3>& v, const Vec3f& origin,
                             float step) {
  return {origin.x() + step * static_cast<float>(v[0]),
          origin.y() + step * static_cast<float>(v[1]),
          origin.z() + step * static_cast<float>(v[2])};
}

}  // namespace sspc::codec
