// The messages of a distributed tiled encode (include/sspc/tiled_encoder.hpp): a tile's job
// (its points and margin, the parameters every tile shares) and its result (the tile's model).
// Byte layouts private to one version of sspc (a job is run by the same build that planned it;
// both start with a magic and a layout number, and a mismatch is refused): little-endian,
// fields in the order the code writes them. Parsers bounds-check every count against the bytes.
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
  PointCloud part;          // the tile's points first, then its margin; normals optional
  BuildOptions build;       // spacing, patch_radius and core_points set
  NormalOptions normals;    // how the part gets normals when it has none
};

std::string serialise_tile_job(const TileJob& job);
StatusOr<TileJob> parse_tile_job(std::string_view bytes);

// A tile's model and what building it cost.
struct TileResult {
  EncodedModel model;
  BuildStats stats;
  // The farthest of the tile's own points from its patches' centres: an upper bound of the
  // distance to the nearest centre of any tile.
  double max_coverage_distance = 0;
};

std::string serialise_tile_result(const TileResult& result);
StatusOr<TileResult> parse_tile_result(std::string_view bytes);

}  // namespace sspc::codec
