// The .sspc metadata part (docs/FORMAT.md, "Metadata"): the model's origin in the world, the
// source LAS file's grid, its CRS and its comments. Kept apart from the block sections: it is
// read once, at open, and nothing in the codec depends on it.
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "sspc/point_cloud.hpp"
#include "sspc/status.hpp"

namespace sspc::codec {

struct ModelMetadata {
  Vec3d origin = Vec3d::Zero();
  CloudMetadata cloud;  // comments, CRS, LAS grid; extra-bytes records are not stored

  // Whether a file needs the part: an origin, comments, a CRS or a LAS source.
  bool present() const;
  friend bool operator==(const ModelMetadata&, const ModelMetadata&) = default;
};

// The part's bytes: payload size, CRC32, payload.
std::string encode_metadata(const ModelMetadata& metadata);

// Parses the part that fills `bytes` (from the end of section 4 to the end of the file), which
// starts at `file_offset`. kCorrupt naming `name` and the byte for anything FORMAT.md forbids.
StatusOr<ModelMetadata> decode_metadata(std::span<const std::byte> bytes, std::uint64_t file_offset,
                                        const std::string& name);

}  // namespace sspc::codec
