#include "encoder/descriptor.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <vector>

namespace sspc {

namespace {

int bin_of(float v, float stretch, float inv_tanh, int bins) {
  const float s = std::tanh(stretch * std::clamp(v, -1.0f, 1.0f)) * inv_tanh;  // in [-1, 1]
  const int b = static_cast<int>((s + 1.0f) * 0.5f * static_cast<float>(bins));
  return std::clamp(b, 0, bins - 1);
}

void cumulative(const std::vector<float>& histogram, float total, float* out) {
  float running = 0;
  for (std::size_t i = 0; i + 1 < histogram.size(); ++i) {
    running += histogram[i];
    out[i] = running / total;
  }
}

}  // namespace

void compute_descriptor(std::span<const Vec3f> canonical_normals, const DescriptorParams& params,
                        std::span<float> out) {
  const int bins = params.bins;
  assert(static_cast<int>(out.size()) == params.dimension());
  std::vector<float> hx(static_cast<std::size_t>(bins), 0.0f);
  std::vector<float> hy(static_cast<std::size_t>(bins), 0.0f);
  const float inv_tanh = 1.0f / std::tanh(params.stretch);
  for (const Vec3f& n : canonical_normals) {
    hx[static_cast<std::size_t>(bin_of(n.x(), params.stretch, inv_tanh, bins))] += 1.0f;
    hy[static_cast<std::size_t>(bin_of(n.y(), params.stretch, inv_tanh, bins))] += 1.0f;
  }
  float total = static_cast<float>(canonical_normals.size());
  if (canonical_normals.empty()) {
    hx[static_cast<std::size_t>(bins / 2)] = hy[static_cast<std::size_t>(bins / 2)] = 1.0f;
    total = 1.0f;
  }
  const std::size_t half = static_cast<std::size_t>(bins - 1);
  cumulative(hx, total, out.data());
  cumulative(hy, total, out.data() + half);
}

float match_distance(std::span<const float> a, std::span<const float> b) {
  assert(a.size() == b.size());
  float d = 0;
  for (std::size_t i = 0; i < a.size(); ++i) d += std::abs(a[i] - b[i]);
  return d;
}

}  // namespace sspc
