// Writes an EncodedModel as an .sspc container (docs/FORMAT.md): quantises the code book and the
// patch transforms, cuts them into independently decodable blocks, compresses each with zstd and
// writes the seek tables that make random access possible.
//
// The output is deterministic: the same model and options give the same bytes on any machine and
// any thread count (blocks are compressed in parallel but each on its own and in a fixed place).
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>

#include "format/attribute_coder.hpp"
#include "format/container_format.hpp"
#include "format/encoded_model.hpp"
#include "sspc/status.hpp"

namespace sspc::codec {

// The container's knobs; the encoder's level table fills them. FORMAT.md says why the defaults
// are what they are.
struct QuantOptions {
  int position_bits = 12;      // code-word coordinates; step = 2·patch_radius / 2^bits
  // When positive, the code words' grid step instead: the writer takes the fewest position bits
  // whose grid spans the code words and stores a patch_radius enlarged to step·2^(bits−1), so
  // that the step is exactly this one (a power-of-two grid would move it by up to √2).
  float position_step = 0;
  int normal_bits = 10;        // per octahedral component
  int rotation_bits = 13;      // per smallest-three component: error < the position step
  float translation_step = 0;  // 0: spacing / 64 (patch_radius / 256 when spacing is 0)
  std::uint32_t patches_per_block = 64;   // bench/decode_bench: see FORMAT.md
  std::uint32_t codewords_per_block = 32;
  int zstd_level = 19;
  // Drop the code-word points no instance's region claims (encoder/codeword_trim.hpp): the
  // default decode is unchanged, the overlap decode no longer sees whole spheres.
  bool trim_unclaimed = false;
  // Store every point of a code word, also several in one grid cell (header flag bit 3);
  // otherwise a cell keeps one (merge_duplicate_cells in encoder/codeword_trim.hpp).
  bool keep_duplicates = false;
  // The format version to write: 5, or 4 (the heights predicted at the cells' corners, without
  // the encoder's choice of heights, block_codec.cpp), 3 (the columns without version 4's
  // plane-reach contexts) or 2 (whose code words store duplicates as they are), for comparisons
  // and the golden files.
  int format_version = kFormatVersion;
  // The header's resample byte (FORMAT.md, "Resampling"): 0 to 4, or -1 to choose by
  // resample_for() once the code words are known. Version 4 and later.
  int resample = -1;
  // Per-point attributes coded per patch (FORMAT.md, "Attributes"): when `attributes.channels`
  // is not 0, the values of each decoded point are those of its nearest point of
  // `attribute_source` (which must have them, and outlive the call). Needs format version 3 or
  // later and a model without code-word colours.
  AttributeParams attributes;
  const PointCloud* attribute_source = nullptr;
};

// The resampling a model of `source_points` decoding to about `decoded_points` on a grid of
// `step_in_spacings` source spacings asks for: none while the decode holds two thirds of the
// source's points or more, or while the grid is no coarser than the spacing (then the points
// lost are duplicates, which resampling would not bring back); otherwise enough points a decoded
// point to reach the source's count, ceil(sqrt(source / decoded)), at most 4. (The
// prototype's measurements, docs/FORMAT_NOTES.md "Resampling": dragon_scans at level 7, whose
// decode holds 73%, lost 0.2 dB; bunny and igea at 56-58% gained 2.6-2.9 dB.)
int resample_for(std::uint64_t source_points, double decoded_points, double step_in_spacings);

// Where the writer has the source (a TileSource for finish(), QuantOptions::attribute_source for
// encode_container and write_container) and the grid is coarser than this many spacings, it
// measures instead which m decodes closest to the source (resample_choice.hpp), of 0, 1 and up
// to resample_for's m, at kResampleSamples patch centres. On finer grids resampling pays too
// little for what it costs the decoder (a k-d tree search and two small solves a point): at
// level 5 (0.85 spacings) projection gained 0.15-0.22 dB on igea and bunny, lost 0.28 dB on
// dragon_scans, and made igea's whole decode 4.6 times slower (0.058 -> 0.267 s with writing);
// at level 3 it changed the PSNR by -0.04 to +0.001 dB.
inline constexpr double kMeasuredResampleStep = 1.0;
inline constexpr std::size_t kResampleSamples = 32;

// Bytes per part of the written file.
struct ContainerStats {
  std::uint64_t file_bytes = 0;
  std::uint64_t header_bytes = 0;
  std::uint64_t codebook_bytes = 0;  // code-book blocks as stored
  std::uint64_t codebook_seek_bytes = 0;
  std::uint64_t patch_bytes = 0;  // patch blocks as stored
  std::uint64_t patch_seek_bytes = 0;
  std::uint64_t codebook_raw_bytes = 0;  // before zstd
  std::uint64_t patch_raw_bytes = 0;
  std::uint32_t codebook_blocks = 0;
  std::uint32_t patch_blocks = 0;
  std::uint64_t codeword_points = 0;            // stored
  std::uint64_t untrimmed_codeword_points = 0;  // before trim_unclaimed (0 when off)
  int resample = 0;  // the header's resample byte
  std::uint64_t attribute_bytes = 0;  // the whole attributes part
  // Its streams by channel bit (colour, intensity, classification, returns), without their
  // sizes and the seek table.
  std::array<std::uint64_t, kChannelCount> channel_bytes{};
};

// A container written as its model comes, tile by tile (a tiled encode, encoder/tiling.hpp). A
// code word is trimmed against every patch near its instances, so a tile's code book waits (in a
// file beside the output, or in memory) until all patches are known; finish() then trims and
// writes the code books one tile at a time, then the patch blocks, attributes, metadata and the
// header. The writer holds one tile's code book, the patches (about 60 bytes each) and the seek
// tables, never the whole model. One tile holding the whole model writes exactly what
// encode_container writes (it is how encode_container writes).
class ContainerStreamWriter {
 public:
  // Tile t's source of attributes (FORMAT.md, "Attributes"): points with the channels
  // options.attributes names, holding the nearest source point of every point the tile's patches
  // decode to (its own points and a margin). Asked once per tile that has patches, in order.
  using TileSource = std::function<Status(std::size_t tile, std::shared_ptr<const PointCloud>& out)>;

  // `model` gives what every tile shares: patch_radius, coverage_radius, spacing, source_points,
  // bounds, has_normals, has_colours, metadata (its code book and patches are not read).
  // to_file writes a temporary file beside `path`, renamed over it by a successful finish();
  // with `spill` the tiles' code books wait in a file beside it too, else in memory.
  static StatusOr<ContainerStreamWriter> to_file(const EncodedModel& model, const QuantOptions& options,
                                                 const std::filesystem::path& path, bool spill = false);
  static StatusOr<ContainerStreamWriter> to_memory(const EncodedModel& model, const QuantOptions& options);

  ContainerStreamWriter(ContainerStreamWriter&&) noexcept;
  ContainerStreamWriter& operator=(ContainerStreamWriter&&) noexcept;
  ~ContainerStreamWriter();

  // A tile's code book and the patches that use it, code-word indices local to the tile (the
  // model-wide fields of `tile` are ignored). Tiles are numbered in the order they are added.
  Status add_tile(EncodedModel tile);
  // The boxes that hold each tile's patch centres, in the order the tiles will be added, when
  // known in advance (a tiled encode's plan): a tile's code book is then trimmed and written as
  // soon as no tile still to come can hold a patch within its reach, not all at finish(). The
  // same bytes either way.
  void expect_tiles(std::vector<Box3f> boxes);
  // Writes the rest; `attributes` is needed when options.attributes names channels.
  StatusOr<ContainerStats> finish(const TileSource& attributes = {});
  // to_memory: the container's bytes, after finish().
  std::string take_bytes();

 private:
  struct Impl;
  static StatusOr<ContainerStreamWriter> open(const EncodedModel& model, const QuantOptions& options,
                                              const std::filesystem::path* path, bool spill);
  explicit ContainerStreamWriter(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// The container's bytes. Fails with kInvalidArgument for a model that breaks its own invariants
// (a code-word index out of range, attribute arrays of the wrong length, a non-positive radius)
// or options out of range.
StatusOr<std::string> encode_container(const EncodedModel& model, const QuantOptions& options,
                                       ContainerStats* stats = nullptr);

// The same written atomically to `path` (a temporary file renamed over it).
StatusOr<ContainerStats> write_container(EncodedModel model, const QuantOptions& options,
                                         const std::filesystem::path& path);

}  // namespace sspc::codec
