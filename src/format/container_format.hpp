// The constants and fixed layouts of the .sspc container, versions 1 and 2 (docs/FORMAT.md is the
// specification; this file mirrors its tables, and a change here is a change of format).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "sspc/point_cloud.hpp"

namespace sspc::codec {

// "\x8A S P C \r \n \x1A \n": high bit set (7-bit transfers), CR LF and LF (line-ending
// conversion either way), Ctrl-Z (stops an MS-DOS `type`). See FORMAT.md.
inline constexpr std::array<std::uint8_t, 8> kMagic = {0x8A, 'S', 'P', 'C', 0x0D, 0x0A, 0x1A, 0x0A};
// The version the writer writes, and the oldest one readers still decode. Versions 2 to 5
// changed only the code-book blocks' position layout (FORMAT.md, "Code-book blocks"; version 4
// only the columns' contexts of "another point", version 5 only their height prediction), and
// so did 6 and 7 (6 the occupancy bits' probabilities, 7 how the columns' values code lengths).
inline constexpr std::uint16_t kFormatVersion = 7;
inline constexpr std::uint16_t kOldestFormatVersion = 1;

inline constexpr std::uint16_t kFlagNormals = 1u << 0;
inline constexpr std::uint16_t kFlagColours = 1u << 1;
inline constexpr std::uint16_t kFlagMetadata = 1u << 2;  // the metadata part follows section 4
// Version 3 and later: code words store each occupied cell's point count (sspc encode
// --keep-duplicates); without it a cell holds one point.
inline constexpr std::uint16_t kFlagDuplicates = 1u << 3;
// Revision 3.1: the attributes part follows section 4 (FORMAT.md, "Attributes"); excludes
// kFlagColours.
inline constexpr std::uint16_t kFlagAttributes = 1u << 4;
inline constexpr std::uint16_t kKnownFlags =
    kFlagNormals | kFlagColours | kFlagMetadata | kFlagDuplicates | kFlagAttributes;
inline constexpr std::size_t kAttributeDescriptorSize = 16;  // after the part's 8-byte prefix
inline constexpr std::size_t kAttributeSeekEntrySize = 16;

inline constexpr std::size_t kHeaderSize = 196;
inline constexpr std::size_t kHeaderCrcOffset = 192;
inline constexpr std::size_t kSectionTableOffset = 96;
inline constexpr std::size_t kSectionEntrySize = 24;
inline constexpr std::size_t kSectionCount = 4;
inline constexpr std::size_t kCodebookSeekEntrySize = 32;
inline constexpr std::size_t kPatchSeekEntrySize = 56;

// A reader must be able to bound one block's memory whatever the file says.
inline constexpr std::uint32_t kMaxRawBlockSize = 1u << 26;
// And by the bytes the file really holds: a zstd-compressed block's raw size is at most this
// many times its stored size. Honest blocks expand 1-3x (bunny, levels 0-9, with and without
// normals), but zstd turns a few KB of runs into 64 MiB, which a hostile seek table could claim
// and whose points (kMaxPointsPerByte) the reader would allocate. A writer whose frame would
// expand more stores the block raw.
inline constexpr std::uint32_t kMaxBlockExpansion = 64;
// |v| < 2^24 keeps float(v) exact for translation grid values.
inline constexpr std::int64_t kMaxTranslationGrid = (std::int64_t{1} << 24) - 1;

inline constexpr int kMinPositionBits = 4, kMaxPositionBits = 16;
inline constexpr int kMinNormalBits = 4, kMaxNormalBits = 16;
inline constexpr int kMinRotationBits = 4, kMaxRotationBits = 20;

enum class SectionKind : std::uint32_t {
  kCodebookBlocks = 1,
  kCodebookSeek = 2,
  kPatchBlocks = 3,
  kPatchSeek = 4,
};

// Human-readable names for error messages and `sspc info`.
inline const char* section_name(SectionKind kind) {
  switch (kind) {
    case SectionKind::kCodebookBlocks: return "code-book blocks";
    case SectionKind::kCodebookSeek: return "code-book seek table";
    case SectionKind::kPatchBlocks: return "patch blocks";
    case SectionKind::kPatchSeek: return "patch seek table";
  }
  return "unknown section";
}

struct SectionEntry {
  SectionKind kind = SectionKind::kCodebookBlocks;
  std::uint32_t crc32 = 0;
  std::uint64_t offset = 0;
  std::uint64_t size = 0;
};

// The header's fields, decoded (FORMAT.md, "Header").
struct ContainerHeader {
  std::uint16_t version = kFormatVersion;
  std::uint16_t flags = 0;
  float patch_radius = 0;
  float coverage_radius = 0;
  float spacing = 0;
  float codeword_radius = 0;
  std::uint64_t source_points = 0;
  Vec3f bounds_min = Vec3f::Zero();
  Vec3f bounds_max = Vec3f::Zero();
  float translation_step = 0;
  int position_bits = 12;
  int normal_bits = 10;
  int rotation_bits = 13;
  // Version 4: the decoder replaces each decoded point by resample × resample points on its
  // code word's local surface (FORMAT.md, "Resampling"); 0: the points as stored.
  int resample = 0;
  std::uint32_t codeword_count = 0;
  std::uint32_t patch_count = 0;
  std::uint64_t codeword_point_count = 0;
  std::uint32_t codewords_per_block = 1;
  std::uint32_t patches_per_block = 1;
  std::array<SectionEntry, kSectionCount> sections{};

  bool has_normals() const { return (flags & kFlagNormals) != 0; }
  bool has_colours() const { return (flags & kFlagColours) != 0; }
  bool has_duplicates() const { return (flags & kFlagDuplicates) != 0; }
  bool has_metadata() const { return (flags & kFlagMetadata) != 0; }
  bool has_attributes() const { return (flags & kFlagAttributes) != 0; }
};

// One block's place in its section, as the seek tables store it.
struct BlockEntry {
  std::uint64_t offset = 0;  // within the section
  std::uint32_t stored_size = 0;
  std::uint32_t raw_size = 0;
  std::uint32_t crc32 = 0;
  std::uint32_t first = 0;
  std::uint32_t count = 0;
  std::uint32_t point_count = 0;  // code-book blocks only
  Box3f box;                      // patch blocks only

  bool is_stored_raw() const { return stored_size == raw_size; }
};

inline std::uint64_t block_count(std::uint64_t items, std::uint32_t per_block) {
  return per_block == 0 ? 0 : (items + per_block - 1) / per_block;
}

}  // namespace sspc::codec
