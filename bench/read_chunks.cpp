// read_chunks PATH [CHUNK_POINTS | whole]: reads a point cloud with read_point_cloud_chunks
// (chunks of CHUNK_POINTS, default 1,000,000) or, given "whole", with read_point_cloud, and prints
// one JSON object: points, chunks, seconds, points per second and the peak resident memory. For
// checking that a chunked read of a file larger than memory stays within its chunks' memory
// (scripts/bench_read_chunks.sh); not part of the installed tool.
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "sspc/io.hpp"

namespace {

// ru_maxrss is in kibibytes on Linux.
double peak_rss_mib() {
  struct rusage usage {};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: read_chunks PATH [CHUNK_POINTS | whole]\n");
    return 2;
  }
  const std::string mode = argc > 2 ? argv[2] : "1000000";
  const bool whole = mode == "whole";
  const std::size_t chunk_points = whole ? 0 : std::strtoull(mode.c_str(), nullptr, 10);
  if (!whole && chunk_points == 0) {
    std::fprintf(stderr, "read_chunks: CHUNK_POINTS must be a positive integer or \"whole\"\n");
    return 2;
  }
  const auto start = std::chrono::steady_clock::now();
  std::size_t points = 0, chunks = 0;
  sspc::Status status;
  if (whole) {
    sspc::StatusOr<sspc::PointCloud> cloud = sspc::read_point_cloud(argv[1]);
    status = cloud.status();
    if (cloud.ok()) points = cloud->size(), chunks = 1;
  } else {
    status = sspc::read_point_cloud_chunks(argv[1], chunk_points, [&](sspc::PointCloud&& chunk) {
      points += chunk.size();
      ++chunks;
      return sspc::Status();
    });
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (!status.ok()) {
    std::fprintf(stderr, "read_chunks: %s\n", status.to_string().c_str());
    return 1;
  }
  std::printf(
      "{\"path\": \"%s\", \"mode\": \"%s\", \"points\": %zu, \"chunks\": %zu, \"seconds\": %.3f, "
      "\"points_per_second\": %.4g, \"peak_rss_mib\": %.1f}\n",
      argv[1], mode.c_str(), points, chunks, seconds, static_cast<double>(points) / seconds,
      peak_rss_mib());
  return 0;
}
