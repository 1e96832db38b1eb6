// What a ray found, per pixel, and how it becomes a colour: shared by the uncompressed and the
// compressed renderer so their images compare pixel for pixel.
#pragma once

#include <cstdint>
#include <vector>

#include "render/camera.hpp"
#include "sspc/render.hpp"

namespace sspc::render {

// Option checks common to both renderers.
Status check_options(const RenderOptions& options);

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

}  // namespace sspc::render
