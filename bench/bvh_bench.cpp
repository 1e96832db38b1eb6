// The renderer's acceleration structure (issue: "Embree with user geometry, or an own BVH where
// that is measurably faster"): render::SphereBvh against Embree 3 user geometry on the same
// spheres and rays. The scene is the patches' bounding spheres of dragon_scans.ply encoded at
// the default level (or the .sspc named by SSPC_BENCH_MODEL); the rays are the primary rays of
// a 1024 × 1024 pinhole camera framing it, traced one at a time on one thread, as the renderer
// does (it parallelises over rows, so per-thread throughput is the figure). Both structures
// report every sphere a ray meets (the "collect all hits" pattern: Embree's intersect callback
// records the hit and does not commit it, so traversal goes on), and they are checked to find
// the same spheres before any timing.
#include <benchmark/benchmark.h>
#include <embree3/rtcore.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "render/camera.hpp"
#include "render/sphere_bvh.hpp"
#include "sspc/compressed_model.hpp"
#include "sspc/encoder.hpp"
#include "sspc/io.hpp"
#include "sspc/render.hpp"

namespace {

using sspc::Vec3f;
using sspc::render::Sphere;
using sspc::render::SphereBvh;

constexpr int kImage = 1024;
constexpr float kInf = std::numeric_limits<float>::infinity();

struct Workload {
  std::string error;              // why there is no workload; empty when there is one
  std::vector<Sphere> spheres;    // the dragon's patches
  std::vector<Sphere> synthetic;  // 1M random spheres, for the build's scaling
  Vec3f eye = Vec3f::Zero();
  std::vector<Vec3f> directions;  // row-major, kImage × kImage
};

// SSPC_BENCH_MODEL, or dragon_scans.ply encoded once per run at the default level.
std::filesystem::path model_path(std::string& error) {
  if (const char* env = std::getenv("SSPC_BENCH_MODEL"); env != nullptr && *env != 0) return env;
  const std::filesystem::path source = std::filesystem::path(SSPC_DATA_DIR) / "dragon_scans.ply";
  const std::filesystem::path out =
      std::filesystem::temp_directory_path() / "sspc_bvh_bench_dragon.sspc";
  auto cloud = sspc::read_point_cloud(source);
  if (!cloud.ok()) {
    error = source.string() + ": " + cloud.status().to_string();
    return {};
  }
  if (auto stats = sspc::encode(std::move(cloud).value(), out); !stats.ok()) {
    error = stats.status().to_string();
    return {};
  }
  return out;
}

// One sphere per patch around its centre, of the renderer's radius (compressed_renderer.cpp):
// min(code-word radius + MLS support radius, coverage radius + 2h), h = 1.5 spacings, the
// support radius 2.5h (mls_surface.cpp's kSupport).
std::vector<Sphere> patch_spheres(const sspc::CompressedModel& model, std::string& error) {
  const sspc::ModelInfo info = model.info();
  const float h = std::max(1.5f * info.spacing, 1e-6f * info.patch_radius);
  const float cap = info.coverage_radius + 2 * h;
  std::vector<float> radius(model.codeword_count());
  for (std::size_t c = 0; c < radius.size(); ++c) {
    auto word = model.codeword(c);
    if (!word.ok()) {
      error = word.status().to_string();
      return {};
    }
    radius[c] = std::min(word->radius + 2.5f * h, cap);
  }
  std::vector<Sphere> spheres(model.patch_count());
  std::size_t capped = 0;
  for (std::size_t k = 0; k < spheres.size(); ++k) {
    auto patch = model.patch(k);
    if (!patch.ok()) {
      error = patch.status().to_string();
      return {};
    }
    spheres[k] = {patch->translation, radius[patch->codeword]};
    if (spheres[k].radius == cap) ++capped;
  }
  std::fprintf(stderr, "%zu spheres, %zu of them at the cap %g\n", spheres.size(), capped,
               static_cast<double>(cap));
  return spheres;
}

// 1M spheres in the unit cube, radii 0.002 to 0.004: each overlaps a few neighbours, as patches
// do, and the centres are unsorted, as no encoder would leave them (the worst case for a build).
std::vector<Sphere> synthetic_spheres() {
  std::mt19937 rng(42);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<Sphere> spheres(1000000);
  for (Sphere& s : spheres) s = {Vec3f(u(rng), u(rng), u(rng)), 0.002f + 0.002f * u(rng)};
  return spheres;
}

const Workload& workload() {
  static const Workload cached = [] {
    Workload w;
    const std::filesystem::path path = model_path(w.error);
    if (path.empty()) return w;
    auto model = sspc::CompressedModel::open(path);
    if (!model.ok()) {
      w.error = path.string() + ": " + model.status().to_string();
      return w;
    }
    w.spheres = patch_spheres(*model, w.error);
    if (!w.error.empty()) return w;
    w.synthetic = synthetic_spheres();
    const sspc::render::PinholeCamera camera(sspc::frame_bounds(model->info().bounds), kImage,
                                             kImage);
    w.eye = camera.eye();
    w.directions.resize(static_cast<std::size_t>(kImage) * kImage);
    for (int y = 0; y < kImage; ++y) {
      for (int x = 0; x < kImage; ++x) {
        w.directions[static_cast<std::size_t>(y) * kImage + static_cast<std::size_t>(x)] =
            camera.direction(x, y);
      }
    }
    return w;
  }();
  return cached;
}

const std::vector<Sphere>& sphere_set(const Workload& w, std::int64_t which) {
  return which == 0 ? w.spheres : w.synthetic;
}

// What both structures do with a hit, in the timed loops: count it and sum its entry.
struct Tally {
  std::uint64_t hits = 0;
  double sum_t0 = 0;
  std::vector<std::uint32_t>* indices = nullptr;  // the spheres met, for the check only
  void add(std::uint32_t index, float t0) {
    ++hits;
    sum_t0 += static_cast<double>(t0);
    if (indices != nullptr) indices->push_back(index);
  }
};

void report(benchmark::State& state, const Tally& tally, std::size_t rays) {
  const auto iterations = static_cast<double>(state.iterations());
  state.counters["rays/s"] =
      benchmark::Counter(static_cast<double>(rays) * iterations, benchmark::Counter::kIsRate);
  state.counters["spheres/ray"] =
      static_cast<double>(tally.hits) / (static_cast<double>(rays) * iterations);
  state.counters["sum_t0"] = tally.sum_t0 / iterations;  // the checksum: equal for both
}

// ---- Embree 3, user geometry ----------------------------------------------------------------

// The intersect context every callback receives, extended by the hits' tally (Embree's
// documented way to pass per-ray data to a user geometry).
struct AllHitsContext {
  RTCIntersectContext context;
  Tally* tally;
};

void sphere_bounds(const RTCBoundsFunctionArguments* args) {
  const Sphere& s = static_cast<const Sphere*>(args->geometryUserPtr)[args->primID];
  RTCBounds* b = args->bounds_o;
  b->lower_x = s.centre.x() - s.radius;
  b->lower_y = s.centre.y() - s.radius;
  b->lower_z = s.centre.z() - s.radius;
  b->upper_x = s.centre.x() + s.radius;
  b->upper_y = s.centre.y() + s.radius;
  b->upper_z = s.centre.z() + s.radius;
}

// SphereBvh's sphere test, word for word, so both find the same spheres. Records the hit and
// leaves tfar and the hit alone: Embree then visits every primitive whose box the ray meets.
void sphere_all_hits(const RTCIntersectFunctionNArguments* args) {
  const Sphere& s = static_cast<const Sphere*>(args->geometryUserPtr)[args->primID];
  Tally& tally = *reinterpret_cast<AllHitsContext*>(args->context)->tally;
  RTCRayN* ray = RTCRayHitN_RayN(args->rayhit, args->N);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] == 0) continue;
    const Vec3f o(RTCRayN_org_x(ray, args->N, i), RTCRayN_org_y(ray, args->N, i),
                  RTCRayN_org_z(ray, args->N, i));
    const Vec3f d(RTCRayN_dir_x(ray, args->N, i), RTCRayN_dir_y(ray, args->N, i),
                  RTCRayN_dir_z(ray, args->N, i));
    const float t_max = RTCRayN_tfar(ray, args->N, i);
    const Vec3f oc = o - s.centre;
    const float b = oc.dot(d);
    const float c = oc.squaredNorm() - s.radius * s.radius;
    const float disc = b * b - c;
    if (disc < 0) continue;
    const float root = std::sqrt(disc);
    const float enter = -b - root, leave = -b + root;
    if (leave < 0 || enter > t_max) continue;
    tally.add(args->primID, std::max(enter, 0.0f));
  }
}

void sphere_occluded(const RTCOccludedFunctionNArguments*) {}

struct EmbreeDevice {
  RTCDevice device;
  explicit EmbreeDevice(const char* config) : device(rtcNewDevice(config)) {
    if (device == nullptr) std::abort();
    rtcSetDeviceErrorFunction(
        device,
        [](void*, RTCError, const char* message) { std::fprintf(stderr, "embree: %s\n", message); },
        nullptr);
  }
  ~EmbreeDevice() { rtcReleaseDevice(device); }
  EmbreeDevice(const EmbreeDevice&) = delete;
  EmbreeDevice& operator=(const EmbreeDevice&) = delete;
};

// threads = 0: Embree's default, every core (its worker threads exist only once asked for).
RTCDevice embree_device(int threads) {
  if (threads == 1) {
    static EmbreeDevice one("threads=1");
    return one.device;
  }
  static EmbreeDevice all("");
  return all.device;
}

class EmbreeScene {
 public:
  EmbreeScene(RTCDevice device, const std::vector<Sphere>& spheres) : scene_(rtcNewScene(device)) {
    rtcSetSceneBuildQuality(scene_, RTC_BUILD_QUALITY_HIGH);
    RTCGeometry geometry = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_USER);
    rtcSetGeometryBuildQuality(geometry, RTC_BUILD_QUALITY_HIGH);
    rtcSetGeometryUserPrimitiveCount(geometry, static_cast<unsigned>(spheres.size()));
    rtcSetGeometryUserData(geometry, const_cast<Sphere*>(spheres.data()));
    rtcSetGeometryBoundsFunction(geometry, sphere_bounds, nullptr);
    rtcSetGeometryIntersectFunction(geometry, sphere_all_hits);
    rtcSetGeometryOccludedFunction(geometry, sphere_occluded);
    rtcCommitGeometry(geometry);
    rtcAttachGeometry(scene_, geometry);
    rtcReleaseGeometry(geometry);
    rtcCommitScene(scene_);
  }
  ~EmbreeScene() { rtcReleaseScene(scene_); }
  EmbreeScene(const EmbreeScene&) = delete;
  EmbreeScene& operator=(const EmbreeScene&) = delete;

  void intersect1(const Vec3f& o, const Vec3f& d, Tally& tally) const {
    AllHitsContext ctx;
    rtcInitIntersectContext(&ctx.context);
    ctx.tally = &tally;
    RTCRayHit rh;
    rh.ray.org_x = o.x();
    rh.ray.org_y = o.y();
    rh.ray.org_z = o.z();
    rh.ray.tnear = 0;
    rh.ray.dir_x = d.x();
    rh.ray.dir_y = d.y();
    rh.ray.dir_z = d.z();
    rh.ray.time = 0;
    rh.ray.tfar = kInf;
    rh.ray.mask = ~0u;
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene_, &ctx.context, &rh);
  }

  // Eight rays of one row at once (Embree's packet path; the renderer has no packets).
  void intersect8(const Vec3f& o, const Vec3f* d, Tally& tally) const {
    AllHitsContext ctx;
    rtcInitIntersectContext(&ctx.context);
    ctx.context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    ctx.tally = &tally;
    alignas(32) int valid[8];
    alignas(32) RTCRayHit8 rh;
    for (int i = 0; i < 8; ++i) {
      valid[i] = -1;
      rh.ray.org_x[i] = o.x();
      rh.ray.org_y[i] = o.y();
      rh.ray.org_z[i] = o.z();
      rh.ray.tnear[i] = 0;
      rh.ray.dir_x[i] = d[i].x();
      rh.ray.dir_y[i] = d[i].y();
      rh.ray.dir_z[i] = d[i].z();
      rh.ray.time[i] = 0;
      rh.ray.tfar[i] = kInf;
      rh.ray.mask[i] = ~0u;
      rh.ray.id[i] = static_cast<unsigned>(i);
      rh.ray.flags[i] = 0;
      rh.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
      rh.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
    }
    rtcIntersect8(valid, scene_, &ctx.context, &rh);
  }

 private:
  RTCScene scene_;
};

// Both structures must report the same spheres for every ray of a 10k sample; an empty string
// when they do.
std::string check_same_hits(const Workload& w, const SphereBvh& bvh, const EmbreeScene& embree) {
  std::mt19937 rng(7);
  std::vector<std::uint32_t> ours, theirs;
  std::uint64_t met = 0, hits = 0;
  for (int r = 0; r < 10000; ++r) {
    const std::size_t k = rng() % w.directions.size();
    const Vec3f& d = w.directions[k];
    ours.clear();
    theirs.clear();
    bvh.intersect(w.eye, d, kInf, [&](std::uint32_t s, float, float) { ours.push_back(s); });
    Tally tally;
    tally.indices = &theirs;
    embree.intersect1(w.eye, d, tally);
    std::sort(ours.begin(), ours.end());
    std::sort(theirs.begin(), theirs.end());
    if (ours != theirs) {
      return "ray " + std::to_string(k) + ": SphereBvh finds " + std::to_string(ours.size()) +
             " spheres, Embree " + std::to_string(theirs.size());
    }
    met += ours.empty() ? 0u : 1u;
    hits += ours.size();
  }
  std::fprintf(
      stderr, "check: 10000 rays, same spheres; %.1f %% meet a sphere, %.2f spheres per such ray\n",
      0.01 * static_cast<double>(met),
      static_cast<double>(hits) / static_cast<double>(std::max<std::uint64_t>(met, 1)));
  return {};
}

// The dragon's structures, built once, checked once; and the rays that meet a sphere.
struct Structures {
  SphereBvh bvh;
  EmbreeScene embree;
  std::string mismatch;
  std::vector<Vec3f> meeting;  // the directions of rays that meet at least one sphere
  explicit Structures(const Workload& w)
      : bvh(w.spheres),
        embree(embree_device(1), w.spheres),
        mismatch(check_same_hits(w, bvh, embree)) {
    for (const Vec3f& d : w.directions) {
      bool met = false;
      bvh.intersect(w.eye, d, kInf, [&](std::uint32_t, float, float) { met = true; });
      if (met) meeting.push_back(d);
    }
    // Whole packets of 8 for BM_EmbreeAllHits8.
    meeting.resize(meeting.size() / 8 * 8);
  }
};

// The workload and both structures, or a reason to skip.
const Structures* structures(benchmark::State& state) {
  const Workload& w = workload();
  if (!w.error.empty()) {
    state.SkipWithError(w.error.c_str());
    return nullptr;
  }
  static const Structures s(w);
  if (!s.mismatch.empty()) {
    state.SkipWithError(("SphereBvh and Embree disagree: " + s.mismatch).c_str());
    return nullptr;
  }
  return &s;
}

// ---- Build ------------------------------------------------------------------------------------

// Argument: 0 the dragon's spheres, 1 the synthetic million.
void BM_SphereBvhBuild(benchmark::State& state) {
  if (structures(state) == nullptr) return;
  const std::vector<Sphere>& spheres = sphere_set(workload(), state.range(0));
  for (auto _ : state) {
    state.PauseTiming();
    std::vector<Sphere> copy = spheres;
    state.ResumeTiming();
    SphereBvh bvh(std::move(copy));
    benchmark::DoNotOptimize(bvh.node_count());
  }
  state.counters["spheres"] = static_cast<double>(spheres.size());
}
BENCHMARK(BM_SphereBvhBuild)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();

// Arguments: the sphere set, Embree's build threads (1, or 0 for its default: every core).
void BM_EmbreeBuild(benchmark::State& state) {
  if (structures(state) == nullptr) return;
  const std::vector<Sphere>& spheres = sphere_set(workload(), state.range(0));
  const RTCDevice device = embree_device(static_cast<int>(state.range(1)));
  for (auto _ : state) {
    EmbreeScene scene(device, spheres);
    benchmark::ClobberMemory();
  }
  state.counters["spheres"] = static_cast<double>(spheres.size());
}
BENCHMARK(BM_EmbreeBuild)
    ->ArgsProduct({{0, 1}, {1, 0}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// ---- Every sphere each primary ray meets --------------------------------------------------------

// Argument 0: every pixel's ray, the renderer's workload (most miss the dragon and cost one box
// test); 1: only the rays that meet a sphere, the cost of traversal proper. Rates are per CPU
// second of the one tracing thread, which a shared machine disturbs less than wall time.
const std::vector<Vec3f>& rays(const Structures& s, benchmark::State& state) {
  return state.range(0) == 0 ? workload().directions : s.meeting;
}

void BM_SphereBvhAllHits(benchmark::State& state) {
  const Structures* s = structures(state);
  if (s == nullptr) return;
  const Workload& w = workload();
  const std::vector<Vec3f>& directions = rays(*s, state);
  Tally tally;
  for (auto _ : state) {
    for (const Vec3f& d : directions) {
      s->bvh.intersect(w.eye, d, kInf, [&](std::uint32_t k, float t0, float) { tally.add(k, t0); });
    }
  }
  report(state, tally, directions.size());
}
BENCHMARK(BM_SphereBvhAllHits)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

void BM_EmbreeAllHits(benchmark::State& state) {
  const Structures* s = structures(state);
  if (s == nullptr) return;
  const Workload& w = workload();
  const std::vector<Vec3f>& directions = rays(*s, state);
  Tally tally;
  for (auto _ : state) {
    for (const Vec3f& d : directions) s->embree.intersect1(w.eye, d, tally);
  }
  report(state, tally, directions.size());
}
BENCHMARK(BM_EmbreeAllHits)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

void BM_EmbreeAllHits8(benchmark::State& state) {
  const Structures* s = structures(state);
  if (s == nullptr) return;
  const Workload& w = workload();
  const std::vector<Vec3f>& directions = rays(*s, state);
  Tally tally;
  for (auto _ : state) {
    for (std::size_t k = 0; k < directions.size(); k += 8)
      s->embree.intersect8(w.eye, &directions[k], tally);
  }
  report(state, tally, directions.size());
}
BENCHMARK(BM_EmbreeAllHits8)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace
