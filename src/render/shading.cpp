#include "render/shading.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "sspc/neighbours.hpp"

namespace sspc::render {

namespace {

std::uint8_t to_byte(float v) {
  return static_cast<std::uint8_t>(std::clamp(v, 0.0f, 1.0f) * 255.0f + 0.5f);
}

// A well-spread colour per code word (the paper's Figure 6): a hash of the index into a hue,
// saturated and bright enough to tell neighbours apart.
Vec3f id_colour(std::uint32_t id) {
  std::uint32_t v = id * 0x9E3779B1u;
  v ^= v >> 15;
  v *= 0x85EBCA77u;
  v ^= v >> 13;
  const float hue = static_cast<float>(v & 0xFFFFu) / 65536.0f * 6.0f;
  const float f = hue - std::floor(hue);
  const float s = 0.55f + 0.35f * static_cast<float>((v >> 16) & 0xFFu) / 255.0f;
  const float lo = 1 - s, mid_up = 1 - s * (1 - f), mid_down = 1 - s * f;
  switch (static_cast<int>(hue)) {
    case 0: return {1, mid_up, lo};
    case 1: return {mid_down, 1, lo};
    case 2: return {lo, 1, mid_up};
    case 3: return {lo, mid_down, 1};
    case 4: return {mid_up, lo, 1};
    default: return {1, lo, mid_down};
  }
}

}  // namespace

std::vector<std::pair<int, int>> hilbert_tiles(int width, int height) {
  const int tx = (width + kTile - 1) / kTile, ty = (height + kTile - 1) / kTile;
  int n = 1;
  while (n < tx || n < ty) n *= 2;
  std::vector<std::pair<int, int>> tiles;
  tiles.reserve(static_cast<std::size_t>(tx) * static_cast<std::size_t>(ty));
  // Position d along the curve over the n × n square, to (x, y): quadrant by quadrant from the
  // coarsest, each step rotating the sub-square so that the curve enters and leaves it at the
  // corners its neighbours meet. Tiles of the square outside the image are skipped.
  const auto total = static_cast<std::uint64_t>(n) * static_cast<std::uint64_t>(n);
  for (std::uint64_t d = 0; d < total; ++d) {
    std::uint64_t rest = d;
    int x = 0, y = 0;
    for (int s = 1; s < n; s *= 2) {
      const int rx = static_cast<int>((rest / 2) & 1u);
      const int ry = static_cast<int>((rest ^ static_cast<std::uint64_t>(rx)) & 1u);
      if (ry == 0) {
        if (rx == 1) {
          x = s - 1 - x;
          y = s - 1 - y;
        }
        std::swap(x, y);
      }
      x += s * rx;
      y += s * ry;
      rest /= 4;
    }
    if (x < tx && y < ty) tiles.emplace_back(x * kTile, y * kTile);
  }
  return tiles;
}

Status check_frame(const FrameOptions& o) {
  if (o.width < 1 || o.height < 1 || o.width > 16384 || o.height > 16384) {
    return invalid_argument("image size must be 1..16384 pixels per side");
  }
  if (!(o.camera.fov_degrees > 0.1f && o.camera.fov_degrees < 179.0f)) {
    return invalid_argument("field of view must be in (0.1, 179) degrees");
  }
  const Vec3f forward = o.camera.target - o.camera.eye;
  if (!o.camera.eye.allFinite() || !o.camera.target.allFinite() || !o.camera.up.allFinite() ||
      !(forward.norm() > 0) || !(forward.normalized().cross(o.camera.up).norm() > 1e-6f)) {
    return invalid_argument("the camera needs distinct eye and target and an up vector not along the view");
  }
  if (!(o.level_of_detail >= 0 && o.level_of_detail <= 64)) {
    return invalid_argument("level of detail must be 0 (off) to 64 pixels");
  }
  return Status();
}

Status check_scene(const SceneOptions& o) {
  if (!(o.bandwidth > 0.1f && o.bandwidth < 100.0f)) return invalid_argument("bandwidth must be in (0.1, 100) spacings");
  if (o.memory_budget_bytes == 0) return invalid_argument("the memory budget must be positive");
  return Status();
}

Status check_renderable(const PointCloud& cloud, const SceneOptions& o) {
  SSPC_RETURN_IF_ERROR(check_scene(o));
  SSPC_RETURN_IF_ERROR(cloud.validate());
  if (cloud.empty()) return invalid_argument("the cloud is empty");
  if (!cloud.has_normals()) return invalid_argument("rendering needs normals (estimate them first)");
  return Status();
}

StatusOr<double> surface_spacing(const PointCloud& cloud) {
  SSPC_RETURN_IF_ERROR(check_coordinate_range(cloud.positions));
  const double spacing = ladder_spacing(nominal_spacing(cloud));
  SSPC_RETURN_IF_ERROR(check_geometry_range(cloud.positions, spacing));
  return spacing;
}

double ladder_spacing(double spacing) {
  if (!(spacing > 0) || !std::isfinite(spacing)) return spacing;
  return std::exp2(std::round(std::log2(spacing) * kSpacingLadder) / kSpacingLadder);
}

StatusOr<UnitRay> UnitRay::make(const Vec3f& origin, const Vec3f& direction, float t_min, float t_max) {
  const float length = direction.norm();
  if (!origin.allFinite() || !direction.allFinite() || !(length > 0) || !std::isfinite(length)) {
    return invalid_argument("intersect: the ray needs a finite origin and a finite, non-zero direction");
  }
  if (std::isnan(t_min) || std::isnan(t_max)) return invalid_argument("intersect: t_min and t_max must not be NaN");
  UnitRay ray;
  ray.origin = origin;
  ray.direction = direction / length;
  ray.scale = length;
  ray.t_min = t_min * length;
  ray.t_max = t_max * length;
  return ray;
}

Frame::Frame(int width, int height, Shade mode, const PinholeCamera& camera) : mode_(mode), camera_(camera) {
  image_.width = width;
  image_.height = height;
  image_.depth.assign(static_cast<std::size_t>(width) * static_cast<std::size_t>(height),
                      std::numeric_limits<float>::infinity());
  image_.rgb.assign(image_.depth.size() * 3, 0);
}

void Frame::set(int x, int y, float t, const Vec3f& n, std::uint32_t id) {
  const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(image_.width) + static_cast<std::size_t>(x);
  image_.depth[i] = t;
  if (mode_ == Shade::kDepth) return;  // finish() shades it
  // A headlight: the light at the eye, so every visible surface is lit.
  const float lambert = 0.15f + 0.85f * std::abs(n.dot(camera_.direction(x, y)));
  Vec3f c = Vec3f::Zero();
  switch (mode_) {
    case Shade::kLambert: c = Vec3f::Constant(lambert); break;
    case Shade::kNormal: c = 0.5f * (n + Vec3f::Ones()); break;
    case Shade::kCodeword: c = lambert * id_colour(id); break;
    case Shade::kDepth: break;
  }
  for (int a = 0; a < 3; ++a) image_.rgb[3 * i + static_cast<std::size_t>(a)] = to_byte(c[a]);
}

Image Frame::finish() && {
  if (mode_ == Shade::kDepth) {
    float near = std::numeric_limits<float>::infinity(), far = 0;
    for (float t : image_.depth) {
      if (std::isfinite(t)) {
        near = std::min(near, t);
        far = std::max(far, t);
      }
    }
    for (std::size_t i = 0; i < image_.depth.size(); ++i) {
      if (!std::isfinite(image_.depth[i])) continue;
      const float c = 1.0f - 0.8f * (far > near ? (image_.depth[i] - near) / (far - near) : 0.0f);
      for (std::size_t a = 0; a < 3; ++a) image_.rgb[3 * i + a] = to_byte(c);
    }
  }
  return std::move(image_);
}

}  // namespace sspc::render
