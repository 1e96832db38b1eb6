// CRC32 (zlib's, as PNG and the .sspc format use it) over any span of bytes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

namespace sspc::codec {

std::uint32_t crc32_of(std::span<const std::byte> bytes);
// The CRC32 of the bytes so far (`crc`, 0 for none) followed by `bytes`: crc32_of in pieces.
std::uint32_t crc32_continue(std::uint32_t crc, std::span<const std::byte> bytes);

}  // namespace sspc::codec
