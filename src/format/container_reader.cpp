// The .sspc reader: header and seek-table validation at open, CRC-checked block loads after.
// Every rule of FORMAT.md that a reader "must" enforce is enforced here or in block_codec.cpp.
#include "format/container_reader.hpp"

#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>

#include <zstd.h>

#include "core/byte_reader.hpp"
#include "format/checksum.hpp"
#include "format/resample.hpp"

namespace sspc::codec {
namespace {

// Little-endian loads from spans the caller has already checked.
std::uint16_t le16(const std::byte* p) {
  return static_cast<std::uint16_t>(static_cast<unsigned>(p[0]) |
                                    (static_cast<unsigned>(p[1]) << 8));
}
std::uint32_t le32(const std::byte* p) {
  std::uint32_t v = 0;
  for (int i = 3; i >= 0; --i) v = (v << 8) | static_cast<std::uint32_t>(p[i]);
  return v;
}
std::uint64_t le64(const std::byte* p) {
  return le32(p) | (static_cast<std::uint64_t>(le32(p + 4)) << 32);
}
float lef32(const std::byte* p) {
  return std::bit_cast<float>(le32(p));
}
Vec3f levec3(const std::byte* p) {
  return {lef32(p), lef32(p + 4), lef32(p + 8)};
}

std::string hex32(std::uint32_t v) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%08x", v);
  return buf;
}

struct ZstdDctxDeleter {
  void operator()(ZSTD_DCtx* ctx) const { ZSTD_freeDCtx(ctx); }
};

ZSTD_DCtx* thread_dctx() {
  thread_local std::unique_ptr<ZSTD_DCtx, ZstdDctxDeleter> ctx(ZSTD_createDCtx());
  return ctx.get();
}

// A corrupt-file status naming the file and the byte offset of the broken field.
struct Failure {
  std::string file;
  Status operator()(std::uint64_t offset, const std::string& what) const {
    return corrupt(file + ": byte " + std::to_string(offset) + ": " + what);
  }
};

// Step 1: magic, version, the header's size and CRC. Returns the version.
StatusOr<std::uint16_t> check_preamble(std::span<const std::byte> bytes, const Failure& fail) {
  if (bytes.size() < kMagic.size() ||
      std::memcmp(bytes.data(), kMagic.data(), kMagic.size()) != 0) {
    return corrupt(fail.file + ": not an .sspc file (bad magic number)");
  }
  if (bytes.size() < 10) return fail(bytes.size(), "truncated header (no version)");
  const std::uint16_t version = le16(bytes.data() + 8);
  if (version < kOldestFormatVersion || version > kFormatVersion) {
    return unsupported(fail.file + ": .sspc format version " + std::to_string(version) +
                       " (this sspc reads versions " + std::to_string(kOldestFormatVersion) + " to " +
                       std::to_string(kFormatVersion) + ")");
  }
  if (bytes.size() < kHeaderSize) {
    return fail(bytes.size(), "truncated header: " + std::to_string(bytes.size()) + " of " +
                                  std::to_string(kHeaderSize) + " bytes");
  }
  const std::uint32_t stored_crc = le32(bytes.data() + kHeaderCrcOffset);
  const std::uint32_t crc = crc32_of(bytes.first(kHeaderCrcOffset));
  if (stored_crc != crc) {
    return fail(kHeaderCrcOffset, "header CRC32 mismatch (stored " + hex32(stored_crc) +
                                      ", computed " + hex32(crc) + ")");
  }
  return version;
}

// Step 2: the header's fields (FORMAT.md "Header"), each checked against its range.
Status read_header_fields(const std::byte* p, std::uint16_t version, const Failure& fail,
                          ContainerHeader& h) {
  h.version = version;
  h.flags = le16(p + 10);
  if ((h.flags & ~kKnownFlags) != 0) return fail(10, "unknown flags " + hex32(h.flags));
  if (h.has_duplicates() && version < 3) return fail(10, "flag bit 3 (duplicates) before version 3");
  if (h.has_attributes() && version < 3) return fail(10, "flag bit 4 (attributes) before version 3");
  if (h.has_attributes() && h.has_colours()) {
    return fail(10, "flag bits 1 (code-word colours) and 4 (attributes) are exclusive");
  }
  if (le32(p + 12) != kHeaderSize) return fail(12, "header size is not 196");
  h.patch_radius = lef32(p + 16);
  h.coverage_radius = lef32(p + 20);
  h.spacing = lef32(p + 24);
  h.codeword_radius = lef32(p + 28);
  h.source_points = le64(p + 32);
  h.bounds_min = levec3(p + 40);
  h.bounds_max = levec3(p + 52);
  h.translation_step = lef32(p + 64);
  h.position_bits = static_cast<int>(p[68]);
  h.normal_bits = static_cast<int>(p[69]);
  h.rotation_bits = static_cast<int>(p[70]);
  h.codeword_count = le32(p + 72);
  h.patch_count = le32(p + 76);
  h.codeword_point_count = le64(p + 80);
  h.codewords_per_block = le32(p + 88);
  h.patches_per_block = le32(p + 92);

  if (!(h.patch_radius > 0) || !std::isfinite(h.patch_radius)) return fail(16, "bad patch_radius");
  if (!(h.coverage_radius >= 0) || !std::isfinite(h.coverage_radius)) {
    return fail(20, "bad coverage_radius");
  }
  if (!(h.spacing >= 0) || !std::isfinite(h.spacing)) return fail(24, "bad spacing");
  if (!(h.codeword_radius >= 0) || !std::isfinite(h.codeword_radius)) {
    return fail(28, "bad codeword_radius");
  }
  if (!h.bounds_min.allFinite() || !h.bounds_max.allFinite() ||
      !(h.bounds_min.array() <= h.bounds_max.array()).all()) {
    return fail(40, "bad bounds");
  }
  if (!(h.translation_step > 0) || !std::isfinite(h.translation_step)) {
    return fail(64, "bad translation_step");
  }
  if (h.position_bits < kMinPositionBits || h.position_bits > kMaxPositionBits) {
    return fail(68, "position_bits out of range");
  }
  if (h.normal_bits < kMinNormalBits || h.normal_bits > kMaxNormalBits) {
    return fail(69, "normal_bits out of range");
  }
  if (h.rotation_bits < kMinRotationBits || h.rotation_bits > kMaxRotationBits) {
    return fail(70, "rotation_bits out of range");
  }
  h.resample = static_cast<int>(p[71]);
  if (h.version < 4 && h.resample != 0) return fail(71, "reserved byte is not 0");
  if (h.resample > kMaxResample) return fail(71, "resample out of range");
  if (h.codewords_per_block == 0) return fail(88, "codewords_per_block is 0");
  if (h.patches_per_block == 0) return fail(92, "patches_per_block is 0");
  return Status();
}

// Step 3: the section table. Sections are in order and contiguous from the header's end;
// returns where the last one ends.
StatusOr<std::uint64_t> read_section_table(std::span<const std::byte> bytes, const Failure& fail,
                                           ContainerHeader& h) {
  std::uint64_t expected = kHeaderSize;
  for (std::size_t i = 0; i < kSectionCount; ++i) {
    const std::uint64_t at = kSectionTableOffset + i * kSectionEntrySize;
    const std::byte* e = bytes.data() + at;
    SectionEntry& s = h.sections[i];
    const std::uint32_t kind = le32(e);
    if (kind != i + 1)
      return fail(at,
                  "section table entry " + std::to_string(i) + " has kind " + std::to_string(kind));
    s.kind = static_cast<SectionKind>(kind);
    s.crc32 = le32(e + 4);
    s.offset = le64(e + 8);
    s.size = le64(e + 16);
    if (s.offset != expected) {
      return fail(at + 8, std::string(section_name(s.kind)) + " starts at " +
                              std::to_string(s.offset) + ", expected " + std::to_string(expected));
    }
    if (s.size > bytes.size() - std::min<std::uint64_t>(s.offset, bytes.size())) {
      return fail(bytes.size(), std::string("truncated: the ") + section_name(s.kind) +
                                    " section ends at byte " + std::to_string(s.offset + s.size) +
                                    " but the file has " + std::to_string(bytes.size()) + " bytes");
    }
    expected = s.offset + s.size;
  }
  return expected;
}

// Step 4: the seek tables' sizes follow from the counts (which bounds the counts by the file
// size), and their CRCs are checked before any entry is trusted.
Status check_seek_tables(std::span<const std::byte> bytes, const ContainerHeader& h,
                         const Failure& fail) {
  const SectionEntry& cw_seek = h.sections[1];
  const SectionEntry& p_seek = h.sections[3];
  const std::uint64_t cw_blocks = block_count(h.codeword_count, h.codewords_per_block);
  const std::uint64_t p_blocks = block_count(h.patch_count, h.patches_per_block);
  if (cw_seek.size != cw_blocks * kCodebookSeekEntrySize) {
    return fail(cw_seek.offset, "code-book seek table has " + std::to_string(cw_seek.size) +
                                    " bytes; " + std::to_string(h.codeword_count) +
                                    " code words need " +
                                    std::to_string(cw_blocks * kCodebookSeekEntrySize));
  }
  if (p_seek.size != p_blocks * kPatchSeekEntrySize) {
    return fail(p_seek.offset, "patch seek table has " + std::to_string(p_seek.size) + " bytes; " +
                                   std::to_string(h.patch_count) + " patches need " +
                                   std::to_string(p_blocks * kPatchSeekEntrySize));
  }
  for (const SectionEntry* s : {&cw_seek, &p_seek}) {
    const std::uint32_t c = crc32_of(bytes.subspan(s->offset, s->size));
    if (c != s->crc32) {
      return fail(s->offset, std::string(section_name(s->kind)) + ": CRC32 mismatch (stored " +
                                 hex32(s->crc32) + ", computed " + hex32(c) + ")");
    }
  }
  return Status();
}

// Which seek table step 5 reads: the two share the first 28 bytes of an entry (FORMAT.md
// "Seek tables") and differ in the rest.
struct SeekTable {
  const SectionEntry& seek;
  const SectionEntry& data;
  std::uint32_t per_block;
  std::uint64_t items;
  bool patches;
};

// Step 5: one seek table's entries. Blocks tile their data section in order, each holds the
// items its position says, and (code book) the point counts add up to the header's.
Status read_seek_entries(std::span<const std::byte> bytes, const ContainerHeader& h,
                         const SeekTable& t, const Failure& fail, std::vector<BlockEntry>& out) {
  out.resize(block_count(t.items, t.per_block));
  std::uint64_t next = 0;
  std::uint64_t points = 0;
  const std::size_t entry_size = t.patches ? kPatchSeekEntrySize : kCodebookSeekEntrySize;
  for (std::uint64_t b = 0; b < out.size(); ++b) {
    const std::uint64_t at = t.seek.offset + b * entry_size;
    const std::byte* e = bytes.data() + at;
    BlockEntry& x = out[b];
    x.offset = le64(e);
    x.stored_size = le32(e + 8);
    x.raw_size = le32(e + 12);
    x.crc32 = le32(e + 16);
    x.first = le32(e + 20);
    x.count = le32(e + 24);
    const std::string what = std::string(section_name(t.seek.kind)) + ", block " + std::to_string(b);
    if (x.offset != next)
      return fail(at, what + ": offset " + std::to_string(x.offset) + ", expected " +
                          std::to_string(next));
    if (x.stored_size == 0 || x.raw_size == 0 || x.stored_size > x.raw_size ||
        x.raw_size > kMaxRawBlockSize) {
      return fail(at + 8, what + ": bad sizes (stored " + std::to_string(x.stored_size) +
                              ", raw " + std::to_string(x.raw_size) + ")");
    }
    if (x.raw_size > std::uint64_t{x.stored_size} * kMaxBlockExpansion) {
      return fail(at + 8, what + ": " + std::to_string(x.stored_size) +
                              " stored bytes cannot expand to " + std::to_string(x.raw_size) +
                              " (at most " + std::to_string(kMaxBlockExpansion) + "x)");
    }
    if (x.stored_size > t.data.size - next) {
      return fail(at + 8, what + " runs past the end of its section");
    }
    next += x.stored_size;
    const std::uint64_t first = b * t.per_block;
    if (x.first != first || x.count != std::min<std::uint64_t>(t.per_block, t.items - first)) {
      return fail(at + 20, what + ": first/count " + std::to_string(x.first) + "/" +
                               std::to_string(x.count) + " do not match the block's position");
    }
    if (t.patches) {
      if (le32(e + 28) != 0) return fail(at + 28, what + ": reserved field is not 0");
      const Vec3f lo = levec3(e + 32), hi = levec3(e + 44);
      if (!lo.allFinite() || !hi.allFinite() || !(lo.array() <= hi.array()).all()) {
        return fail(at + 32, what + ": bad box");
      }
      x.box = Box3f(lo, hi);
    } else {
      x.point_count = le32(e + 28);
      if (!codeword_points_fit(h, x.point_count, x.raw_size)) {
        return fail(at + 28, what + ": " + std::to_string(x.point_count) +
                                 " points cannot fit in " + std::to_string(x.raw_size) + " bytes");
      }
      points += x.point_count;
    }
  }
  if (next != t.data.size) {
    return fail(t.data.offset + next, std::string(section_name(t.data.kind)) + ": " +
                                          std::to_string(t.data.size - next) +
                                          " bytes after the last block");
  }
  if (!t.patches && points != h.codeword_point_count) {
    return fail(80, "codeword_point_count " + std::to_string(h.codeword_point_count) +
                        " but the seek table adds up to " + std::to_string(points));
  }
  return Status();
}

// Step 6 (flag bit 4): the attributes part at `start`: its prefix, descriptor and seek table
// (FORMAT.md, "Attributes"). Returns where the part ends.
StatusOr<std::uint64_t> read_attribute_part(std::span<const std::byte> bytes, std::uint64_t start,
                                            std::uint64_t blocks, const Failure& fail,
                                            AttributeParams& params,
                                            std::vector<BlockEntry>& entries) {
  const std::uint64_t left = bytes.size() - start;
  if (left < 8) return fail(start, "truncated attributes part");
  const std::byte* p = bytes.data() + start;
  const std::uint64_t size = le32(p);
  const std::uint64_t table = kAttributeDescriptorSize + kAttributeSeekEntrySize * blocks;
  if (size > left - 8) {
    return fail(start, "attributes part of " + std::to_string(size) + " bytes, " +
                           std::to_string(left - 8) + " left in the file");
  }
  if (size < table) {
    return fail(start, "attributes part of " + std::to_string(size) + " bytes cannot hold " +
                           std::to_string(blocks) + " seek entries");
  }
  const std::uint32_t crc = crc32_of(bytes.subspan(start + 8, table));
  if (crc != le32(p + 4)) {
    return fail(start + 4, "attributes table CRC32 mismatch (stored " + hex32(le32(p + 4)) +
                               ", computed " + hex32(crc) + ")");
  }
  params.channels = static_cast<std::uint8_t>(p[8]);
  params.colour_step = static_cast<int>(p[9]);
  params.intensity_step = le16(p + 10);
  if (params.channels == 0 || (params.channels & ~kKnownChannels) != 0) {
    return fail(start + 8, "bad attribute channels " + hex32(params.channels));
  }
  const bool colour = (params.channels & kChannelColour) != 0;
  const bool intensity = (params.channels & kChannelIntensity) != 0;
  if (colour ? params.colour_step < 1 || params.colour_step > kMaxColourStep
             : params.colour_step != 0) {
    return fail(start + 9, "bad colour_step " + std::to_string(params.colour_step));
  }
  if (intensity ? params.intensity_step < 1 || params.intensity_step > kMaxIntensityStep
                : params.intensity_step != 0) {
    return fail(start + 10, "bad intensity_step " + std::to_string(params.intensity_step));
  }
  for (std::uint64_t i = 12; i < 24; ++i) {
    if (p[i] != std::byte{0}) return fail(start + i, "attributes reserved byte is not 0");
  }
  const std::uint64_t data_start = start + 8 + table;
  const std::uint64_t data_size = size - table;
  entries.resize(blocks);
  std::uint64_t next = 0;
  for (std::uint64_t b = 0; b < blocks; ++b) {
    const std::uint64_t at = start + 24 + b * kAttributeSeekEntrySize;
    const std::byte* e = bytes.data() + at;
    BlockEntry& x = entries[b];
    const std::uint64_t offset = le64(e);
    x.stored_size = le32(e + 8);
    x.raw_size = x.stored_size;
    x.crc32 = le32(e + 12);
    const std::string what = "attributes, block " + std::to_string(b);
    if (offset != next) {
      return fail(at, what + ": offset " + std::to_string(offset) + ", expected " +
                          std::to_string(next));
    }
    if (x.stored_size == 0 || x.stored_size > data_size - next) {
      return fail(at + 8, what + ": bad size " + std::to_string(x.stored_size));
    }
    x.offset = data_start + offset;
    next += x.stored_size;
  }
  if (next != data_size) {
    return fail(data_start + next,
                "attributes: " + std::to_string(data_size - next) + " bytes after the last block");
  }
  return start + 8 + size;
}

}  // namespace

StatusOr<ContainerReader> ContainerReader::open(std::span<const std::byte> bytes,
                                                std::string name) {
  const Failure fail{name};
  auto version = check_preamble(bytes, fail);
  if (!version.ok()) return version.status();

  ContainerReader r;
  r.bytes_ = bytes;
  r.name_ = std::move(name);
  ContainerHeader& h = r.header_;
  SSPC_RETURN_IF_ERROR(read_header_fields(bytes.data(), *version, fail, h));
  auto sections_end = read_section_table(bytes, fail, h);
  if (!sections_end.ok()) return sections_end.status();
  std::uint64_t end = *sections_end;
  if (h.has_attributes()) {
    auto attributes_end = read_attribute_part(bytes, end, block_count(h.patch_count, h.patches_per_block),
                                              fail, r.attributes_, r.attribute_blocks_);
    if (!attributes_end.ok()) return attributes_end.status();
    r.attributes_.unary_lengths = h.version >= 7;
    r.attribute_part_bytes_ = *attributes_end - end;
    end = *attributes_end;
  }
  if (h.has_metadata()) {
    auto metadata = decode_metadata(bytes.subspan(static_cast<std::size_t>(end)), end, r.name_);
    if (!metadata.ok()) return metadata.status();
    r.metadata_ = std::move(*metadata);
  } else if (end != bytes.size()) {
    return fail(end, std::to_string(bytes.size() - end) +
                         " trailing bytes after the declared end of the file");
  }
  SSPC_RETURN_IF_ERROR(check_seek_tables(bytes, h, fail));
  SSPC_RETURN_IF_ERROR(read_seek_entries(
      bytes, h, {h.sections[1], h.sections[0], h.codewords_per_block, h.codeword_count, false},
      fail, r.codebook_blocks_));
  SSPC_RETURN_IF_ERROR(read_seek_entries(
      bytes, h, {h.sections[3], h.sections[2], h.patches_per_block, h.patch_count, true}, fail,
      r.patch_blocks_));
  return r;
}

Status ContainerReader::block_error(SectionKind kind, std::size_t block, const BlockEntry& entry,
                                    const Status& cause) const {
  const SectionEntry& s = header_.sections[static_cast<std::size_t>(kind) - 1];
  const char* items = kind == SectionKind::kCodebookBlocks ? "code words" : "patches";
  const std::string last = entry.count == 0 ? std::to_string(entry.first)
                                            : std::to_string(entry.first + entry.count - 1);
  return Status(cause.code(),
                name_ + ": " + section_name(kind) + " section, block " + std::to_string(block) +
                    " (" + items + " " + std::to_string(entry.first) + "–" + last + ", byte " +
                    std::to_string(s.offset + entry.offset) + "): " + cause.message());
}

Status ContainerReader::load_block(SectionKind kind, std::size_t block, const BlockEntry& entry,
                                   std::vector<std::byte>& scratch,
                                   std::span<const std::byte>& payload) const {
  const SectionEntry& s = header_.sections[static_cast<std::size_t>(kind) - 1];
  // open() proved that the block lies inside its section and the section inside the file.
  const std::span<const std::byte> stored =
      bytes_.subspan(s.offset + entry.offset, entry.stored_size);
  const std::uint32_t crc = crc32_of(stored);
  if (crc != entry.crc32) {
    return block_error(
        kind, block, entry,
        corrupt("CRC32 mismatch (stored " + hex32(entry.crc32) + ", computed " + hex32(crc) + ")"));
  }
  if (entry.is_stored_raw()) {
    payload = stored;
    return Status();
  }
  const std::size_t frame = ZSTD_findFrameCompressedSize(stored.data(), stored.size());
  if (ZSTD_isError(frame) || frame != stored.size()) {
    return block_error(kind, block, entry, corrupt("not exactly one zstd frame"));
  }
  scratch.resize(entry.raw_size);
  const std::size_t n = ZSTD_decompressDCtx(thread_dctx(), scratch.data(), scratch.size(),
                                            stored.data(), stored.size());
  if (ZSTD_isError(n)) {
    return block_error(kind, block, entry, corrupt(std::string("zstd: ") + ZSTD_getErrorName(n)));
  }
  if (n != entry.raw_size) {
    return block_error(kind, block, entry,
                       corrupt("decompressed to " + std::to_string(n) +
                               " bytes, the seek table says " + std::to_string(entry.raw_size)));
  }
  payload = std::span<const std::byte>(scratch.data(), n);
  return Status();
}

std::pair<std::size_t, std::size_t> ContainerReader::block_bytes(SectionKind kind, std::size_t block) const {
  const std::vector<BlockEntry>& entries = kind == SectionKind::kCodebookBlocks ? codebook_blocks_ : patch_blocks_;
  if (block >= entries.size()) return {0, 0};
  const std::size_t begin = header_.sections[static_cast<std::size_t>(kind) - 1].offset + entries[block].offset;
  return {begin, begin + entries[block].stored_size};
}

Status ContainerReader::read_codewords(std::size_t block, DecodedCodewords& out) const {
  if (block >= codebook_blocks_.size()) return invalid_argument("code-book block out of range");
  out.surfaces.clear();  // they point into the points the decode replaces
  const BlockEntry& entry = codebook_blocks_[block];
  thread_local std::vector<std::byte> scratch;
  std::span<const std::byte> payload;
  SSPC_RETURN_IF_ERROR(load_block(SectionKind::kCodebookBlocks, block, entry, scratch, payload));
  Status s = decode_codeword_block(payload, entry, header_, out);
  if (!s.ok()) return block_error(SectionKind::kCodebookBlocks, block, entry, s);
  for (std::uint32_t c = 0; c < out.count(); ++c) {
    if (out.radius[c] > header_.codeword_radius) {
      return block_error(SectionKind::kCodebookBlocks, block, entry,
                         corrupt("code word " + std::to_string(entry.first + c) +
                                 " reaches beyond the header's codeword_radius"));
    }
  }
  if (header_.resample > 0) {
    out.surfaces.reserve(out.count());
    for (std::uint32_t c = 0; c < out.count(); ++c) {
      out.surfaces.emplace_back(std::span<const Vec3f>(out.points.data() + out.offsets[c],
                                                       out.offsets[c + 1] - out.offsets[c]));
    }
  }
  return Status();
}

Status ContainerReader::read_patches(std::size_t block, DecodedPatches& out) const {
  if (block >= patch_blocks_.size()) return invalid_argument("patch block out of range");
  const BlockEntry& entry = patch_blocks_[block];
  thread_local std::vector<std::byte> scratch;
  std::span<const std::byte> payload;
  SSPC_RETURN_IF_ERROR(load_block(SectionKind::kPatchBlocks, block, entry, scratch, payload));
  Status s = decode_patch_block(payload, entry, header_, true, out);
  if (!s.ok()) return block_error(SectionKind::kPatchBlocks, block, entry, s);
  if (header_.has_attributes()) return read_attribute_streams(block, out);
  out.attribute_streams.clear();
  return Status();
}

Status ContainerReader::read_attribute_streams(std::size_t block, DecodedPatches& out) const {
  const BlockEntry& entry = attribute_blocks_[block];
  auto fail = [&](std::uint64_t at, const std::string& what) {
    return corrupt(name_ + ": attributes, block " + std::to_string(block) + " (patches " +
                   std::to_string(out.first) + "–" + std::to_string(out.first + out.count() - 1) +
                   ", byte " + std::to_string(at) + "): " + what);
  };
  const std::span<const std::byte> stored = bytes_.subspan(entry.offset, entry.stored_size);
  const std::uint32_t crc = crc32_of(stored);
  if (crc != entry.crc32) {
    return fail(entry.offset, "CRC32 mismatch (stored " + hex32(entry.crc32) + ", computed " +
                                  hex32(crc) + ")");
  }
  ByteReader in(stored, entry.offset);
  out.attribute_streams.assign(out.count(), {});
  std::vector<std::uint64_t> sizes;
  for (std::uint32_t k = 0; k < out.count(); ++k) {
    for (int c = 0; c < kChannelCount; ++c) {
      if ((attributes_.channels & (1u << c)) == 0) continue;
      std::uint64_t n = 0;
      if (!in.read_varint(n).ok() || n > in.remaining()) {
        return fail(in.offset(), "bad stream size");
      }
      sizes.push_back(n);
    }
  }
  std::size_t at = in.position();
  std::size_t i = 0;
  for (std::uint32_t k = 0; k < out.count(); ++k) {
    for (int c = 0; c < kChannelCount; ++c) {
      if ((attributes_.channels & (1u << c)) == 0) continue;
      const std::uint64_t n = sizes[i++];
      if (n > stored.size() - at) return fail(entry.offset + at, "streams run past the block");
      out.attribute_streams[k][static_cast<std::size_t>(c)] = stored.subspan(at, n);
      at += n;
    }
  }
  if (at != stored.size()) {
    return fail(entry.offset + at, std::to_string(stored.size() - at) + " bytes after the last stream");
  }
  return Status();
}

Status ContainerReader::check_section_crc(SectionKind kind) const {
  const SectionEntry& s = header_.sections[static_cast<std::size_t>(kind) - 1];
  const std::uint32_t c = crc32_of(bytes_.subspan(s.offset, s.size));
  if (c != s.crc32) {
    return corrupt(name_ + ": " + section_name(kind) + " section (bytes " +
                   std::to_string(s.offset) + "–" + std::to_string(s.offset + s.size) +
                   "): CRC32 mismatch (stored " + hex32(s.crc32) + ", computed " + hex32(c) + ")");
  }
  return Status();
}

}  // namespace sspc::codec
