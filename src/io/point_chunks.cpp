#include "io/point_chunks.hpp"

#include <algorithm>
#include <string>
#include <utility>

#include "core/check.hpp"

namespace sspc::io {

namespace {

// For a handler that did not take the chunk (a first pass): the next one reuses its memory
// instead of faulting in new pages.
void empty_keeping_capacity(PointCloud& cloud) {
  const auto empty = [](auto&... arrays) { (arrays.clear(), ...); };
  LasPointAttributes& a = cloud.las;
  empty(cloud.positions, cloud.normals, cloud.colours, a.intensity, a.return_number,
        a.number_of_returns, a.classification, a.classification_flags, a.scan_angle, a.scan_flags,
        a.user_data, a.point_source_id, a.gps_time, a.rgb, a.nir, a.extra_bytes);
  a.extra_bytes_per_point = 0;
  cloud.origin = Vec3d::Zero();
  cloud.metadata = CloudMetadata();
}

}  // namespace

StatusOr<std::size_t> read_in_chunks(PointReader& reader, const MappedFile& file,
                                     std::size_t chunk_points, const ChunkHandler& handle) {
  SSPC_DCHECK(chunk_points > 0);
  std::size_t total = 0;
  std::size_t released = 0;
  PointCloud chunk;
  while (!reader.done()) {
    SSPC_RETURN_IF_ERROR(reader.read(chunk_points - chunk.size(), chunk));
    if (chunk.size() == chunk_points || (reader.done() && !chunk.empty())) {
      // A file that shrank was read partly as zeros (core/mapped_file.hpp): none of them leave.
      SSPC_RETURN_IF_ERROR(file.check_intact());
      const std::size_t n = chunk.size();
      SSPC_RETURN_IF_ERROR(handle(chunk, total));
      total += n;
      empty_keeping_capacity(chunk);
    }
    // After the handler, which may look at the chunk's bytes again (the LAS first pass does).
    const std::size_t consumed = reader.consumed();
    if (consumed > released) {
      file.release(released, consumed);
      released = consumed;
    }
  }
  return total;
}

StatusOr<std::size_t> run_pass(const ChunkedRead& in, Pass pass, PointReader& reader,
                               const ChunkHandler& handle) {
  const std::string stage = pass == Pass::kScan ? "scanning " : "reading ";
  progress_begin(in.options.progress, stage + in.file.path().filename().string(), in.file.size(),
                 "bytes");
  StatusOr<std::size_t> points = read_in_chunks(reader, in.file, in.chunk_points, handle);
  progress_end(in.options.progress);
  return points;
}


Status hand_out_in_chunks(PointCloud cloud, std::size_t chunk_points,
                          const std::function<Status(PointCloud&&)>& sink) {
  SSPC_DCHECK(chunk_points > 0);
  if (cloud.size() <= chunk_points) return sink(std::move(cloud));
  for (std::size_t b = 0; b < cloud.size(); b += chunk_points) {
    SSPC_RETURN_IF_ERROR(sink(cloud.slice(b, std::min(cloud.size(), b + chunk_points))));
  }
  return Status();
}

}  // namespace sspc::io
