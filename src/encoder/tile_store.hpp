// Where a tiled encode's points wait between the plan and the tiles' jobs (encoder/tiling.hpp):
// a cloud in memory, or an input file read in passes and spilled to one file per tile, so that
// the encode holds one tile (and its margin) at a time whatever the input's size.
//
// Both give a tile's points in the same order (the tile's own in input order, then each other
// tile's within reach of its box, tiles in order, each in input order), so an encode planned
// from a file gives the bytes of one planned from the same cloud in memory.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <string>

#include "encoder/tiling.hpp"
#include "sspc/io.hpp"
#include "sspc/point_cloud.hpp"
#include "sspc/status.hpp"

namespace sspc::codec {

// What a pass over the input learns of it.
struct TileInput {
  std::uint64_t points = 0;
  Box3f bounds;
  bool has_normals = false;
  std::uint8_t channels = 0;  // the attribute channels kept (attribute_coder.hpp's bits)
  Vec3d origin = Vec3d::Zero();
  CloudMetadata metadata;
  // The fields the input has that the encode does not keep (drop_unkept_attributes' names).
  std::string dropped;
};

class TileStore {
 public:
  virtual ~TileStore() = default;
  const TilePlan& plan() const { return plan_; }
  const TileInput& input() const { return input_; }
  // Tile t's own points, then the other tiles' within `reach` of its box (Box3f::contains on
  // the box grown by `reach`; none when `reach` < 0): positions, normals when the input has
  // them, and the channels kept.
  virtual StatusOr<PointCloud> load(std::size_t t, float reach) const = 0;

  // The cloud kept in memory; `channels` are the attribute channels wanted (those it has are kept).
  static std::unique_ptr<TileStore> in_memory(PointCloud cloud, std::uint64_t tile_points, std::uint8_t channels);
  // `input` read in three passes of `chunk_points` points (bounds, counts, spill), never held
  // whole; the tiles' files go to a hidden folder in `work_dir` that the store removes (also on
  // SIGINT/SIGTERM when the program installed remove_temporary_files_on_signals()). The tiles hold
  // at most `size.points` points, or what `size.memory_limit` allows for the input's count
  // (tile_points_for_memory, known after the first pass); under a limit the spill's buffers share
  // a sixteenth of it.
  struct TileSize {
    std::uint64_t points = 0;
    std::uint64_t memory_limit = 0;
  };
  // Several files are read one after another as one cloud, about one origin (FileSetOrigin in
  // sspc/io.hpp), with the per-point arrays every file has: the points of read_point_clouds.
  static StatusOr<std::unique_ptr<TileStore>> spilled(std::span<const std::filesystem::path> inputs, const ReadOptions& read,
                                                      TileSize size, std::uint8_t channels,
                                                      const std::filesystem::path& work_dir,
                                                      std::size_t chunk_points = std::size_t{1} << 20);

 protected:
  TilePlan plan_;
  TileInput input_;
};

}  // namespace sspc::codec
