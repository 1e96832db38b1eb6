#include "render/camera.hpp"

#include <cmath>
#include <numbers>

namespace sspc::render {

PinholeCamera::PinholeCamera(const Camera& c, int width, int height)
    : eye_(c.eye), width_(width), height_(height) {
  forward_ = (c.target - c.eye).normalized();
  right_ = forward_.cross(c.up).normalized();
  down_ = forward_.cross(right_);  // right × forward would be up
  const float half = std::tan(0.5f * c.fov_degrees * std::numbers::pi_v<float> / 180.0f);
  scale_ = 2.0f * half / static_cast<float>(height);
}

Vec3f PinholeCamera::direction(int x, int y) const {
  const float u = (static_cast<float>(x) + 0.5f - 0.5f * static_cast<float>(width_)) * scale_;
  const float v = (static_cast<float>(y) + 0.5f - 0.5f * static_cast<float>(height_)) * scale_;
  return (forward_ + u * right_ + v * down_).normalized();
}

}  // namespace sspc::render
