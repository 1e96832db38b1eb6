// Recomputes every CRC32 of an .sspc file (blocks, sections, header) wherever the file's layout
// fields allow, so that a fuzzer's mutations reach the decoders behind the checksums. Reads only
// what it has bounds-checked; a file too broken to locate a CRC keeps that CRC as it was.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

#include "format/checksum.hpp"
#include "format/container_format.hpp"

namespace sspc::fuzz {

inline std::uint64_t load_le(const std::string& s, std::size_t at, int bytes) {
  std::uint64_t v = 0;
  for (int i = bytes - 1; i >= 0; --i) {
    v = (v << 8) | static_cast<std::uint8_t>(s[at + static_cast<std::size_t>(i)]);
  }
  return v;
}

inline void store_le32(std::string& s, std::size_t at, std::uint32_t v) {
  for (std::size_t i = 0; i < 4; ++i) s[at + i] = static_cast<char>((v >> (8 * i)) & 0xFF);
}

inline std::uint32_t crc_of(const std::string& s, std::uint64_t offset, std::uint64_t size) {
  return codec::crc32_of(std::as_bytes(std::span<const char>(s.data() + offset, size)));
}

inline std::string repair_crcs(std::string s) {
  using namespace codec;
  if (s.size() < kHeaderSize) return s;
  struct Section {
    std::uint64_t offset = 0, size = 0;
    bool inside = false;
  };
  Section sec[kSectionCount];
  for (std::size_t i = 0; i < kSectionCount; ++i) {
    const std::size_t e = kSectionTableOffset + i * kSectionEntrySize;
    sec[i].offset = load_le(s, e + 8, 8);
    sec[i].size = load_le(s, e + 16, 8);
    sec[i].inside = sec[i].offset <= s.size() && sec[i].size <= s.size() - sec[i].offset;
  }
  for (std::size_t data : {std::size_t{0}, std::size_t{2}}) {
    const Section& d = sec[data];
    const Section& t = sec[data + 1];
    const std::size_t entry = data == 0 ? kCodebookSeekEntrySize : kPatchSeekEntrySize;
    if (!d.inside || !t.inside) continue;
    for (std::uint64_t e = t.offset; e + entry <= t.offset + t.size; e += entry) {
      const std::uint64_t off = load_le(s, e, 8);
      const std::uint64_t stored = load_le(s, e + 8, 4);
      if (off > d.size || stored > d.size - off) continue;
      store_le32(s, e + 16, crc_of(s, d.offset + off, stored));
    }
  }
  // The attributes part (header flag bit 4), right after section 4: its blocks, then its table.
  const auto flags = static_cast<std::uint16_t>(load_le(s, 10, 2));
  if ((flags & kFlagAttributes) != 0 && sec[3].inside) {
    const std::uint64_t start = sec[3].offset + sec[3].size;
    const std::uint64_t blocks = sec[3].size / kPatchSeekEntrySize;
    const std::uint64_t table = kAttributeDescriptorSize + kAttributeSeekEntrySize * blocks;
    if (start <= s.size() && s.size() - start >= 8 + table) {
      const std::uint64_t data = start + 8 + table;
      for (std::uint64_t b = 0; b < blocks; ++b) {
        const std::uint64_t e = start + 24 + b * kAttributeSeekEntrySize;
        const std::uint64_t off = load_le(s, e, 8);
        const std::uint64_t size = load_le(s, e + 8, 4);
        if (off > s.size() - data || size > s.size() - data - off) continue;
        store_le32(s, e + 12, crc_of(s, data + off, size));
      }
      store_le32(s, start + 4, crc_of(s, start + 8, table));
    }
  }
  for (std::size_t i = 0; i < kSectionCount; ++i) {
    if (!sec[i].inside) continue;
    store_le32(s, kSectionTableOffset + i * kSectionEntrySize + 4,
               crc_of(s, sec[i].offset, sec[i].size));
  }
  store_le32(s, kHeaderCrcOffset, crc_of(s, 0, kHeaderCrcOffset));
  return s;
}

}  // namespace sspc::fuzz
