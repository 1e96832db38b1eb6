// Reads an .sspc container (docs/FORMAT.md) from bytes in memory or a mapped file.
//
// Safe on untrusted input. open() checks the magic, the version, the header's CRC and every
// header field, the exact layout of the sections (no gaps, no trailing bytes), the seek tables'
// CRCs and every seek-table entry, bounding every count by the file's size before allocating.
// Reading a block checks its CRC before decompressing, checks that zstd produced exactly the
// seek table's raw size, and decodes the payload with bounds checks. Errors are kCorrupt (or
// kUnsupported for a newer version) and name the file, the section, the block and the byte
// offset in the file.
//
// Thread-safe: the reader is immutable after open(); block reads use per-thread zstd contexts.
#pragma once

#include <cstddef>
#include <span>
#include <utility>
#include <string>
#include <vector>

#include "format/attribute_coder.hpp"
#include "format/block_codec.hpp"
#include "format/container_format.hpp"
#include "format/metadata_section.hpp"
#include "sspc/status.hpp"

namespace sspc::codec {

class ContainerReader {
 public:
  // `bytes` must outlive the reader; `name` is used in error messages (a path or "<memory>").
  static StatusOr<ContainerReader> open(std::span<const std::byte> bytes, std::string name);

  const ContainerHeader& header() const { return header_; }
  const std::vector<BlockEntry>& codebook_blocks() const { return codebook_blocks_; }
  const std::vector<BlockEntry>& patch_blocks() const { return patch_blocks_; }
  std::size_t file_size() const { return bytes_.size(); }
  const std::string& name() const { return name_; }
  // The metadata part; origin 0 and nothing else for a file without one.
  const ModelMetadata& metadata() const { return metadata_; }
  // The attributes part's parameters; channels 0 for a file without one.
  const AttributeParams& attributes() const { return attributes_; }
  std::uint64_t attribute_part_bytes() const { return attribute_part_bytes_; }

  Status read_codewords(std::size_t block, DecodedCodewords& out) const;
  Status read_patches(std::size_t block, DecodedPatches& out) const;

  // Where a code-book or patch block's stored bytes lie in the file: [first, second). A reader
  // of a mapped file hands them back to the kernel once decoded (CompressedModel's block source).
  std::pair<std::size_t, std::size_t> block_bytes(SectionKind kind, std::size_t block) const;

  // CRC32 of a whole block section (open() checks only the seek tables'); for verify().
  Status check_section_crc(SectionKind kind) const;

 private:
  // Checks the stored bytes' CRC and returns the raw payload (a view of the file when stored
  // raw, else decompressed into `scratch`).
  Status load_block(SectionKind kind, std::size_t block, const BlockEntry& entry,
                    std::vector<std::byte>& scratch, std::span<const std::byte>& payload) const;
  Status block_error(SectionKind kind, std::size_t block, const BlockEntry& entry,
                     const Status& cause) const;

  std::span<const std::byte> bytes_;
  std::string name_;
  ContainerHeader header_;
  std::vector<BlockEntry> codebook_blocks_;
  std::vector<BlockEntry> patch_blocks_;
  ModelMetadata metadata_;
  AttributeParams attributes_;
  std::vector<BlockEntry> attribute_blocks_;  // offset from the file's start; raw_size unused
  std::uint64_t attribute_part_bytes_ = 0;
  Status read_attribute_streams(std::size_t block, DecodedPatches& out) const;
};

}  // namespace sspc::codec
