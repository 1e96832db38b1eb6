#include "codec/codeword_surface.hpp"

#include <algorithm>
#include <cmath>

namespace sspc::codec {

CodewordSurface::CodewordSurface(std::span<const Vec3f> points, std::span<const Vec3f> normals,
                                 float bandwidth)
    : points_(points), normals_(normals), bandwidth_(bandwidth), tree_(points) {}

float CodewordSurface::mls_residual(const Vec3f& x, float* nearest_distance) const {
  std::uint32_t idx[kNeighbours];
  float d2[kNeighbours];
  const std::size_t n = tree_.knn(x, kNeighbours, idx, d2);
  if (n == 0) {
    if (nearest_distance != nullptr) *nearest_distance = std::numeric_limits<float>::infinity();
    return 0;
  }
  if (nearest_distance != nullptr) *nearest_distance = std::sqrt(d2[0]);
  const float inv_h2 = 1.0f / (bandwidth_ * bandwidth_);
  Vec3f a = Vec3f::Zero();
  Vec3f normal = Vec3f::Zero();
  float weight = 0;
  for (std::size_t j = 0; j < n; ++j) {
    // Relative to the nearest sample's weight, so that far queries do not underflow to 0/0.
    const float w = std::exp(-(d2[j] - d2[0]) * inv_h2);
    a += w * points_[idx[j]];
    normal += w * normals_[idx[j]];
    weight += w;
  }
  a /= weight;
  const float length = normal.norm();
  if (length <= 0) return (x - a).norm();
  return (normal / length).dot(x - a);
}

}  // namespace sspc::codec
