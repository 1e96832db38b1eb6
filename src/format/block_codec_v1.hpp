// Version 1 of the block payloads (docs/FORMAT.md, "Code-book blocks" and "Patch blocks"), which
// readers keep decoding and the writer no longer writes. It differs from version 2 in two fields
// only: code-word positions are two byte planes of 16-bit values (version 2 range-codes them),
// and patch translations are three zig-zag varints a patch (version 2: byte planes). The rest of
// a version 1 payload is decoded by the version 2 code in block_codec.cpp.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "core/byte_reader.hpp"

namespace sspc::codec::v1 {

// Bytes the positions of `points` code-word points take: 3 coordinates of 2 bytes.
constexpr std::uint64_t position_bytes(std::uint64_t points) { return 6 * points; }

// Decodes grid.size() points from `planes` (position_bytes(grid.size()) bytes: the low bytes of
// all coordinates, then the high bytes, x y z a point). False when a value exceeds `bits`.
bool decode_positions(std::span<const std::byte> planes, int bits,
                      std::span<std::array<std::uint32_t, 3>> grid);

// Reads one zig-zag translation delta (one axis of one patch). False when the varint is bad or
// the payload ends.
bool read_translation_delta(ByteReader& reader, std::uint64_t& zigzag);

}  // namespace sspc::codec::v1
