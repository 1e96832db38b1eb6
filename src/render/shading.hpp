// What a ray found, per pixel, and how it becomes a colour: shared by the uncompressed and the
// compressed renderer so their images compare pixel for pixel.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
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

// A ray of RenderScene::intersect with its direction made unit length (the surfaces march in
// world units): t_unit = t · scale.
struct UnitRay {
  Vec3f origin, direction;
  float t_min = 0, t_max = 0, scale = 1;
  static StatusOr<UnitRay> make(const Vec3f& origin, const Vec3f& direction, float t_min, float t_max);
};

class Frame {
 public:
  Frame(int width, int height);
  // Each pixel is written by one task: no synchronisation needed.
  void set(int x, int y, float t, const Vec3f& normal, std::uint32_t id);
  Image shade(Shade mode, const PinholeCamera& camera) const;

 private:
  int width_, height_;
  std::vector<float> depth_;
  std::vector<Vec3f> normal_;
  std::vector<std::uint32_t> id_;
};

// Traces every pixel, rows in parallel, with trace(x, y, frame, evaluations) → whether it hit
// (it may set the pixel in `frame` and add its MLS evaluations), then shades the frame. Fills
// the tracing half of `stats` (rays, hits, evaluations, render seconds) when given.
template <typename Trace>
Image trace_image(const FrameOptions& o, const PinholeCamera& camera, Trace&& trace, RenderStats* stats) {
  const auto start = std::chrono::steady_clock::now();
  Frame frame(o.width, o.height);
  std::atomic<std::uint64_t> hits{0}, evaluations{0};
  progress_begin(o.progress, "render", static_cast<std::uint64_t>(o.height), "rows");
  parallel_for_ranges(0, static_cast<std::size_t>(o.height), 4, [&](std::size_t y0, std::size_t y1) {
    std::uint64_t local_hits = 0, local_evaluations = 0;
    for (std::size_t y = y0; y < y1; ++y) {
      for (int x = 0; x < o.width; ++x) {
        if (trace(x, static_cast<int>(y), frame, local_evaluations)) ++local_hits;
      }
    }
    hits += local_hits;
    evaluations += local_evaluations;
    progress_advance(o.progress, y1 - y0);
  });
  progress_end(o.progress);
  Image image = frame.shade(o.shade, camera);
  if (stats != nullptr) {
    stats->render_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    stats->rays = static_cast<std::uint64_t>(o.width) * static_cast<std::uint64_t>(o.height);
    stats->hits = hits;
    stats->evaluations = evaluations;
  }
  return image;
}

}  // namespace sspc::render
