// The uncompressed renderer (paper §5): one MLS surface over the whole cloud, primary rays from
// a pinhole camera, parallel over image rows (each pixel written by one task: deterministic).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>

#include "core/parallel.hpp"
#include "core/stopwatch.hpp"
#include "render/camera.hpp"
#include "render/mls_surface.hpp"
#include "render/shading.hpp"
#include "sspc/neighbours.hpp"
#include "sspc/render.hpp"

namespace sspc {

Camera frame_bounds(const Box3f& bounds, float fov_degrees) {
  Camera c;
  c.fov_degrees = fov_degrees;
  if (bounds.isEmpty()) return c;
  const Vec3f centre = bounds.center();
  const float radius = std::max(0.5f * bounds.diagonal().norm(), 1e-20f);
  const float half = std::tan(0.5f * fov_degrees * 3.14159265f / 180.0f);
  c.target = centre;
  c.eye = centre + Vec3f(0, 0, 1.05f * radius / std::sin(std::atan(half)));
  c.up = Vec3f::UnitY();
  return c;
}

namespace {

class PointCloudScene final : public RenderScene {
 public:
  PointCloudScene(const PointCloud& cloud, float h)
      : surface_(cloud.positions, cloud.normals, h), bounds_(cloud.bounding_box()) {}

  StatusOr<Image> render(const FrameOptions& o, RenderStats* stats) const override {
    SSPC_RETURN_IF_ERROR(render::check_frame(o));
    const render::PinholeCamera camera(o.camera, o.width, o.height);
    Image image = render::trace_image(
        o, camera,
        [&] {
          return [&](int x, int y, render::Frame& frame, std::uint64_t& evaluations) {
            const auto hit = surface_.intersect(camera.eye(), camera.direction(x, y), 0,
                                                std::numeric_limits<float>::infinity(), &evaluations);
            if (!hit) return false;
            frame.set(x, y, hit->t, hit->normal, 0);
            return true;
          };
        },
        stats);
    if (stats != nullptr) {
      stats->build_seconds = build_seconds_;
      stats->scene_bytes = memory_bytes_;
    }
    return image;
  }

  StatusOr<std::optional<RayHit>> intersect(const Vec3f& origin, const Vec3f& direction, float t_min,
                                            float t_max) const override {
    SSPC_ASSIGN_OR_RETURN(const render::UnitRay ray, render::UnitRay::make(origin, direction, t_min, t_max));
    const auto hit = surface_.intersect(ray.origin, ray.direction, ray.t_min, ray.t_max);
    if (!hit) return std::optional<RayHit>();
    return std::optional<RayHit>(RayHit{hit->t / ray.scale, hit->normal, 0});
  }

  Box3f bounds() const override { return bounds_; }
  Box3f surface_bounds() const override { return surface_.box().merged(bounds_); }

  void set_build(double seconds) {
    build_seconds_ = seconds;
    memory_bytes_ = surface_.memory_bytes();
  }

 private:
  render::MlsSurface surface_;
  Box3f bounds_;
};

}  // namespace

StatusOr<std::unique_ptr<RenderScene>> RenderScene::from_point_cloud(const PointCloud& cloud,
                                                                     const SceneOptions& options) {
  SSPC_RETURN_IF_ERROR(render::check_renderable(cloud, options));
  Progress* progress = options.progress;
  const auto start = std::chrono::steady_clock::now();
  progress_begin(progress, "scene", 1, "surfaces");
  SSPC_ASSIGN_OR_RETURN(const double spacing, render::surface_spacing(cloud));
  const auto h = static_cast<float>(static_cast<double>(options.bandwidth) * spacing);
  auto scene = std::make_unique<PointCloudScene>(cloud, h);
  scene->set_build(seconds_since(start));
  progress_advance(progress, 1);
  progress_end(progress);
  return std::unique_ptr<RenderScene>(std::move(scene));
}

StatusOr<Image> render_point_cloud(const PointCloud& cloud, const FrameOptions& frame, const SceneOptions& scene_options,
                                   RenderStats* stats) {
  SSPC_RETURN_IF_ERROR(render::check_frame(frame));
  SSPC_ASSIGN_OR_RETURN(auto scene, RenderScene::from_point_cloud(cloud, scene_options));
  return scene->render(frame, stats);
}

}  // namespace sspc
