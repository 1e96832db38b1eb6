#include "format/checksum.hpp"

#include <algorithm>

#include <zlib.h>

namespace sspc::codec {

std::uint32_t crc32_of(std::span<const std::byte> bytes) { return crc32_continue(0, bytes); }

std::uint32_t crc32_continue(std::uint32_t start, std::span<const std::byte> bytes) {
  uLong crc = start;
  // zlib takes 32-bit lengths; feed larger spans in pieces.
  while (!bytes.empty()) {
    const std::size_t n = std::min<std::size_t>(bytes.size(), std::size_t{1} << 30);
    crc = crc32(crc, reinterpret_cast<const Bytef*>(bytes.data()), static_cast<uInt>(n));
    bytes = bytes.subspan(n);
  }
  return static_cast<std::uint32_t>(crc);
}

}  // namespace sspc::codec
