// LZF decompression, for PCD's binary_compressed bodies.
//
// Format: Marc Lehmann's liblzf (lzf_d.c), which PCL embeds. The stream is a sequence of
// instructions, each starting with a control byte `c`:
//   c < 32:  a literal run; the next c + 1 bytes are copied to the output.
//   c >= 32: a back-reference of length (c >> 5) + 2, where a length field of 7 is extended by
//            the next byte; the distance is ((c & 31) << 8) + next byte + 1 bytes back from the
//            current end of the output. Source and destination may overlap (runs).
//
// Safe on untrusted input: every read of the input and every write and back-reference into the
// output is bounds-checked, and the output is never grown beyond the size the caller expects.
#pragma once

#include <cstddef>
#include <span>

#include "sspc/status.hpp"

namespace sspc::io {

// The most output one input byte can produce: a 3-byte back-reference yields at most 264 bytes.
inline constexpr std::size_t kLzfMaxExpansion = 88;

// Decompresses `in` into exactly `out.size()` bytes. kCorrupt when the stream is malformed (a
// literal or back-reference running past the input, a back-reference before the start of the
// output), would produce more than out.size() bytes, or produces fewer. Messages give the byte
// offset of the failing instruction counted from `base_offset` (the stream's place in its file).
Status lzf_decompress(std::span<const std::byte> in, std::span<std::byte> out,
                      std::size_t base_offset = 0);

}  // namespace sspc::io
