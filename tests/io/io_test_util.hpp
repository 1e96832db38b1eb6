// Helpers for the io tests: byte views of strings, sample clouds, and hand-built binary values.
#pragma once

#include <bit>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <string_view>

#include "sspc/point_cloud.hpp"

namespace sspc::test {

inline std::span<const std::byte> bytes_of(std::string_view s) {
  return std::as_bytes(std::span(s.data(), s.size()));
}

// A cloud whose floats exercise the exact round trip: negative zero, tiny and huge magnitudes,
// values with no short decimal form.
inline PointCloud sample_cloud(std::size_t n, bool normals, bool colours) {
  PointCloud c;
  for (std::size_t i = 0; i < n; ++i) {
    const auto f = static_cast<float>(i);
    c.positions.emplace_back(f * 0.1f + 1.0f / 3.0f, -f * 1e-7f - 0.0f, 1e30f / (f + 1.0f));
    if (normals) c.normals.emplace_back(0.6f, -0.8f * (i % 2 == 0 ? 1.0f : -1.0f), 1e-38f);
    if (colours) {
      c.colours.push_back(Rgb8{static_cast<std::uint8_t>(i * 37), static_cast<std::uint8_t>(255 - i),
                              static_cast<std::uint8_t>(i * 11 + 5)});
    }
  }
  if (n > 0) c.positions[0] = Vec3f(-0.0f, 3.4028235e38f, 1.17549435e-38f);
  return c;
}

// Appends the bytes of `v` in little- or big-endian order.
template <typename T>
void put(std::string& out, T v, bool big_endian = false) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if (big_endian == (std::endian::native == std::endian::little)) {
    for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
  }
  out.append(b, sizeof(T));
}

// Bitwise float equality, so that -0.0 and 0.0 differ and the test sees the exact bits.
inline bool same_bits(const Vec3f& a, const Vec3f& b) {
  return std::memcmp(a.data(), b.data(), sizeof(float) * 3) == 0;
}

}  // namespace sspc::test
