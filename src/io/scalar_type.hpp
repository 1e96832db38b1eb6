// The numeric types that PLY and PCD files store, and how to turn one stored value into the
// float or colour channel the point cloud model holds.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <string_view>

#include "core/byte_reader.hpp"

namespace sspc::io {

enum class ScalarType : std::uint8_t {
  kInt8,
  kUint8,
  kInt16,
  kUint16,
  kInt32,
  kUint32,
  kInt64,  // PCD only: PLY names no 64-bit integers
  kUint64,
  kFloat32,
  kFloat64,
};

constexpr std::size_t scalar_size(ScalarType t) {
  switch (t) {
    case ScalarType::kInt8:
    case ScalarType::kUint8: return 1;
    case ScalarType::kInt16:
    case ScalarType::kUint16: return 2;
    case ScalarType::kInt32:
    case ScalarType::kUint32:
    case ScalarType::kFloat32: return 4;
    case ScalarType::kInt64:
    case ScalarType::kUint64:
    case ScalarType::kFloat64: return 8;
  }
  return 0;
}

constexpr bool scalar_is_float(ScalarType t) {
  return t == ScalarType::kFloat32 || t == ScalarType::kFloat64;
}

constexpr bool scalar_is_signed(ScalarType t) {
  return t == ScalarType::kInt8 || t == ScalarType::kInt16 || t == ScalarType::kInt32 ||
         t == ScalarType::kInt64 || scalar_is_float(t);
}

// The PLY name sspc writes ("float", "uchar").
std::string_view ply_type_name(ScalarType t);

// Both PLY spellings (Turk's original "uchar" and the later "uint8"); nullopt otherwise.
std::optional<ScalarType> ply_type_from_name(std::string_view name);

// The value at `p` as a double (exact for every type but 64-bit integers beyond 2^53).
// Unchecked: the caller has verified that scalar_size(t) bytes exist.
inline double load_as_double(const std::byte* p, ScalarType t, Endian e) {
  switch (t) {
    case ScalarType::kInt8: return load<std::int8_t>(p, e);
    case ScalarType::kUint8: return load<std::uint8_t>(p, e);
    case ScalarType::kInt16: return load<std::int16_t>(p, e);
    case ScalarType::kUint16: return load<std::uint16_t>(p, e);
    case ScalarType::kInt32: return load<std::int32_t>(p, e);
    case ScalarType::kUint32: return load<std::uint32_t>(p, e);
    case ScalarType::kInt64: return static_cast<double>(load<std::int64_t>(p, e));
    case ScalarType::kUint64: return static_cast<double>(load<std::uint64_t>(p, e));
    case ScalarType::kFloat32: return static_cast<double>(load<float>(p, e));
    case ScalarType::kFloat64: return load<double>(p, e);
  }
  return 0.0;
}

// A double narrowed to float, with magnitudes beyond float's range becoming infinities (which
// the readers then reject) instead of the undefined behaviour of a plain cast.
inline float narrow_to_float(double v) {
  constexpr double kMax = static_cast<double>(std::numeric_limits<float>::max());
  if (v > kMax) return std::numeric_limits<float>::infinity();
  if (v < -kMax) return -std::numeric_limits<float>::infinity();
  return static_cast<float>(v);
}

// The value at `p` as a float; a float32 is returned bit for bit (NaN payloads included).
inline float load_as_float(const std::byte* p, ScalarType t, Endian e) {
  if (t == ScalarType::kFloat32) return load<float>(p, e);
  return narrow_to_float(load_as_double(p, t, e));
}

// An integer list count or list length at `p`; nullopt when negative (or the type is a float,
// which the header parsers reject before this is reached).
inline std::optional<std::uint64_t> load_count(const std::byte* p, ScalarType t, Endian e) {
  switch (t) {
    case ScalarType::kUint8: return load<std::uint8_t>(p, e);
    case ScalarType::kUint16: return load<std::uint16_t>(p, e);
    case ScalarType::kUint32: return load<std::uint32_t>(p, e);
    case ScalarType::kUint64: return load<std::uint64_t>(p, e);
    case ScalarType::kInt8:
    case ScalarType::kInt16:
    case ScalarType::kInt32:
    case ScalarType::kInt64: {
      const auto v = static_cast<std::int64_t>(load_as_double(p, t, e));
      if (v < 0) return std::nullopt;
      return static_cast<std::uint64_t>(v);
    }
    case ScalarType::kFloat32:
    case ScalarType::kFloat64: return std::nullopt;
  }
  return std::nullopt;
}

// A colour channel from a stored value. The rule every common tool follows: 8-bit integers are
// the channel itself, 16-bit integers are scaled down (65535 -> 255), floats are in [0, 1];
// anything outside the range is clamped rather than wrapped.
inline std::uint8_t colour_channel(double v, ScalarType t) {
  double scaled = v;
  if (scalar_is_float(t)) {
    scaled = v * 255.0;
  } else if (t == ScalarType::kUint16 || t == ScalarType::kInt16) {
    scaled = v / 257.0;
  }
  if (!(scaled > 0.0)) return 0;  // also catches NaN
  if (scaled >= 255.0) return 255;
  return static_cast<std::uint8_t>(std::lround(scaled));
}

}  // namespace sspc::io
