// The oracle every point-cloud reader target applies: an error has a message; a success is a
// valid, non-empty cloud that survives a binary PLY round trip bit for bit (so nothing a reader
// accepts can break the writer or the other reader).
#pragma once

#include "fuzz_util.hpp"
#include "sspc/io.hpp"

namespace sspc::fuzz {

inline void check_read_result(const StatusOr<PointCloud>& result) {
  if (!result.ok()) {
    SSPC_FUZZ_CHECK(!result.status().message().empty());
    return;
  }
  const PointCloud& cloud = *result;
  SSPC_FUZZ_CHECK_CLOUD(cloud);
  const std::string ply = encode_ply(cloud);
  const StatusOr<PointCloud> again =
      read_ply(std::as_bytes(std::span<const char>(ply.data(), ply.size())), "<round trip>");
  SSPC_FUZZ_CHECK(again.ok());
  SSPC_FUZZ_CHECK(again->positions == cloud.positions);
  SSPC_FUZZ_CHECK(again->normals == cloud.normals);
  SSPC_FUZZ_CHECK(again->colors == cloud.colors);
}

}  // namespace sspc::fuzz
