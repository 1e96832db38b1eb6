// A pinhole camera's primary rays (pbrt's perspective camera, without lens): the pixel centre
// (x + ½, y + ½) through the image plane at distance 1, y down the image.
#pragma once

#include "sspc/render.hpp"

namespace sspc::render {

class PinholeCamera {
 public:
  PinholeCamera(const Camera& camera, int width, int height);
  // The unit direction of the ray through pixel (x, y); the origin is the eye.
  Vec3f direction(int x, int y) const;
  const Vec3f& eye() const { return eye_; }

 private:
  Vec3f eye_, forward_, right_, down_;
  float scale_;  // image-plane half-height per pixel row
  int width_, height_;
};

}  // namespace sspc::render
