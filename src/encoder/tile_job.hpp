// The messages of a distributed tiled encode (include/sspc/tiled_encoder.hpp): a tile's job
// (its points and margin, the parameters every tile shares) and its result (the tile's model).
// Byte layouts private to one version of sspc (a job is run by the same build that planned it;
// both start with a magic and a layout number, and a mismatch is refused): little-endian,
// fields in the order the code writes them, a CRC32 of the rest as the last four bytes. A result
// names its tile and the digest of the job it ran, so that the planner refuses a result routed
// to the wrong tile or left from another plan. Parsers treat the bytes as hostile: they check
// the checksum, bound every count by the bytes, and check the content as the writer and a
// decoder would (finite values, rotations orthonormal, parameters in their ranges).
#pragma once

#include <string>
#include <string_view>

#include "encoder/model_builder.hpp"
#include "format/encoded_model.hpp"
#include "sspc/normals.hpp"
#include "sspc/point_cloud.hpp"
#include "sspc/status.hpp"

namespace sspc::codec {

struct TileJob {
  std::uint64_t tile = 0;   // its index in the plan
  PointCloud part;          // the tile's points first, then its margin; normals optional
  BuildOptions build;       // spacing, patch_radius and core_points set
  NormalOptions normals;    // how the part gets normals when it has none
};

std::string serialise_tile_job(const TileJob& job);
StatusOr<TileJob> parse_tile_job(std::string_view bytes);
// What a result quotes of its job: the CRC32 of the job's bytes before its trailer.
std::uint32_t tile_job_digest(std::string_view job);

// A tile's model and what building it cost.
struct TileResult {
  std::uint64_t tile = 0;         // the job's tile
  std::uint32_t job_digest = 0;   // tile_job_digest of the job it ran
  EncodedModel model;
  BuildStats stats;
  // The farthest of the tile's own points from its patches' centres: an upper bound of the
  // distance to the nearest centre of any tile.
  double max_coverage_distance = 0;
};

// The content checks a parsed result passes (finite points and translations within +-1e18,
// rotations orthonormal and proper, radii positive); run_tile_job applies them to the result it
// made too, so that a job whose points make a degenerate model fails with a message.
Status check_tile_result(const TileResult& result);

std::string serialise_tile_result(const TileResult& result);
StatusOr<TileResult> parse_tile_result(std::string_view bytes);

}  // namespace sspc::codec
