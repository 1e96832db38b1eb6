// `sspc eval`'s engine on real and synthetic clouds: two k-d trees, two nearest-neighbour
// passes, D1 and D2. Target (issue 2): two 10.6M-point clouds (autzen.ply and a noisy copy) in
// under 60 s on 2 cores. The synthetic cases show how the time grows with the point count.
#include <benchmark/benchmark.h>

#include <cmath>
#include <filesystem>
#include <optional>
#include <string>

#include "sspc/io.hpp"
#include "sspc/metrics.hpp"
#include "sspc/neighbours.hpp"
#include "sspc/normals.hpp"
#include "sspc/synthetic.hpp"

namespace {

// A copy of `cloud` with isotropic Gaussian noise of `fraction` × spacing per axis.
sspc::PointCloud noisy_copy(const sspc::PointCloud& cloud, double fraction) {
  const double sigma = fraction * sspc::nominal_spacing(cloud);
  sspc::PointCloud noisy = cloud;
  sspc::synthetic::Rng rng(12345);
  for (sspc::Vec3f& p : noisy.positions) {
    for (int a = 0; a < 3; ++a) p[a] += static_cast<float>(sigma * rng.gaussian());
  }
  return noisy;
}

void run(benchmark::State& state, const sspc::PointCloud& ref, const sspc::PointCloud& test) {
  for (auto _ : state) {
    auto report = sspc::evaluate(ref, test);
    if (!report.ok()) {
      state.SkipWithError(report.status().to_string().c_str());
      return;
    }
    benchmark::DoNotOptimize(report->d1_psnr);
  }
  const double points = static_cast<double>(ref.size() + test.size());
  state.counters["points"] = points;
  state.counters["points/s"] =
      benchmark::Counter(points * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

void BM_EvalAutzenNoisy(benchmark::State& state) {
  static std::optional<sspc::PointCloud> ref;
  static std::optional<sspc::PointCloud> test;
  if (!ref) {
    const std::filesystem::path path = std::filesystem::path(SSPC_DATA_DIR) / "autzen.ply";
    auto cloud = sspc::read_point_cloud(path);
    if (!cloud.ok()) {
      state.SkipWithError(("needs " + path.string() + ": " + cloud.status().to_string()).c_str());
      return;
    }
    ref = std::move(*cloud);
    // D2 needs REF's normals; estimate them once, outside the timing, as `sspc eval` does for a
    // REF without normals.
    sspc::NormalOptions options;
    options.mode = sspc::NormalMode::kAuto;
    if (auto s = sspc::ensure_normals(*ref, options); !s.ok()) {
      state.SkipWithError(s.to_string().c_str());
      return;
    }
    test = noisy_copy(*ref, 0.01);
  }
  run(state, *ref, *test);
}
BENCHMARK(BM_EvalAutzenNoisy)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

// A bump surface with normals against a noisy copy, 2^18 to 2^22 points per cloud.
void BM_EvalSynthetic(benchmark::State& state) {
  const auto n = static_cast<std::size_t>(state.range(0));
  const sspc::PointCloud ref = sspc::synthetic::bumps(n, 1.0, 8, 0.05);
  sspc::synthetic::Options noisy;
  noisy.seed = 2;
  noisy.noise = 1e-4;
  const sspc::PointCloud test = sspc::synthetic::bumps(n, 1.0, 8, 0.05, noisy);
  run(state, ref, test);
}
BENCHMARK(BM_EvalSynthetic)->RangeMultiplier(4)->Range(1 << 18, 1 << 22)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
