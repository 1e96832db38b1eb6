// Normal estimation and Hoppe orientation (ensure_normals with kEstimate) on autzen.ply and on
// synthetic clouds of 1M points. Target (issue 3): estimate + orient at ≥ 500k points/s on 2
// cores over autzen's 10.6M points. Each run reports the time of every stage (k-d tree + k-NN,
// PCA, MST orientation) from the progress callbacks, so a regression shows where it is.
//
// BM_PcaSolver compares Eigen's closed-form 3×3 solver (what normals_pca.cpp uses) with the
// iterative one on the same neighbourhoods, for speed and for the worst angle to the truth.
#include <benchmark/benchmark.h>

#include <Eigen/Eigenvalues>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <string>

#include "core/parallel.hpp"
#include "sspc/io.hpp"
#include "sspc/neighbours.hpp"
#include "sspc/normals.hpp"
#include "sspc/synthetic.hpp"

namespace {

using Clock = std::chrono::steady_clock;

// Records each stage's wall time; advance() is called from worker threads and does nothing.
class StageTimer final : public sspc::Progress {
 public:
  void begin_stage(std::string_view name, std::uint64_t, std::string_view) override {
    name_ = name;
    start_ = Clock::now();
  }
  void advance(std::uint64_t) override {}
  void end_stage() override {
    seconds[name_] += std::chrono::duration<double>(Clock::now() - start_).count();
  }
  std::map<std::string, double> seconds;

 private:
  std::string name_;
  Clock::time_point start_;
};

void run(benchmark::State& state, const sspc::PointCloud& input) {
  StageTimer timer;
  for (auto _ : state) {
    state.PauseTiming();
    sspc::PointCloud cloud = input;
    cloud.normals.clear();
    state.ResumeTiming();
    sspc::NormalOptions options;
    options.mode = sspc::NormalMode::kEstimate;
    options.progress = &timer;
    if (const sspc::Status s = sspc::ensure_normals(cloud, options); !s.ok()) {
      state.SkipWithError(s.to_string().c_str());
      return;
    }
    benchmark::DoNotOptimize(cloud.normals.data());
  }
  const auto iterations = static_cast<double>(state.iterations());
  const auto points = static_cast<double>(input.size());
  state.counters["points"] = points;
  state.counters["points/s"] = benchmark::Counter(points * iterations, benchmark::Counter::kIsRate);
  for (const auto& [name, s] : timer.seconds) {
    // "normals: PCA" -> "PCA_s"
    state.counters[name.substr(name.find(' ') + 1) + "_s"] = s / iterations;
  }
}

const sspc::PointCloud* autzen() {
  static std::optional<sspc::StatusOr<sspc::PointCloud>> cloud;
  if (!cloud) cloud = sspc::read_point_cloud(std::filesystem::path(SSPC_DATA_DIR) / "autzen.ply");
  return cloud->ok() ? &cloud->value() : nullptr;
}

void BM_NormalsAutzen(benchmark::State& state) {
  const sspc::PointCloud* cloud = autzen();
  if (cloud == nullptr) {
    state.SkipWithError("needs autzen.ply in " SSPC_DATA_DIR);
    return;
  }
  run(state, *cloud);
}
BENCHMARK(BM_NormalsAutzen)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

void BM_NormalsTorus1M(benchmark::State& state) {
  static const sspc::PointCloud cloud =
      sspc::synthetic::torus(1'000'000, 2.0, 0.5, {.seed = 1, .normals = false, .noise = 1e-4});
  run(state, cloud);
}
BENCHMARK(BM_NormalsTorus1M)->Unit(benchmark::kMillisecond)->Iterations(2)->UseRealTime();

void BM_NormalsBumps1M(benchmark::State& state) {
  static const sspc::PointCloud cloud = sspc::synthetic::bumps(
      1'000'000, 20.0, 10, 1.0, {.seed = 1, .normals = false, .noise = 2e-4});
  run(state, cloud);
}
BENCHMARK(BM_NormalsBumps1M)->Unit(benchmark::kMillisecond)->Iterations(2)->UseRealTime();

// The normal of one neighbourhood with either solver.
template <bool kDirect>
sspc::Vec3f pca_normal(std::span<const sspc::Vec3f> positions, std::span<const std::uint32_t> row) {
  sspc::Vec3d centroid = sspc::Vec3d::Zero();
  for (const std::uint32_t j : row) centroid += positions[j].cast<double>();
  centroid /= static_cast<double>(row.size());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (const std::uint32_t j : row) {
    const sspc::Vec3d d = positions[j].cast<double>() - centroid;
    covariance.selfadjointView<Eigen::Lower>().rankUpdate(d);
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
  if constexpr (kDirect) {
    solver.computeDirect(covariance, Eigen::ComputeEigenvectors);
  } else {
    solver.compute(covariance, Eigen::ComputeEigenvectors);
  }
  return solver.eigenvectors().col(0).cast<float>().normalized();
}

template <bool kDirect>
void BM_PcaSolver(benchmark::State& state) {
  // A sphere: every neighbourhood is curved and the truth is known; offset far from the origin
  // like a georeferenced scan.
  static const sspc::PointCloud cloud = [] {
    sspc::PointCloud c = sspc::synthetic::sphere(1'000'000, 50.0, {.seed = 2});
    for (sspc::Vec3f& p : c.positions) p += sspc::Vec3f(3000, -2000, 500);
    return c;
  }();
  static const sspc::KnnTable table = sspc::KdTree3(cloud.positions).knn_batch(cloud.positions, 16);
  std::vector<sspc::Vec3f> normals(cloud.size());
  for (auto _ : state) {
    sspc::parallel_for(0, cloud.size(), 4096, [&](std::size_t i) {
      normals[i] = pca_normal<kDirect>(cloud.positions, table.row(i));
    });
    benchmark::DoNotOptimize(normals.data());
  }
  double worst = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const double c = std::abs(static_cast<double>(normals[i].dot(cloud.normals[i])));
    worst = std::max(worst, std::acos(std::min(1.0, c)) * 180.0 / 3.14159265358979);
  }
  state.counters["worst_deg"] = worst;
  state.counters["points/s"] = benchmark::Counter(
      static_cast<double>(cloud.size()) * static_cast<double>(state.iterations()),
      benchmark::Counter::kIsRate);
}
BENCHMARK_TEMPLATE(BM_PcaSolver, true)
    ->Name("BM_PcaSolver/direct")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_TEMPLATE(BM_PcaSolver, false)
    ->Name("BM_PcaSolver/iterative")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
