// Random access to a compressed model: an .sspc file (docs/FORMAT.md) opened for decoding.
//
// A CompressedModel answers for one patch, one code word, one box or the whole model without
// reading more of the file than the answer needs: the file is memory-mapped, its blocks are
// decoded on demand and kept in a small cache, and a patch's region test reads only the patch
// blocks near it. This is the API the renderer uses too.
//
// Safe on untrusted files: every byte is checked (CRCs before decompressing, sizes and counts
// bounded by the file), and a corrupt file gives a kCorrupt Status naming the section, block and
// byte offset, never a crash. Thread-safe: all const members may be called from many threads at
// once.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "sspc/point_cloud.hpp"
#include "sspc/progress.hpp"
#include "sspc/status.hpp"

namespace sspc {

struct DecodeOptions {
  // false: each patch keeps only the code-word points of its own region (the Voronoi cell of its
  // centre), so the decoded count is close to the source's. true: every stored point of every
  // instance (whole spheres when the file was written with --full-spheres).
  bool overlap = false;
  Progress* progress = nullptr;
  // When not null, replaced by the patch of each decoded point, index for index with the
  // returned cloud (what a renderer needs to colour points by code word, and what a user needs
  // to tell instances apart).
  std::vector<std::uint32_t>* patch_of = nullptr;
  // Resampling (docs/FORMAT.md, "Resampling"): each point replaced by m × m points on its code
  // word's local surface. -1: the m the header asks for (ModelInfo::resample; 0 where it asks
  // for none); 0: the points as stored; 1-4: that m, whatever the header asks. Ignored with
  // `overlap`.
  int resample = -1;
};

// Patch k as stored: its code word and the transform world_from_codeword (x ↦ R x + t); t is
// the patch's region centre.
struct PatchRecord {
  std::uint32_t codeword = 0;
  Eigen::Matrix3f rotation = Eigen::Matrix3f::Identity();
  Vec3f translation = Vec3f::Zero();
};

// One code word, decoded, in its own frame (origin = the representative patch's centre).
struct CodewordData {
  PointCloud points;  // normals and colours when the model has them
  float radius = 0;   // largest distance of a point from the origin: the instances' bounding sphere
};

struct SectionInfo {
  std::string name;
  std::uint64_t offset = 0;
  std::uint64_t bytes = 0;
  std::uint64_t raw_bytes = 0;  // block sections: before zstd; seek tables: = bytes
  std::uint64_t blocks = 0;
};

struct ModelInfo {
  int version = 0;
  bool has_normals = false;
  bool has_colours = false;  // per code word or per point (the attributes part)
  // Per-point attributes coded per patch (docs/FORMAT.md, "Attributes"): kAttribute* bits of
  // sspc/encoder.hpp, their steps (0 when absent), and the part's size.
  unsigned attributes = 0;
  int colour_step = 0;
  int intensity_step = 0;
  std::uint64_t attribute_bytes = 0;
  float patch_radius = 0;
  float coverage_radius = 0;
  float spacing = 0;
  float codeword_radius = 0;
  Box3f bounds;
  std::uint64_t source_points = 0;
  int position_bits = 0;
  int normal_bits = 0;
  int rotation_bits = 0;
  float translation_step = 0;
  // Points a decoded point stands for, per side: resample² points on its code word's local
  // surface (DecodeOptions::resample); 0 when the model is decoded as stored.
  int resample = 0;
  std::uint64_t patches = 0;
  std::uint64_t codewords = 0;
  std::uint64_t codeword_points = 0;  // Σ code-word sizes
  std::uint64_t overlap_points = 0;   // points of an overlap-mode decode: Σ over patches
  std::uint32_t patches_per_block = 0;
  std::uint32_t codewords_per_block = 0;
  std::uint64_t file_bytes = 0;
  std::uint64_t header_bytes = 0;
  SectionInfo sections[4];
  double codebook_ratio = 0;  // patches / code words
  double bits_per_point = 0;  // file bytes × 8 / source points
};

class CompressedModel {
 public:
  CompressedModel(CompressedModel&&) noexcept;
  CompressedModel& operator=(CompressedModel&&) noexcept;
  ~CompressedModel();

  // Maps the file and checks its header and seek tables (not the blocks: see verify()).
  static StatusOr<CompressedModel> open(const std::filesystem::path& path);
  // The same over bytes in memory, which the model keeps.
  static StatusOr<CompressedModel> from_bytes(std::string bytes);

  std::size_t patch_count() const;
  std::size_t codeword_count() const;

  StatusOr<PatchRecord> patch(std::size_t k) const;
  StatusOr<CodewordData> codeword(std::size_t c) const;

  // Where the model lies: a point in the world is origin() + its decoded position (in double).
  // Every position the model answers with (patches, boxes, bounds) is local to it; decoded
  // clouds carry it as PointCloud::origin. metadata(): the source's comments, CRS and LAS grid.
  Vec3d origin() const;
  const CloudMetadata& metadata() const;

  // Patch k's points in the world: exactly its part of decode_all(), in the same order.
  StatusOr<PointCloud> decode_patch(std::size_t k, const DecodeOptions& options = {}) const;
  // Exactly the points of decode_all() inside `box` (inclusive, local coordinates), in the same
  // order.
  StatusOr<PointCloud> decode_box(const Box3f& box, const DecodeOptions& options = {}) const;
  // The whole model, patches in file order; parallel and deterministic.
  StatusOr<PointCloud> decode_all(const DecodeOptions& options = {}) const;
  // The same points handed to `sink` in chunks of whole patches, about `chunk_points` points
  // each (whole patch blocks: FORMAT.md), in order: joined, the chunks are exactly decode_all()'s
  // cloud, and each carries its origin. Memory stays about one chunk and the code-word blocks
  // its patches use, whatever the model's size (a tiled model's tiles use their own code books).
  // chunk_points = SIZE_MAX gives one chunk, whatever the header says of the source's size. A
  // model without patches gives one empty chunk. options.patch_of, when set, holds each
  // chunk's patches when the sink sees it. Stops at the
  // first error, the sink's included. kInvalidArgument for chunk_points == 0.
  Status decode_chunks(std::size_t chunk_points, const std::function<Status(PointCloud&&)>& sink,
                       const DecodeOptions& options = {}) const;

  // Every checksum (sections and blocks) and a decode of every block; with per-point attributes,
  // a whole decode (their streams are decoded against the geometry).
  Status verify() const;

  ModelInfo info() const;

  // Random queries (decode_patch, decode_box, patch, codeword) keep the blocks they decode in a
  // least-recently-used cache bounded in bytes (kDefaultCacheBudget unless set), shared by the
  // threads querying the model; decode_all and decode_chunks decode their own. A budget of 0
  // keeps only the blocks last used. The cache is not part of the model's value: these may be
  // called on a const model, from any thread, while queries run (a smaller budget evicts at
  // once). cache_peak_bytes(): the most the cache has held since open or the
  // last reset_cache_peak().
  static constexpr std::uint64_t kDefaultCacheBudget = std::uint64_t{64} << 20;
  void set_cache_budget(std::uint64_t bytes) const;
  std::uint64_t cache_budget() const;
  std::uint64_t cache_bytes() const;
  std::uint64_t cache_peak_bytes() const;
  void reset_cache_peak() const;

 private:
  struct Impl;
  explicit CompressedModel(std::unique_ptr<Impl> impl);
  PointCloud placed(PointCloud cloud) const;
  std::unique_ptr<Impl> impl_;
};

}  // namespace sspc
