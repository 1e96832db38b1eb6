// A tiled encode split into jobs that can run anywhere (Dask workers: python/sspc/distributed.py):
// plan on one machine, run each tile's job (its points, a margin of its neighbours' and the
// parameters every tile shares) with run_tile_job, then add the results and finish the model.
// The file is byte for byte that of encode() with the same options, whoever ran the jobs and in
// whatever order they finished (src/encoder/tiling.hpp states the tiling rule).
//
// Memory: plan() keeps the cloud; plan_file() reads the input in passes and keeps it in one file
// per tile beside the output, so the encoder holds one tile's job and result at a time, the
// patches (about 60 bytes each) and the plan's grid (about 40 MB), whatever the input's size.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <string_view>

#include "sspc/encoder.hpp"
#include "sspc/io.hpp"
#include "sspc/point_cloud.hpp"
#include "sspc/status.hpp"

namespace sspc {

class TiledEncoder {
 public:
  // Checks the options and the cloud as encode() does (options.tile_points must be > 0), cuts
  // the cloud into tiles and measures the spacing and patch radius they share. Keeps the cloud.
  static StatusOr<TiledEncoder> plan(PointCloud cloud, const EncodeOptions& options);
  // The same from a file read in chunks (three passes: bounds, the tiles' counts, the tiles'
  // files, written into a hidden folder in `work_dir` and removed with the encoder). The tile
  // size is options.tile_points, else the one options.memory_limit allows
  // (tile_points_for_memory). The same bytes as plan(read_point_cloud(input)).
  static StatusOr<TiledEncoder> plan_file(const std::filesystem::path& input, const EncodeOptions& options,
                                          const ReadOptions& read = {}, const std::filesystem::path& work_dir = ".");
  // Several files as one cloud, read in the same passes one after another (TileStore::spilled):
  // the bytes of plan(read_point_clouds(inputs)).
  static StatusOr<TiledEncoder> plan_files(std::span<const std::filesystem::path> inputs, const EncodeOptions& options,
                                           const ReadOptions& read = {}, const std::filesystem::path& work_dir = ".");

  TiledEncoder(TiledEncoder&&) noexcept;
  TiledEncoder& operator=(TiledEncoder&&) noexcept;
  ~TiledEncoder();

  std::size_t tile_count() const;
  int level() const;
  std::uint64_t points() const;               // the whole cloud's
  std::size_t tile_points(std::size_t t) const;  // the tile's own points (its job carries more)
  // plan_file: the fields of the input that are not kept (drop_unkept_attributes' names).
  const std::string& dropped_fields() const;
  // Tile t's job, self-contained bytes for run_tile_job (on this machine or another running the
  // same sspc). Fails only when a tile's file cannot be read back.
  StatusOr<std::string> job(std::size_t t) const;
  // The same bytes written to a file (for workers that share storage with this machine: the job
  // travels as a path, not through a scheduler), atomically.
  Status write_job(std::size_t t, const std::filesystem::path& path) const;

  // Writing: begin(), then each tile's result in any order (a result is held until every tile
  // before it is written), then finish(). A result that is not of this sspc, or of a tile given
  // twice, is kInvalidArgument; finish() before every tile's result is too. A tile's code book
  // is trimmed and written as soon as no tile still to come can reach it, so that finish() is
  // left the last few. begin() after finish() writes the model again.
  Status begin(const std::filesystem::path& output);
  Status add(std::size_t t, std::string result);
  // A result that run_tile_job_file wrote: read when its turn comes, then removed.
  Status add_file(std::size_t t, const std::filesystem::path& result);
  StatusOr<EncodeStats> finish();
  // All three at once, the results in tile order.
  StatusOr<EncodeStats> write(const std::filesystem::path& output, std::span<const std::string> results);
  // Every job run here, one after the other (each on all threads), and the model written.
  StatusOr<EncodeStats> run(const std::filesystem::path& output, Progress* progress = nullptr);

 private:
  struct Impl;
  explicit TiledEncoder(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// The tile size a memory limit allows for a cloud of `points` points: what a tile's encode holds
// per point (its job, margin, normals, search tree, patches and code book: see tiled_encoder.cpp)
// into the limit less a fixed part for the plan and the read, and less what the writer holds for
// the whole model (its patch records, about 0.22 bytes a point). kInvalidArgument, naming the
// least limit, when that leaves no room for a tile of 65,536 points.
StatusOr<std::uint64_t> tile_points_for_memory(std::uint64_t memory_limit_bytes, std::uint64_t points);

// Runs one tile's job: normals where its points have none, patch centres over the tile's own
// points, the code book over the tile and its margin. Returns the tile's model as bytes for
// TiledEncoder::add. Deterministic: the same job gives the same bytes anywhere.
StatusOr<std::string> run_tile_job(std::string_view job);
// The same from a job file (TiledEncoder::write_job) to a result file (for
// TiledEncoder::add_file), written atomically. Through files the bytes are copied once each way,
// where a scheduler copies them several times: on autzen's 16 tiles of 1M points (a result about
// 49 MB) a local Dask client's CPU time fell from 38-44 s to 34 s, most of it system time.
Status run_tile_job_file(const std::filesystem::path& job, const std::filesystem::path& result);

}  // namespace sspc
