// Compressing a point cloud into an .sspc file (Hubo et al. 2007, §4; the format in docs/FORMAT.md).
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <optional>
#include <string>

#include "sspc/io.hpp"
#include "sspc/normals.hpp"
#include "sspc/point_cloud.hpp"
#include "sspc/progress.hpp"
#include "sspc/status.hpp"

namespace sspc {

// Per-point attributes the encoder can keep, each coded per patch against the decoded geometry
// (docs/FORMAT.md, "Attributes"): bits of EncodeOptions::attributes.
inline constexpr unsigned kAttributeColour = 1u << 0;          // PointCloud::colours
inline constexpr unsigned kAttributeIntensity = 1u << 1;       // las.intensity
inline constexpr unsigned kAttributeClassification = 1u << 2;  // las.classification, lossless
inline constexpr unsigned kAttributeReturns = 1u << 3;  // las.return_number and number_of_returns, lossless
inline constexpr unsigned kAllAttributes = 0xF;

// The most points a patch may be asked to hold (EncodeOptions::patch_points): what the level
// table gives the coarsest levels of the largest models (docs/FORMAT_NOTES.md, "Level table").
inline constexpr int kMaxPatchPoints = 131072;

// The colour quantisation step for a colour quality 0..100: 2^((100 − quality) · 6 / 100)
// rounded, so 100 is lossless, every ~17 points halve the step (about 6 dB of colour PSNR) and
// 0 gives a step of 64.
int colour_step_for_quality(int quality);

struct EncodeOptions {
  int level = 5;  // 0 (most detail) .. 9 (smallest); one row of docs/FORMAT.md's level table
  // Expert overrides of single fields of the level's row.
  std::optional<int> patch_points;  // expected points per patch, 8..kMaxPatchPoints
  std::optional<float> epsilon;     // descriptor L1 radius, > 0
  std::optional<float> tau;         // MLS error threshold in point spacings, > 0
  std::optional<int> position_bits; // code-word coordinate bits, 4..16 (instead of the level's step)
  std::optional<float> step;        // code-word grid step in point spacings, > 0 (the level's otherwise)
  // Store the code words' normals (10-bit octahedral; about 12–16 more bits per code-word
  // point after zstd). Off by default: the rate a point-cloud codec is compared by counts
  // positions only, and decoders and the renderer can estimate normals from the points.
  bool store_normals = false;
  // Keep each code word's whole sphere of radius R, as the paper does. By default the writer
  // drops the points no instance's region claims: the decoded model is the same, the code book
  // about half the size, and only `decode --overlap` sees fewer points.
  bool full_spheres = false;
  // Store every input point, also several in one cell of the code words' grid. By default a
  // cell keeps one point (G-PCC's merged duplicates): they decode to one position, so the
  // paper's PSNR barely moves (≤ 0.06 dB) while coarse levels lose 20–30% of their points.
  bool keep_duplicates = false;
  // Whether the decoder resamples each decoded point on its code word's surface, m × m points
  // for one (docs/FORMAT.md, "Resampling"): -1 lets the writer choose, by measuring which m
  // decodes closest to the source around a sample of patches (0 at the fine levels, where it
  // never pays), 0 never, 1-4 that m. A decoder may still ask for another (DecodeOptions).
  int resample = -1;
  // The attributes to keep, of those the cloud has (kAttribute* bits); the others are dropped.
  unsigned attributes = kAllAttributes;
  int colour_quality = 70;   // 0..100 (100: lossless); see colour_step_for_quality
  int intensity_step = 1;    // 1..4096 (1: lossless)
  // Encode in tiles of at most this many points (0: the whole cloud at once): octree cells,
  // each built with a margin of its neighbours' points and joined into one model
  // (src/encoder/tiling.hpp). Normals are estimated per tile.
  std::uint64_t tile_points = 0;
  // encode_file: bytes the encode may hold (0: no limit). The input is then read in passes and
  // never held whole, and encoded in tiles of the size the limit allows (tile_points, when set,
  // instead); the tiles wait in files beside the output (docs/ARCHITECTURE.md, "Scale").
  std::uint64_t memory_limit = 0;
  NormalOptions normals;            // how the input gets its normals (default: auto)
  std::uint64_t seed = 1;
  Progress* progress = nullptr;
};

struct EncodeStats {
  std::uint64_t points = 0;
  std::uint64_t patches = 0;
  std::uint64_t codewords = 0;
  double codebook_ratio = 0;  // patches / code words
  std::uint64_t codeword_points = 0;          // stored (after trimming)
  std::uint64_t untrimmed_codeword_points = 0;  // Σ of the representatives' sphere sizes
  int position_bits = 0;      // the code words' grid: 2·patch_radius / 2^position_bits
  double position_step = 0;
  int resample = 0;  // points a decoded point stands for, per side (EncodeOptions::resample)
  double spacing = 0;
  double patch_radius = 0;
  double coverage_radius = 0;
  double max_coverage_distance = 0;  // largest point-to-centre distance (≤ coverage_radius)
  std::uint64_t candidates_tested = 0;
  std::uint64_t file_bytes = 0;
  std::uint64_t codebook_bytes = 0;
  std::uint64_t patch_bytes = 0;
  std::uint64_t attribute_bytes = 0;  // the attributes part, with its tables
  // Of which each channel's streams: colour, intensity, classification, returns.
  std::uint64_t colour_bytes = 0;
  std::uint64_t intensity_bytes = 0;
  std::uint64_t classification_bytes = 0;
  std::uint64_t returns_bytes = 0;
  std::uint64_t tiles = 0;  // tiles of a tiled encode (0: untiled)
  unsigned attributes = 0;  // the kAttribute* bits kept
  int colour_step = 0;      // when colours are kept
  double bits_per_point = 0;
  double seconds_normals = 0;
  double seconds_centres = 0;
  double seconds_codebook = 0;     // descriptors and clustering
  double seconds_descriptors = 0;  // ... of which gathering patches and their descriptors
  double seconds_writing = 0;
};

// Keeps in `cloud` the attributes `keep` (kAttribute* bits) names and returns the names of the
// fields it drops ("GPS time, user data"; "RGB's low 8 bits" when LAS's 16-bit colours had
// them), so that a caller can say what is not kept: nothing is lost silently.
std::string drop_unkept_attributes(PointCloud& cloud, unsigned keep);

// Encodes `cloud` (normals are estimated when it has none, per options.normals) and writes
// `output` atomically. Errors: kInvalidArgument for out-of-range options or a cloud of fewer
// than 16 points; I/O errors from writing.
StatusOr<EncodeStats> encode(PointCloud cloud, const std::filesystem::path& output,
                             const EncodeOptions& options = {});

// Encodes the file `input` (read as `read` says). With options.memory_limit the cloud is never
// held whole (TiledEncoder::plan_file: three passes over the input, one file per tile in a
// hidden folder beside `output`, removed at the end); otherwise read_point_cloud, then encode().
StatusOr<EncodeStats> encode_file(const std::filesystem::path& input, const std::filesystem::path& output,
                                  const EncodeOptions& options = {}, const ReadOptions& read = {});
// Several files as one cloud (a survey's tiles in one CRS; sspc/io.hpp's read_point_clouds):
// the same model as encode_file of one file holding their points in the order given, read in
// passes under options.memory_limit.
StatusOr<EncodeStats> encode_files(std::span<const std::filesystem::path> inputs, const std::filesystem::path& output,
                                   const EncodeOptions& options = {}, const ReadOptions& read = {});

}  // namespace sspc
