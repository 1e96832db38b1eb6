// A tiled encode split into jobs that can run anywhere (Dask workers: python/sspc/distributed.py):
// plan on one machine, run each tile's job (its points, a margin of its neighbours' and the
// parameters every tile shares) with run_tile_job, then join the results and write the model.
// The file is byte for byte that of encode() with the same options, whoever ran the jobs and in
// whatever order they finished (src/encoder/tiling.hpp states the tiling rule).
#pragma once

#include <cstddef>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <string_view>

#include "sspc/encoder.hpp"
#include "sspc/point_cloud.hpp"
#include "sspc/status.hpp"

namespace sspc {

class TiledEncoder {
 public:
  // Checks the options and the cloud as encode() does (options.tile_points must be > 0), cuts
  // the cloud into tiles and measures the spacing and patch radius they share. Keeps the cloud.
  static StatusOr<TiledEncoder> plan(PointCloud cloud, const EncodeOptions& options);

  TiledEncoder(TiledEncoder&&) noexcept;
  TiledEncoder& operator=(TiledEncoder&&) noexcept;
  ~TiledEncoder();

  std::size_t tile_count() const;
  int level() const;
  std::size_t tile_points(std::size_t t) const;  // the tile's own points (its job carries more)
  // Tile t's job, self-contained bytes for run_tile_job (on this machine or another running the
  // same sspc).
  std::string job(std::size_t t) const;
  // Joins the jobs' results, given in tile order, and writes the model atomically. Fails
  // (kInvalidArgument) when a result is missing or is not a result of this sspc.
  StatusOr<EncodeStats> write(const std::filesystem::path& output, std::span<const std::string> results);

 private:
  struct Impl;
  explicit TiledEncoder(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// Runs one tile's job: normals where its points have none, patch centres over the tile's own
// points, the code book over the tile and its margin. Returns the tile's model as bytes for
// TiledEncoder::write. Deterministic: the same job gives the same bytes anywhere.
StatusOr<std::string> run_tile_job(std::string_view job);

}  // namespace sspc
