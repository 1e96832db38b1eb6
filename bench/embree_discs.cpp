// embree_discs_bench: the reference a fast raw-point renderer gives, for scripts/bench_render.sh.
// Every point of a cloud becomes an Embree 3 oriented disc (RTC_GEOMETRY_TYPE_ORIENTED_DISC_POINT,
// Embree's API manual) of radius RADIUS × the cloud's nominal spacing (nominal_spacing, the
// spacing sspc's renderer takes its MLS bandwidth from), and primary rays are traced through
// the same cameras, pixels and Lambert shading as `sspc render`, so that the images compare
// pixel for pixel and the speeds ray for ray. Discs are what point ray tracers intersect
// (Schaufler and Jensen, "Ray tracing point sampled geometry", 2000; Wald and Seidel,
// "Interactive ray tracing of point-based models", 2005): no surface between the points, only
// each point's tangent disc, wide enough to close the gaps (1.5 spacings: at 1.0 the bunny
// shows holes).
//
//   embree_discs_bench IN [--size WxH] [--eye X,Y,Z] [--target X,Y,Z] [--up X,Y,Z] [--fov DEG]
//                      [--camera-path FILE] [--radius SPACINGS] [--packet 1|8|16] [--threads N]
//                      [--repeat R] [-o OUT.png] [--compare REF.png]
//
// Without --eye and --target the camera frames the cloud's bounds as `sspc render` does; a
// camera path has `sspc render --camera-path`'s format. Normals are estimated (PCA, k = 16, as
// `sspc normals` does) when the cloud has none. Writes one JSON object on stdout: build
// seconds, rays, hits and, over the median of R renders of all the cameras, wall seconds and
// CPU seconds (getrusage: every thread of the process, user and system), rays per second of
// each, Embree's memory, and with --compare the image PSNR over the pixels hit by both and the
// fraction hit by one only (sspc::compare_images) of the first camera's image.
#include <embree3/rtcore.h>
#include <sys/resource.h>
#include <tbb/blocked_range2d.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "sspc/io.hpp"
#include "sspc/neighbours.hpp"
#include "sspc/normals.hpp"
#include "sspc/render.hpp"

namespace {

using sspc::Vec3f;

// CPU seconds of the whole process so far, every thread, user and system.
double cpu_seconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  const auto seconds = [](const timeval& t) { return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec); };
  return seconds(usage.ru_utime) + seconds(usage.ru_stime);
}

double since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

[[noreturn]] void die(const std::string& message, int code = 1) {
  std::fprintf(stderr, "embree_discs_bench: %s\n", message.c_str());
  std::exit(code);
}

// Up to `count` numbers separated by commas or spaces.
std::vector<float> parse_numbers(std::string text) {
  std::replace(text.begin(), text.end(), ',', ' ');
  std::istringstream in(text);
  std::vector<float> v;
  std::string word;
  while (in >> word) {
    float x = 0;
    const auto r = std::from_chars(word.data(), word.data() + word.size(), x);
    if (r.ec != std::errc() || r.ptr != word.data() + word.size() || !std::isfinite(x)) die("not a number: " + word, 2);
    v.push_back(x);
  }
  return v;
}

Vec3f parse_vec3(const std::string& text) {
  const std::vector<float> v = parse_numbers(text);
  if (v.size() != 3) die("expected X,Y,Z, got '" + text + "'", 2);
  return {v[0], v[1], v[2]};
}

// `sspc render --camera-path`'s format: eye, target [, up [, fov]] a line, '#' comments.
std::vector<sspc::Camera> read_camera_path(const std::string& path, const sspc::Camera& defaults) {
  std::ifstream in(path);
  if (!in) die("cannot open the camera path " + path);
  std::vector<sspc::Camera> cameras;
  std::string line;
  while (std::getline(in, line)) {
    if (const auto hash = line.find('#'); hash != std::string::npos) line.erase(hash);
    std::replace(line.begin(), line.end(), '\t', ' ');
    const std::vector<float> v = parse_numbers(line);
    if (v.empty()) continue;
    if (v.size() != 6 && v.size() != 9 && v.size() != 10) die(path + ": a camera is 6, 9 or 10 numbers");
    sspc::Camera c = defaults;
    c.eye = Vec3f(v[0], v[1], v[2]);
    c.target = Vec3f(v[3], v[4], v[5]);
    if (v.size() >= 9) c.up = Vec3f(v[6], v[7], v[8]);
    if (v.size() == 10) c.fov_degrees = v[9];
    cameras.push_back(c);
  }
  if (cameras.empty()) die(path + ": no camera");
  return cameras;
}

// sspc's pinhole camera (src/render/camera.cpp): the ray through pixel centre (x + ½, y + ½)
// of an image plane at distance 1, y down the image.
struct Pinhole {
  Vec3f eye, forward, right, down;
  float scale;
  int width, height;

  Pinhole(const sspc::Camera& c, int w, int h) : eye(c.eye), width(w), height(h) {
    forward = (c.target - c.eye).normalized();
    right = forward.cross(c.up).normalized();
    down = forward.cross(right);
    scale = 2.0f * std::tan(0.5f * c.fov_degrees * std::numbers::pi_v<float> / 180.0f) / static_cast<float>(h);
  }
  Vec3f direction(int x, int y) const {
    const float u = (static_cast<float>(x) + 0.5f - 0.5f * static_cast<float>(width)) * scale;
    const float v = (static_cast<float>(y) + 0.5f - 0.5f * static_cast<float>(height)) * scale;
    return (forward + u * right + v * down).normalized();
  }
};

// sspc's Lambert shading (src/render/shading.cpp): a headlight, |n · d|; misses stay black.
void shade(sspc::Image& image, int x, int y, const Vec3f& n, const Vec3f& d) {
  const float lambert = 0.15f + 0.85f * std::abs(n.normalized().dot(d));
  const auto byte = static_cast<std::uint8_t>(std::clamp(lambert, 0.0f, 1.0f) * 255.0f + 0.5f);
  const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(image.width) + static_cast<std::size_t>(x);
  std::fill_n(image.rgb.begin() + static_cast<std::ptrdiff_t>(3 * i), 3, byte);
}

// Packets of N = 8 or 16 rays over tiles of 4 × 2 or 4 × 4 pixels: coherent primary rays share
// their BVH traversal, Embree's fast path for them.
template <int N, typename RayHitN, typename IntersectN>
std::uint64_t trace_packets(RTCScene scene, const Pinhole& camera, sspc::Image& image, IntersectN intersect) {
  constexpr int kTileWidth = 4, kTileHeight = N / 4;
  std::atomic<std::uint64_t> hits{0};
  tbb::parallel_for(tbb::blocked_range2d<int>(0, image.height, 16, 0, image.width, 16), [&](const auto& tile) {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    std::uint64_t local = 0;
    for (int y0 = tile.rows().begin(); y0 < tile.rows().end(); y0 += kTileHeight) {
      for (int x0 = tile.cols().begin(); x0 < tile.cols().end(); x0 += kTileWidth) {
        alignas(64) int valid[static_cast<std::size_t>(N)];
        alignas(64) RayHitN packet{};
        Vec3f d[static_cast<std::size_t>(N)];
        for (int k = 0; k < N; ++k) {
          const int x = x0 + k % kTileWidth, y = y0 + k / kTileWidth;
          valid[k] = x < tile.cols().end() && y < tile.rows().end() ? -1 : 0;
          d[k] = valid[k] != 0 ? camera.direction(x, y) : Vec3f::UnitZ();
          packet.ray.org_x[k] = camera.eye.x();
          packet.ray.org_y[k] = camera.eye.y();
          packet.ray.org_z[k] = camera.eye.z();
          packet.ray.dir_x[k] = d[k].x();
          packet.ray.dir_y[k] = d[k].y();
          packet.ray.dir_z[k] = d[k].z();
          packet.ray.tnear[k] = 0;
          packet.ray.tfar[k] = std::numeric_limits<float>::infinity();
          packet.ray.mask[k] = ~0u;
          packet.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
        }
        intersect(valid, scene, &context, &packet);
        for (int k = 0; k < N; ++k) {
          if (valid[k] == 0 || packet.hit.geomID[k] == RTC_INVALID_GEOMETRY_ID) continue;
          shade(image, x0 + k % kTileWidth, y0 + k / kTileWidth,
                Vec3f(packet.hit.Ng_x[k], packet.hit.Ng_y[k], packet.hit.Ng_z[k]), d[k]);
          ++local;
        }
      }
    }
    hits += local;
  });
  return hits;
}

std::uint64_t trace_single(RTCScene scene, const Pinhole& camera, sspc::Image& image) {
  std::atomic<std::uint64_t> hits{0};
  tbb::parallel_for(tbb::blocked_range2d<int>(0, image.height, 16, 0, image.width, 16), [&](const auto& tile) {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    std::uint64_t local = 0;
    for (int y = tile.rows().begin(); y < tile.rows().end(); ++y) {
      for (int x = tile.cols().begin(); x < tile.cols().end(); ++x) {
        const Vec3f d = camera.direction(x, y);
        RTCRayHit rayhit{};
        rayhit.ray = RTCRay{camera.eye.x(), camera.eye.y(), camera.eye.z(), 0, d.x(), d.y(), d.z(), 0,
                            std::numeric_limits<float>::infinity(), ~0u, 0, 0};
        rayhit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(scene, &context, &rayhit);
        if (rayhit.hit.geomID == RTC_INVALID_GEOMETRY_ID) continue;
        shade(image, x, y, Vec3f(rayhit.hit.Ng_x, rayhit.hit.Ng_y, rayhit.hit.Ng_z), d);
        ++local;
      }
    }
    hits += local;
  });
  return hits;
}

// Embree's own allocations (BVH, buffers), through its memory monitor.
std::atomic<std::int64_t> embree_bytes{0}, embree_peak{0};
bool monitor(void*, ssize_t bytes, bool) {
  const std::int64_t now = embree_bytes += bytes;
  std::int64_t peak = embree_peak;
  while (now > peak && !embree_peak.compare_exchange_weak(peak, now)) {
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  std::string input, output, compare, camera_path, eye, target, up;
  int width = 1024, height = 1024, threads = 0, repeat = 3, packet = 1;
  float radius = 1.5f, fov = 40;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc) die(arg + " needs a value", 2);
      return argv[++i];
    };
    if (arg == "--size") {
      const std::string s = value();
      const auto x = s.find('x');
      if (x == std::string::npos) die("--size is WIDTHxHEIGHT", 2);
      width = std::atoi(s.substr(0, x).c_str());
      height = std::atoi(s.substr(x + 1).c_str());
    } else if (arg == "--eye") {
      eye = value();
    } else if (arg == "--target") {
      target = value();
    } else if (arg == "--up") {
      up = value();
    } else if (arg == "--fov") {
      fov = std::strtof(value().c_str(), nullptr);
    } else if (arg == "--camera-path") {
      camera_path = value();
    } else if (arg == "--radius") {
      radius = std::strtof(value().c_str(), nullptr);
    } else if (arg == "--packet") {
      packet = std::atoi(value().c_str());
    } else if (arg == "--threads") {
      threads = std::atoi(value().c_str());
    } else if (arg == "--repeat") {
      repeat = std::atoi(value().c_str());
    } else if (arg == "-o") {
      output = value();
    } else if (arg == "--compare") {
      compare = value();
    } else if (input.empty() && (arg.empty() || arg[0] != '-')) {
      input = arg;
    } else {
      die("unknown argument " + arg, 2);
    }
  }
  if (input.empty()) die("usage: embree_discs_bench IN [options] (see the source's first comment)", 2);
  if (width < 1 || height < 1 || width > 16384 || height > 16384) die("--size must be 1..16384 a side", 2);
  if (!(radius > 0) || !(fov > 0.1f && fov < 179) || repeat < 1 || (packet != 1 && packet != 8 && packet != 16)) {
    die("--radius > 0, --fov in (0.1, 179), --repeat ≥ 1, --packet 1, 8 or 16", 2);
  }
  std::optional<tbb::global_control> cap;
  if (threads > 0) cap.emplace(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));

  auto cloud = sspc::read_point_cloud(input);
  if (!cloud.ok()) die(cloud.status().to_string());
  const bool estimated = !cloud->has_normals();
  if (const sspc::Status s = sspc::ensure_normals(*cloud, sspc::NormalOptions{}); !s.ok()) die(s.to_string());
  const double spacing = sspc::nominal_spacing(*cloud);
  if (!(spacing > 0)) die("the cloud has fewer than two distinct points");
  const auto disc = static_cast<float>(static_cast<double>(radius) * spacing);

  sspc::Camera framing = sspc::frame_bounds(cloud->bounding_box(), fov);
  if (!eye.empty()) framing.eye = parse_vec3(eye);
  if (!target.empty()) framing.target = parse_vec3(target);
  if (!up.empty()) framing.up = parse_vec3(up);
  const std::vector<sspc::Camera> cameras =
      camera_path.empty() ? std::vector<sspc::Camera>{framing} : read_camera_path(camera_path, framing);

  // The scene: one geometry of N discs, (x, y, z, radius) and the unit normal per point.
  const std::string config = threads > 0 ? "threads=" + std::to_string(threads) : "";
  RTCDevice device = rtcNewDevice(config.c_str());
  if (device == nullptr) die("rtcNewDevice failed");
  rtcSetDeviceMemoryMonitorFunction(device, monitor, nullptr);
  const auto build_start = std::chrono::steady_clock::now();
  const double build_cpu_start = cpu_seconds();
  RTCScene scene = rtcNewScene(device);
  rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_HIGH);
  RTCGeometry geometry = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_ORIENTED_DISC_POINT);
  auto* points = static_cast<float*>(
      rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 4 * sizeof(float), cloud->size()));
  auto* normals = static_cast<float*>(
      rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_NORMAL, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), cloud->size()));
  for (std::size_t i = 0; i < cloud->size(); ++i) {
    for (int a = 0; a < 3; ++a) {
      points[4 * i + static_cast<std::size_t>(a)] = cloud->positions[i][a];
      normals[3 * i + static_cast<std::size_t>(a)] = cloud->normals[i][a];
    }
    points[4 * i + 3] = disc;
  }
  rtcCommitGeometry(geometry);
  rtcAttachGeometry(scene, geometry);
  rtcReleaseGeometry(geometry);
  rtcCommitScene(scene);
  const double build_seconds = since(build_start);
  const double build_cpu = cpu_seconds() - build_cpu_start;

  // R renders of every camera; the one of median wall time is reported.
  struct Run {
    double seconds = 0, cpu = 0;
    std::uint64_t hits = 0;
  };
  std::vector<Run> runs;
  sspc::Image first;
  for (int r = 0; r < repeat; ++r) {
    Run run;
    for (std::size_t c = 0; c < cameras.size(); ++c) {
      const Pinhole camera(cameras[c], width, height);
      sspc::Image image;
      image.width = width;
      image.height = height;
      image.rgb.assign(3 * static_cast<std::size_t>(width) * static_cast<std::size_t>(height), 0);
      const auto start = std::chrono::steady_clock::now();
      const double cpu_start = cpu_seconds();
      run.hits += packet == 16 ? trace_packets<16, RTCRayHit16>(scene, camera, image, rtcIntersect16)
                  : packet == 8 ? trace_packets<8, RTCRayHit8>(scene, camera, image, rtcIntersect8)
                                : trace_single(scene, camera, image);
      run.cpu += cpu_seconds() - cpu_start;
      run.seconds += since(start);
      if (r == 0 && c == 0) first = std::move(image);
    }
    runs.push_back(run);
  }
  std::sort(runs.begin(), runs.end(), [](const Run& a, const Run& b) { return a.seconds < b.seconds; });
  const Run& median = runs[runs.size() / 2];
  rtcReleaseScene(scene);
  rtcReleaseDevice(device);

  if (!output.empty()) {
    if (const sspc::Status s = sspc::write_png(first, output); !s.ok()) die(s.to_string());
  }
  std::optional<sspc::ImageComparison> compared;
  if (!compare.empty()) {
    auto reference = sspc::read_png(compare);
    if (!reference.ok()) die(reference.status().to_string());
    auto c = sspc::compare_images(first, *reference);
    if (!c.ok()) die(c.status().to_string());
    compared = *c;
  }

  const double rays = static_cast<double>(width) * static_cast<double>(height) * static_cast<double>(cameras.size());
  nlohmann::json json{{"input", input},
                      {"points", cloud->size()},
                      {"normals_estimated", estimated},
                      {"spacing", spacing},
                      {"radius_spacings", radius},
                      {"disc_radius", disc},
                      {"packet", packet},
                      {"width", width},
                      {"height", height},
                      {"frames", cameras.size()},
                      {"repeat", repeat},
                      {"build_seconds", build_seconds},
                      {"build_cpu_seconds", build_cpu},
                      {"scene_bytes", embree_peak.load()},
                      {"rays", static_cast<std::uint64_t>(rays)},
                      {"hits", median.hits},
                      {"render_seconds", median.seconds},
                      {"render_cpu_seconds", median.cpu},
                      {"rays_per_second", rays / median.seconds},
                      {"rays_per_cpu_second", rays / median.cpu}};
  if (compared) {
    json["psnr_hit_db"] = compared->psnr_hit;  // null when the images agree exactly (+inf)
    json["hit_one_only_fraction"] = compared->one_only_fraction();
  }
  std::printf("%s\n", json.dump().c_str());
  return 0;
}
