// Decoding an .sspc file (issue 3): a synthetic model of ~1M decoded points (a plane cut into
// ~28k patches of ~200 points, instances of 32 code words), and dragon_scans.ply encoded at
// the default level when ../shared/data is there (the *Scan benchmarks). Targets: decode_all ≥ 20M points/s
// on 2 cores; decode_patch ≤ 5 µs per patch from an open file. The block-size arguments are
// how FORMAT.md's defaults were chosen.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "encoder/container_writer.hpp"
#include "format/encoded_model.hpp"
#include "sspc/compressed_model.hpp"
#include "sspc/encoder.hpp"
#include "sspc/io.hpp"

namespace {

using sspc::Vec3f;

float unit(std::mt19937& rng) {
  return static_cast<float>(static_cast<std::uint32_t>(rng()) >> 8) * (1.0f / 16777216.0f);
}

// A 1000 × 1000 plane at unit spacing; patches of radius 8 every 6 units, each a code word
// rotated about the normal.
sspc::codec::EncodedModel plane_model() {
  std::mt19937 rng(42);
  sspc::codec::EncodedModel m;
  m.patch_radius = 8;
  m.coverage_radius = 4.5f;
  m.spacing = 1;
  m.source_points = 1000000;
  m.has_normals = true;
  m.bounds = sspc::Box3f(Vec3f(0, 0, -0.1f), Vec3f(999, 999, 0.1f));
  for (int c = 0; c < 32; ++c) {
    sspc::codec::Codeword w;
    for (int y = -8; y <= 8; ++y) {
      for (int x = -8; x <= 8; ++x) {
        const Vec3f p(static_cast<float>(x) + 0.6f * unit(rng) - 0.3f,
                      static_cast<float>(y) + 0.6f * unit(rng) - 0.3f, 0.1f * unit(rng) - 0.05f);
        if (p.norm() > m.patch_radius) continue;
        w.points.push_back(p);
        w.normals.push_back(
            Vec3f(0.2f * unit(rng) - 0.1f, 0.2f * unit(rng) - 0.1f, 1).normalized());
      }
    }
    m.codebook.push_back(std::move(w));
  }
  // Patch centres every 6 units, written in Morton (Z) order of their grid cells: the kind of
  // spatial order the encoder produces, which keeps each block's patches close together.
  std::vector<std::pair<std::uint32_t, Vec3f>> centres;
  for (std::uint32_t j = 0; j < 167; ++j) {
    for (std::uint32_t i = 0; i < 167; ++i) {
      std::uint32_t code = 0;
      for (int bit = 0; bit < 8; ++bit) {
        code |= ((i >> bit) & 1u) << (2 * bit);
        code |= ((j >> bit) & 1u) << (2 * bit + 1);
      }
      centres.emplace_back(code,
                           Vec3f(6.0f * static_cast<float>(i), 6.0f * static_cast<float>(j), 0));
    }
  }
  std::sort(centres.begin(), centres.end(),
            [](const auto& x, const auto& y) { return x.first < y.first; });
  for (const auto& [code, centre] : centres) {
    sspc::codec::PatchInstance p;
    p.codeword = static_cast<std::uint32_t>(rng() % 32);
    p.world_from_codeword.rotation =
        Eigen::AngleAxisf(6.2831853f * unit(rng), Vec3f::UnitZ()).toRotationMatrix();
    p.world_from_codeword.translation = centre;
    m.patches.push_back(p);
  }
  return m;
}

// One file per block layout, written once and reused.
const std::filesystem::path& model_file(int patches_per_block, int codewords_per_block) {
  static std::map<std::pair<int, int>, std::filesystem::path> files;
  auto& path = files[{patches_per_block, codewords_per_block}];
  if (path.empty()) {
    static const sspc::codec::EncodedModel model = plane_model();
    sspc::codec::QuantOptions o;
    o.patches_per_block = static_cast<std::uint32_t>(patches_per_block);
    o.codewords_per_block = static_cast<std::uint32_t>(codewords_per_block);
    path = std::filesystem::temp_directory_path() /
           ("sspc_decode_bench_" + std::to_string(patches_per_block) + "_" +
            std::to_string(codewords_per_block) + ".sspc");
    auto stats = sspc::codec::write_container(model, o, path);
    if (!stats.ok()) {
      std::fprintf(stderr, "%s\n", stats.status().to_string().c_str());
      std::abort();
    }
    std::fprintf(
        stderr,
        "[%d patches, %d code words per block] %llu bytes: code book %llu (%.2f bits "
        "per code-word point, raw %.2f), patches %llu (%.2f bits per patch, raw %.2f), "
        "seek tables %llu\n",
        patches_per_block, codewords_per_block, static_cast<unsigned long long>(stats->file_bytes),
        static_cast<unsigned long long>(stats->codebook_bytes),
        8.0 * static_cast<double>(stats->codebook_bytes) / 32.0 /
            static_cast<double>(model.codebook[0].points.size()),
        8.0 * static_cast<double>(stats->codebook_raw_bytes) / 32.0 /
            static_cast<double>(model.codebook[0].points.size()),
        static_cast<unsigned long long>(stats->patch_bytes),
        8.0 * static_cast<double>(stats->patch_bytes) / static_cast<double>(model.patches.size()),
        8.0 * static_cast<double>(stats->patch_raw_bytes) /
            static_cast<double>(model.patches.size()),
        static_cast<unsigned long long>(stats->codebook_seek_bytes + stats->patch_seek_bytes));
  }
  return path;
}

sspc::CompressedModel open_model(benchmark::State& state) {
  auto model = sspc::CompressedModel::open(
      model_file(static_cast<int>(state.range(0)), static_cast<int>(state.range(1))));
  if (!model.ok()) std::abort();
  return std::move(model).value();
}

void BM_DecodeAll(benchmark::State& state) {
  const sspc::CompressedModel model = open_model(state);
  sspc::DecodeOptions options;
  options.overlap = state.range(2) != 0;
  std::size_t points = 0;
  for (auto _ : state) {
    auto cloud = model.decode_all(options);
    if (!cloud.ok()) state.SkipWithError(cloud.status().to_string().c_str());
    points = cloud->size();
    benchmark::DoNotOptimize(cloud->positions.data());
  }
  state.counters["points"] = static_cast<double>(points);
  state.counters["points/s"] =
      benchmark::Counter(static_cast<double>(points) * static_cast<double>(state.iterations()),
                         benchmark::Counter::kIsRate);
}
BENCHMARK(BM_DecodeAll)
    ->ArgsProduct({{8, 32, 128}, {4}, {0}})
    ->Args({32, 4, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// Patches in file order from an open model: what a renderer or a box query sees once the
// neighbouring blocks are in the cache.
void BM_DecodePatchWarm(benchmark::State& state) {
  const sspc::CompressedModel model = open_model(state);
  std::size_t k = 0;
  for (auto _ : state) {
    auto cloud = model.decode_patch(k);
    benchmark::DoNotOptimize(cloud->positions.data());
    if (++k == model.patch_count()) k = 0;
  }
  state.counters["us/patch"] =
      benchmark::Counter(static_cast<double>(state.iterations()) * 1e-6,
                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_DecodePatchWarm)->ArgsProduct({{8, 16, 32, 64, 128}, {1, 4, 16}});

// Random patches, first touch: every query on a freshly opened model, so every block it needs
// is read, CRC-checked, decompressed and decoded.
void BM_DecodePatchCold(benchmark::State& state) {
  std::mt19937 rng(7);
  for (auto _ : state) {
    state.PauseTiming();
    sspc::CompressedModel model = open_model(state);
    const std::size_t k = rng() % model.patch_count();
    state.ResumeTiming();
    auto cloud = model.decode_patch(k);
    benchmark::DoNotOptimize(cloud->positions.data());
  }
}
BENCHMARK(BM_DecodePatchCold)
    ->ArgsProduct({{8, 16, 32, 64, 128}, {1, 4}})
    ->Unit(benchmark::kMicrosecond);

// dragon_scans.ply at the default level, encoded once per run; empty when the data is absent.
// SSPC_DECODE_BENCH_MODEL names a model to measure instead (another scan or level: autzen's
// patches of 131,072 points at level 8, say).
const std::filesystem::path& scan_file() {
  static const std::filesystem::path path = [] {
    if (const char* model = std::getenv("SSPC_DECODE_BENCH_MODEL"); model != nullptr && *model != 0) {
      return std::filesystem::path(model);
    }
    const std::filesystem::path source = std::filesystem::path(SSPC_DATA_DIR) / "dragon_scans.ply";
    const std::filesystem::path out = std::filesystem::temp_directory_path() / "sspc_decode_bench_dragon.sspc";
    auto cloud = sspc::read_point_cloud(source);
    if (!cloud.ok()) return std::filesystem::path();
    if (!sspc::encode(std::move(cloud).value(), out).ok()) return std::filesystem::path();
    return out;
  }();
  return path;
}

void BM_DecodeAllScan(benchmark::State& state) {
  if (scan_file().empty()) {
    state.SkipWithError("../shared/data/dragon_scans.ply not found");
    return;
  }
  auto model = sspc::CompressedModel::open(scan_file());
  if (!model.ok()) std::abort();
  std::size_t points = 0;
  for (auto _ : state) {
    auto cloud = model->decode_all();
    points = cloud->size();
    benchmark::DoNotOptimize(cloud->positions.data());
  }
  state.counters["points"] = static_cast<double>(points);
  state.counters["points/s"] =
      benchmark::Counter(static_cast<double>(points) * static_cast<double>(state.iterations()),
                         benchmark::Counter::kIsRate);
}
BENCHMARK(BM_DecodeAllScan)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_DecodePatchWarmScan(benchmark::State& state) {
  if (scan_file().empty()) {
    state.SkipWithError("../shared/data/dragon_scans.ply not found");
    return;
  }
  auto model = sspc::CompressedModel::open(scan_file());
  if (!model.ok()) std::abort();
  std::size_t k = 0;
  for (auto _ : state) {
    auto cloud = model->decode_patch(k);
    benchmark::DoNotOptimize(cloud->positions.data());
    if (++k == model->patch_count()) k = 0;
  }
  state.counters["us/patch"] =
      benchmark::Counter(static_cast<double>(state.iterations()) * 1e-6,
                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_DecodePatchWarmScan);

}  // namespace
