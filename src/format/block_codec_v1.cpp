// Version 1 block fields (block_codec_v1.hpp): read only.
#include "format/block_codec_v1.hpp"

#include "core/check.hpp"

namespace sspc::codec::v1 {

bool decode_positions(std::span<const std::byte> planes, int bits,
                      std::span<std::array<std::uint32_t, 3>> grid) {
  const std::size_t n = grid.size();
  SSPC_DCHECK(planes.size() == position_bytes(n));
  const auto byte_at = [&planes](std::size_t i) { return static_cast<std::uint32_t>(planes[i]); };
  std::uint32_t overflow = 0;
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t a = 0; a < 3; ++a) {
      const std::size_t j = 3 * i + a;
      grid[i][a] = byte_at(j) | (byte_at(3 * n + j) << 8);
      overflow |= grid[i][a] >> bits;
    }
  }
  return overflow == 0;
}

bool read_translation_delta(ByteReader& reader, std::uint64_t& zigzag) {
  return reader.read_varint(zigzag).ok();
}

}  // namespace sspc::codec::v1
