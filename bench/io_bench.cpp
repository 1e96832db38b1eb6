// Point cloud I/O throughput on a real scan: autzen.ply (10.6 M points, binary little-endian
// float x y z, 128 MB) from SSPC_DATA_DIR. The target is at least 300 MB/s for binary PLY.
//
//   ReadPointCloudFile: read_point_cloud() on the path: mmap, header, parallel decode, checks.
//   ReadPlyMapped:      read_ply() on an already-mapped file: the parser alone.
//   ReadPointCloudChunks: read_point_cloud_chunks() on the path, chunks of 1 M points, counted
//                       and dropped.
//   EncodePly:          encode_ply() of the cloud to binary little-endian bytes in memory.
#include <filesystem>
#include <string>

#include <benchmark/benchmark.h>

#include "core/mapped_file.hpp"
#include "sspc/io.hpp"

namespace {

const std::filesystem::path kAutzen = std::filesystem::path(SSPC_DATA_DIR) / "autzen.ply";

bool skip_if_missing(benchmark::State& state) {
  if (std::filesystem::exists(kAutzen)) return false;
  state.SkipWithError(("missing " + kAutzen.string()).c_str());
  return true;
}

void report(benchmark::State& state, std::size_t bytes, std::size_t points) {
  state.SetBytesProcessed(static_cast<std::int64_t>(bytes) * state.iterations());
  state.counters["points/s"] =
      benchmark::Counter(static_cast<double>(points) * static_cast<double>(state.iterations()),
                         benchmark::Counter::kIsRate);
  state.counters["points"] = static_cast<double>(points);
}

void ReadPointCloudFile(benchmark::State& state) {
  if (skip_if_missing(state)) return;
  std::size_t points = 0;
  for (auto _ : state) {
    auto cloud = sspc::read_point_cloud(kAutzen);
    if (!cloud.ok()) {
      state.SkipWithError(cloud.status().to_string().c_str());
      return;
    }
    points = cloud->size();
    benchmark::DoNotOptimize(cloud->positions.data());
  }
  report(state, std::filesystem::file_size(kAutzen), points);
}
BENCHMARK(ReadPointCloudFile)->Unit(benchmark::kMillisecond)->UseRealTime();

void ReadPointCloudChunks(benchmark::State& state) {
  if (skip_if_missing(state)) return;
  std::size_t points = 0;
  for (auto _ : state) {
    points = 0;
    const sspc::Status status =
        sspc::read_point_cloud_chunks(kAutzen, 1000000, [&](sspc::PointCloud&& chunk) {
          points += chunk.size();
          benchmark::DoNotOptimize(chunk.positions.data());
          return sspc::Status();
        });
    if (!status.ok()) {
      state.SkipWithError(status.to_string().c_str());
      return;
    }
  }
  report(state, std::filesystem::file_size(kAutzen), points);
}
BENCHMARK(ReadPointCloudChunks)->Unit(benchmark::kMillisecond)->UseRealTime();

void ReadPlyMapped(benchmark::State& state) {
  if (skip_if_missing(state)) return;
  auto file = sspc::MappedFile::open(kAutzen);
  if (!file.ok()) {
    state.SkipWithError(file.status().to_string().c_str());
    return;
  }
  std::size_t points = 0;
  for (auto _ : state) {
    auto cloud = sspc::read_ply(file->bytes(), "autzen.ply");
    if (!cloud.ok()) {
      state.SkipWithError(cloud.status().to_string().c_str());
      return;
    }
    points = cloud->size();
    benchmark::DoNotOptimize(cloud->positions.data());
  }
  report(state, file->size(), points);
}
BENCHMARK(ReadPlyMapped)->Unit(benchmark::kMillisecond)->UseRealTime();

void EncodePly(benchmark::State& state) {
  if (skip_if_missing(state)) return;
  auto cloud = sspc::read_point_cloud(kAutzen);
  if (!cloud.ok()) {
    state.SkipWithError(cloud.status().to_string().c_str());
    return;
  }
  std::size_t bytes = 0;
  for (auto _ : state) {
    const std::string out = sspc::encode_ply(*cloud);
    bytes = out.size();
    benchmark::DoNotOptimize(out.data());
  }
  report(state, bytes, cloud->size());
}
BENCHMARK(EncodePly)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
