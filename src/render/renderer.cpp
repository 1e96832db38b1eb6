// The uncompressed renderer: one MLS surface over the whole cloud, primary rays from a pinhole
// camera, parallel over image rows (each pixel written by one task: deterministic).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>

#include "core/parallel.hpp"
#include "render/camera.hpp"
#include "render/mls_surface.hpp"
#include "sspc/neighbors.hpp"
#include "sspc/render.hpp"

namespace sspc {

namespace {

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// The ray's parameter interval inside `box` (slab test); empty when it misses.
bool clip_to_box(const Vec3f& o, const Vec3f& d, const Box3f& box, float& t0, float& t1) {
  t0 = 0;
  t1 = std::numeric_limits<float>::infinity();
  for (int a = 0; a < 3; ++a) {
    const float inv = 1.0f / d[a];
    float near = (box.min()[a] - o[a]) * inv, far = (box.max()[a] - o[a]) * inv;
    if (near > far) std::swap(near, far);
    t0 = std::max(t0, near);
    t1 = std::min(t1, far);
  }
  return t0 <= t1;
}

std::uint8_t to_byte(float v) {
  return static_cast<std::uint8_t>(std::clamp(v, 0.0f, 1.0f) * 255.0f + 0.5f);
}

Status check_options(const RenderOptions& o) {
  if (o.width < 1 || o.height < 1 || o.width > 16384 || o.height > 16384) {
    return invalid_argument("image size must be 1..16384 pixels per side");
  }
  if (!(o.camera.fov_degrees > 0.1f && o.camera.fov_degrees < 179.0f)) {
    return invalid_argument("field of view must be in (0.1, 179) degrees");
  }
  if (!(o.bandwidth > 0.1f && o.bandwidth < 100.0f)) return invalid_argument("bandwidth must be in (0.1, 100) spacings");
  const Vec3f forward = o.camera.target - o.camera.eye;
  if (!o.camera.eye.allFinite() || !o.camera.target.allFinite() || !o.camera.up.allFinite() ||
      !(forward.norm() > 0) || !(forward.normalized().cross(o.camera.up).norm() > 1e-6f)) {
    return invalid_argument("the camera needs distinct eye and target and an up vector not along the view");
  }
  return Status();
}

}  // namespace

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

StatusOr<Image> render_point_cloud(const PointCloud& cloud, const RenderOptions& o, RenderStats* stats) {
  SSPC_RETURN_IF_ERROR(check_options(o));
  SSPC_RETURN_IF_ERROR(cloud.validate());
  if (cloud.empty()) return invalid_argument("the cloud is empty");
  if (!cloud.has_normals()) return invalid_argument("rendering needs normals (estimate them first)");

  auto start = std::chrono::steady_clock::now();
  const double spacing = std::max(nominal_spacing(cloud), 1e-30);
  const auto h = static_cast<float>(static_cast<double>(o.bandwidth) * spacing);
  const render::MlsSurface surface(cloud.positions, cloud.normals, h);
  Box3f box = cloud.bounding_box();
  box.extend(box.min() - Vec3f::Constant(3 * h));
  box.extend(box.max() + Vec3f::Constant(3 * h));
  const double build_seconds = seconds_since(start);

  start = std::chrono::steady_clock::now();
  const render::PinholeCamera camera(o.camera, o.width, o.height);
  Image image;
  image.width = o.width;
  image.height = o.height;
  image.rgb.assign(static_cast<std::size_t>(o.width) * static_cast<std::size_t>(o.height) * 3, 0);
  image.depth.assign(static_cast<std::size_t>(o.width) * static_cast<std::size_t>(o.height),
                     std::numeric_limits<float>::infinity());
  std::vector<Vec3f> normals(image.depth.size(), Vec3f::Zero());
  std::atomic<std::uint64_t> hits{0}, evaluations{0};
  progress_begin(o.progress, "render", static_cast<std::uint64_t>(o.height), "rows");
  parallel_for_ranges(0, static_cast<std::size_t>(o.height), 4, [&](std::size_t y0, std::size_t y1) {
    std::uint64_t local_hits = 0, local_evaluations = 0;
    for (std::size_t y = y0; y < y1; ++y) {
      for (int x = 0; x < o.width; ++x) {
        const Vec3f d = camera.direction(x, static_cast<int>(y));
        float t0 = 0, t1 = 0;
        if (!clip_to_box(camera.eye(), d, box, t0, t1)) continue;
        const auto hit = surface.intersect(camera.eye(), d, t0, t1);
        if (!hit) continue;
        const std::size_t i = y * static_cast<std::size_t>(o.width) + static_cast<std::size_t>(x);
        image.depth[i] = hit->t;
        normals[i] = hit->normal;
        ++local_hits;
        local_evaluations += static_cast<std::uint64_t>(hit->evaluations);
      }
    }
    hits += local_hits;
    evaluations += local_evaluations;
    progress_advance(o.progress, y1 - y0);
  });
  progress_end(o.progress);

  // Shading needs the depth range for the depth mode: a second, cheap pass.
  float near = std::numeric_limits<float>::infinity(), far = 0;
  for (float t : image.depth) {
    if (std::isfinite(t)) {
      near = std::min(near, t);
      far = std::max(far, t);
    }
  }
  for (std::size_t i = 0; i < image.depth.size(); ++i) {
    if (!std::isfinite(image.depth[i])) continue;
    const Vec3f& n = normals[i];
    float r = 0, g = 0, b = 0;
    switch (o.shade) {
      case Shade::kLambert: {
        // A headlight: the light at the eye, so every visible surface is lit.
        const int x = static_cast<int>(i % static_cast<std::size_t>(o.width));
        const int y = static_cast<int>(i / static_cast<std::size_t>(o.width));
        const float c = 0.15f + 0.85f * std::abs(n.dot(camera.direction(x, y)));
        r = g = b = c;
        break;
      }
      case Shade::kNormal:
        r = 0.5f * (n.x() + 1);
        g = 0.5f * (n.y() + 1);
        b = 0.5f * (n.z() + 1);
        break;
      case Shade::kDepth: {
        const float v = far > near ? (image.depth[i] - near) / (far - near) : 0.0f;
        r = g = b = 1.0f - 0.8f * v;
        break;
      }
    }
    image.rgb[3 * i] = to_byte(r);
    image.rgb[3 * i + 1] = to_byte(g);
    image.rgb[3 * i + 2] = to_byte(b);
  }
  if (stats != nullptr) {
    stats->build_seconds = build_seconds;
    stats->render_seconds = seconds_since(start);
    stats->rays = static_cast<std::uint64_t>(o.width) * static_cast<std::uint64_t>(o.height);
    stats->hits = hits;
    stats->evaluations = evaluations;
  }
  return image;
}

}  // namespace sspc
