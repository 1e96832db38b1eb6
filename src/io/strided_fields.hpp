// Decoding point attributes from fixed-size binary records: the inner loops of the binary PLY
// reader and of both binary PCD bodies.
//
// A field is addressed as `base + i * stride` for point i, which covers both layouts the
// formats use: records of interleaved fields (PLY, PCD `binary`; stride = record size) and one
// array per field (PCD `binary_compressed`; stride = field size). Unchecked: callers have
// verified that every addressed byte lies inside the block.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>

#include "core/byte_reader.hpp"
#include "io/scalar_type.hpp"
#include "sspc/point_cloud.hpp"

namespace sspc::io {

struct StridedField {
  std::size_t offset = 0;  // of point 0's value, from the start of the block
  std::size_t stride = 0;  // bytes from one point's value to the next
  ScalarType type = ScalarType::kFloat32;
};

// Three fields (x y z, or nx ny nz) decoded into Vec3f for points [begin, end).
inline void decode_vec3(const std::byte* block, const StridedField (&f)[3], Endian endian,
                        std::size_t begin, std::size_t end, Vec3f* out) {
  const bool native_floats = endian == kNativeEndian && f[0].type == ScalarType::kFloat32 &&
                             f[1].type == ScalarType::kFloat32 && f[2].type == ScalarType::kFloat32;
  // The common layout (three host-order floats side by side in each record): one memcpy per
  // point, which the compiler turns into two loads and stores.
  if (native_floats && f[1].stride == f[0].stride && f[2].stride == f[0].stride &&
      f[1].offset == f[0].offset + 4 && f[2].offset == f[0].offset + 8) {
    const std::byte* src = block + f[0].offset + begin * f[0].stride;
    for (std::size_t i = begin; i < end; ++i, src += f[0].stride) {
      std::memcpy(out[i].data(), src, 3 * sizeof(float));
    }
    return;
  }
  for (std::size_t i = begin; i < end; ++i) {
    for (int k = 0; k < 3; ++k) {
      out[i][k] = load_as_float(block + f[k].offset + i * f[k].stride, f[k].type, endian);
    }
  }
}

// Three colour channels (red green blue) for points [begin, end), each converted by
// colour_channel() unless it is already a byte.
inline void decode_rgb_channels(const std::byte* block, const StridedField (&f)[3], Endian endian,
                                std::size_t begin, std::size_t end, Rgb8* out) {
  std::uint8_t c[3];
  for (std::size_t i = begin; i < end; ++i) {
    for (int k = 0; k < 3; ++k) {
      const std::byte* p = block + f[k].offset + i * f[k].stride;
      c[k] = f[k].type == ScalarType::kUint8
                 ? std::to_integer<std::uint8_t>(*p)
                 : colour_channel(load_as_double(p, f[k].type, endian), f[k].type);
    }
    out[i] = Rgb8{c[0], c[1], c[2]};
  }
}

// PCL's packed colour: the bits of a 4-byte field (declared F, U or I) read as 0xAARRGGBB.
inline Rgb8 unpack_pcl_rgb(std::uint32_t v) {
  return Rgb8{static_cast<std::uint8_t>((v >> 16) & 0xffu),
              static_cast<std::uint8_t>((v >> 8) & 0xffu), static_cast<std::uint8_t>(v & 0xffu)};
}

inline void decode_packed_rgb(const std::byte* block, const StridedField& f, Endian endian,
                              std::size_t begin, std::size_t end, Rgb8* out) {
  for (std::size_t i = begin; i < end; ++i) {
    out[i] = unpack_pcl_rgb(load<std::uint32_t>(block + f.offset + i * f.stride, endian));
  }
}

}  // namespace sspc::io
