// The oracle every point-cloud reader target applies: an error has a message; a success is a
// valid, non-empty cloud that survives a binary PLY round trip bit for bit (so nothing a reader
// accepts can break the writer or the other reader). Reading with warnings and the positions
// in double asked for (what the CLI and sspc eval do) accepts and refuses the same bytes and
// gives the same cloud, with one double position per point and at most one warning.
#pragma once

#include <cstring>
#include <string>
#include <vector>

#include "fuzz_util.hpp"
#include "io/reader_common.hpp"
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
  SSPC_FUZZ_CHECK(again->colours == cloud.colours);
}

// `read` is one of io::read_*_with_options; `plain` what the same reader gave without options.
template <typename Read>
void check_read_with_options(Read read, std::span<const std::byte> bytes,
                             const StatusOr<PointCloud>& plain) {
  const auto same_cloud = [&](const StatusOr<PointCloud>& other) {
    SSPC_FUZZ_CHECK(other.ok() == plain.ok());
    if (!plain.ok()) return;
    // Bitwise: a -0.0 read as 0.0 is a different cloud.
    SSPC_FUZZ_CHECK(other->positions.size() == plain->positions.size());
    SSPC_FUZZ_CHECK(std::memcmp(other->positions.data(), plain->positions.data(),
                                plain->positions.size() * sizeof(Vec3f)) == 0);
    SSPC_FUZZ_CHECK(other->normals == plain->normals);
    SSPC_FUZZ_CHECK(other->colours == plain->colours);
  };
  std::vector<std::string> warnings;
  ReadOptions options;
  options.warnings = &warnings;
  same_cloud(read(bytes, "<fuzz>", options));
  SSPC_FUZZ_CHECK(warnings.size() <= 1);

  std::vector<Vec3d> wide;
  options.positions_f64 = &wide;
  warnings.clear();
  same_cloud(read(bytes, "<fuzz>", options));
  SSPC_FUZZ_CHECK(warnings.empty());
  if (!plain.ok()) return;  // read_point_cloud empties `wide` then; the readers need not
  SSPC_FUZZ_CHECK(wide.size() == plain->size());
  for (const Vec3d& p : wide) SSPC_FUZZ_CHECK(p.allFinite());
}

}  // namespace sspc::fuzz
