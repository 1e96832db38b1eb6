// The raw payloads of code-book blocks and patch blocks (docs/FORMAT.md, "Code-book blocks" and
// "Patch blocks"): quantised values laid out for zstd, and their decoding. The writer encodes
// with these and decodes its own output to learn what a reader will see (code-word radii, block
// boxes); the reader decodes with them. Safe on untrusted payloads: every count is bounded by the
// payload's size before anything is allocated, and every byte read is bounds-checked.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "format/container_format.hpp"
#include "format/encoded_model.hpp"
#include "format/resample.hpp"
#include "sspc/status.hpp"

namespace sspc::codec {

// One code-book block, decoded: code words [first, first + count), points concatenated.
struct DecodedCodewords {
  std::uint32_t first = 0;
  std::vector<std::uint32_t> offsets;  // count + 1 offsets into points
  std::vector<Vec3f> points;           // in each code word's frame
  std::vector<float> norm2;            // |point|², as the region test uses it
  std::vector<Vec3f> normals;          // empty without normals
  std::vector<Rgb8> colours;            // empty without colours
  std::vector<float> radius;           // per code word: sqrt(max norm2), 0 when empty
  // Per code word when the header asks for resampling (ContainerReader::read_codewords),
  // otherwise empty.
  std::vector<CodewordFit> surfaces;

  std::uint32_t count() const { return static_cast<std::uint32_t>(radius.size()); }
  // The bytes it holds, as the model's block cache counts them.
  std::uint64_t memory_bytes() const {
    return sizeof(*this) + offsets.capacity() * sizeof(std::uint32_t) + points.capacity() * sizeof(Vec3f) +
           norm2.capacity() * sizeof(float) + normals.capacity() * sizeof(Vec3f) + colours.capacity() * sizeof(Rgb8) +
           radius.capacity() * sizeof(float) + surface_bytes();
  }
  std::uint64_t surface_bytes() const {
    std::uint64_t bytes = 0;
    for (const CodewordFit& s : surfaces) bytes += s.memory_bytes();
    return bytes;
  }
};

// One patch block, decoded: patches [first, first + count).
struct DecodedPatches {
  std::uint32_t first = 0;
  std::vector<std::uint32_t> codeword;
  std::vector<Eigen::Matrix3f> rotation;  // of world_from_codeword
  std::vector<Vec3f> centre;              // translation of world_from_codeword = region centre
  // With an attributes part: each patch's streams, indexed by channel bit (empty when absent),
  // views of the file (FORMAT.md, "Attributes").
  std::vector<std::array<std::span<const std::byte>, 4>> attribute_streams;

  std::uint32_t count() const { return static_cast<std::uint32_t>(codeword.size()); }
  std::uint64_t memory_bytes() const {
    return sizeof(*this) + codeword.capacity() * sizeof(std::uint32_t) +
           rotation.capacity() * sizeof(Eigen::Matrix3f) + centre.capacity() * sizeof(Vec3f) +
           attribute_streams.capacity() * sizeof(attribute_streams[0]);
  }
};

// The most points a version 2 code-book payload may hold per byte: a range-coded position
// costs more than 1/8 of a bit (its 15 binary decisions each cost at least 0.011 bits), so an
// honest writer never comes near; a reader refuses more before it allocates.
inline constexpr std::size_t kMaxPointsPerByte = 64;

// Bytes one code-word point takes in a version 1 payload, given the header's flags.
std::size_t bytes_per_codeword_point(const ContainerHeader& header);

// Whether `points` code-word points can fit in a code-book payload of `raw_size` bytes (the
// bound a reader checks before it allocates anything for them).
bool codeword_points_fit(const ContainerHeader& header, std::uint64_t points, std::uint64_t raw_size);

std::string encode_codeword_block(std::span<const Codeword> codewords,
                                  const ContainerHeader& header);
// Version 5's writer: moves each lowest height of a cell one grid step nearer the columns'
// prediction where the bits saved are worth the error added (column_coder.hpp, HeightChoice),
// judged on the code word alone with fresh models, so that its points, and not the blocks they
// land in, decide (the decoded model does not depend on block sizes or on trimming). Nothing
// for earlier versions.
void choose_codeword_heights(Codeword& codeword, const ContainerHeader& header);
// Fails (kInvalidArgument) when a translation falls off the i32 grid of |v| < 2^24.
StatusOr<std::string> encode_patch_block(std::span<const PatchInstance> patches,
                                         const ContainerHeader& header);

// Decode `raw` for the block `entry` describes. Errors are kCorrupt with the payload offset;
// the caller adds which block of which section.
Status decode_codeword_block(std::span<const std::byte> raw, const BlockEntry& entry,
                             const ContainerHeader& header, DecodedCodewords& out);
// `check_box`: refuse centres outside entry.box (the reader); the writer, which is computing
// the box, passes false.
Status decode_patch_block(std::span<const std::byte> raw, const BlockEntry& entry,
                          const ContainerHeader& header, bool check_box, DecodedPatches& out);

}  // namespace sspc::codec
