// What a ray found, per pixel, and how it becomes a colour: shared by the uncompressed and the
// compressed renderer so their images compare pixel for pixel.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <utility>
#include <vector>

#include "core/parallel.hpp"
#include "render/camera.hpp"
#include "sspc/render.hpp"

namespace sspc::render {

// Option checks common to every scene: of a frame (RenderScene::render) and of a build (the
// factories).
Status check_frame(const FrameOptions& options);
Status check_scene(const SceneOptions& options);
// check_scene and a cloud that can be rendered: valid, not empty, with normals.
Status check_renderable(const PointCloud& cloud, const SceneOptions& options);

// The nominal spacing of a cloud to render (of its distinct positions, nominal_spacing), checked
// against float32's limits (check_geometry_range): the MLS bandwidth is a multiple of it, and a
// ray marches in steps of half the bandwidth, so a spacing of 0 would never move.
StatusOr<double> surface_spacing(const PointCloud& cloud);

// A spacing estimate put on the ladder of 2^(k/kSpacingLadder), the nearest rung (h moves by at
// most 4.4%). A render is chaotic in its bandwidth: the march samples a ray on a lattice of h/2
// steps, and on a rough surface another lattice finds another root. dragon_scans at level 0,
// stored with normals, rendered directly scored 41.9 dB against the render of its decode when
// the two spacing estimates (the compressed scene's from a sample of its patches, the decoded
// cloud's from a stride through its points) differed by 0.0016%, and was identical on every
// hit pixel given the same spacing; autzen's estimates at level 0 differ by 1%. Estimates that
// differ by less than a rung mostly fall on the same rung (not when a rung's edge lies between
// them).
inline constexpr double kSpacingLadder = 8;
double ladder_spacing(double spacing);

// A ray of RenderScene::intersect with its direction made unit length (the surfaces march in
// world units): t_unit = t · scale.
struct UnitRay {
  Vec3f origin, direction;
  float t_min = 0, t_max = 0, scale = 1;
  static StatusOr<UnitRay> make(const Vec3f& origin, const Vec3f& direction, float t_min, float t_max);
};

// A frame being traced: the image itself, each hit shaded as it is set (the headlight's Lambert
// term, the normal or the code word's colour need only the pixel), depth shading once the
// frame's nearest and farthest hits are known (finish). 7 bytes a pixel (the colour and the
// depth); it held each hit's depth, normal and code word apart from the image before, 27 bytes
// a pixel, 28 MB of the 91 MB autzen's level-0 model grew by under a 64 MiB budget at 1024²
// (docs/RESULTS.md, "Renderer: speed and memory"). The same bytes as shading afterwards: the same
// expressions on the same floats.
class Frame {
 public:
  Frame(int width, int height, Shade mode, const PinholeCamera& camera);
  // Each pixel is written by one task: no synchronisation needed.
  void set(int x, int y, float t, const Vec3f& normal, std::uint32_t id);
  Image finish() &&;
  std::size_t memory_bytes() const { return image_.rgb.size() + image_.depth.size() * sizeof(float); }

 private:
  Shade mode_;
  const PinholeCamera& camera_;
  Image image_;
};

// The tiles of a width × height image, kTile pixels a side (the last row and column of tiles
// may be smaller), in the order of a Hilbert curve over the grid of tiles: consecutive tiles
// are neighbours, so the rays of a stretch of tiles cross few bricks of a scene, and a thread
// given a stretch needs few bricks at a time. Traced by rows of pixels instead, autzen at level
// 5 (1024², 2 threads, 64 MiB budget) built its 380 bricks 1,319 times; by tiles in this order
// 525 times (and 380 with room for all), in 43.7 CPU s instead of 162. Handing the tiles out
// one at a time in this order to whichever thread is free built fewer (468) but left the two
// threads waiting on each other's bricks: 29.5 s a frame against 22.2. Each is (x0, y0) of its
// tile.
inline constexpr int kTile = 16;
std::vector<std::pair<int, int>> hilbert_tiles(int width, int height);

// Traces every pixel, stretches of hilbert_tiles' order in parallel, each stretch with a tracer
// of its own from make_trace(): trace(x, y, frame, evaluations) → whether it hit (it may set
// the pixel in `frame` and add its MLS evaluations, and keep what it likes from ray to ray of
// its stretch); then shades the frame. Fills the tracing half of `stats` (rays, hits, evaluations, render
// seconds) when given.
template <typename MakeTrace>
Image trace_image(const FrameOptions& o, const PinholeCamera& camera, MakeTrace&& make_trace, RenderStats* stats) {
  const auto start = std::chrono::steady_clock::now();
  Frame frame(o.width, o.height, o.shade, camera);
  std::atomic<std::uint64_t> hits{0}, evaluations{0};
  const std::vector<std::pair<int, int>> tiles = hilbert_tiles(o.width, o.height);
  progress_begin(o.progress, "render", tiles.size(), "tiles");
  parallel_for_ranges(0, tiles.size(), 1, [&](std::size_t begin, std::size_t end) {
    std::uint64_t local_hits = 0, local_evaluations = 0;
    auto trace = make_trace();
    for (std::size_t i = begin; i < end; ++i) {
      const auto [x0, y0] = tiles[i];
      const int x1 = std::min(o.width, x0 + kTile), y1 = std::min(o.height, y0 + kTile);
      for (int y = y0; y < y1; ++y) {
        for (int x = x0; x < x1; ++x) {
          if (trace(x, y, frame, local_evaluations)) ++local_hits;
        }
      }
    }
    hits += local_hits;
    evaluations += local_evaluations;
    progress_advance(o.progress, end - begin);
  });
  progress_end(o.progress);
  const std::size_t frame_bytes = frame.memory_bytes();
  Image image = std::move(frame).finish();
  if (stats != nullptr) {
    stats->render_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    stats->rays = static_cast<std::uint64_t>(o.width) * static_cast<std::uint64_t>(o.height);
    stats->frame_bytes = frame_bytes;
    stats->hits = hits;
    stats->evaluations = evaluations;
  }
  return image;
}

}  // namespace sspc::render
