// EncodedModels built in code for the container and decoder tests: deterministic on every
// platform (a fixed mt19937 stream mapped to floats by hand, not through the library's
// implementation-defined distributions), so the golden file can be regenerated anywhere.
#pragma once

#include <cmath>
#include <cstdint>
#include <random>

#include <Eigen/Geometry>

#include "format/encoded_model.hpp"

namespace sspc::test {

class TestRng {
 public:
  explicit TestRng(std::uint32_t seed) : engine_(seed) {}
  // Uniform in [0, 1) with 24 random bits.
  float unit() {
    return static_cast<float>(static_cast<std::uint32_t>(engine_()) >> 8) * (1.0f / 16777216.0f);
  }
  float range(float lo, float hi) { return lo + (hi - lo) * unit(); }
  std::uint32_t below(std::uint32_t n) { return static_cast<std::uint32_t>(engine_() % n); }
  Eigen::Matrix3f rotation() {
    Eigen::Quaternionf q(range(-1, 1), range(-1, 1), range(-1, 1), range(-1, 1));
    if (q.norm() < 1e-3f) q = Eigen::Quaternionf::Identity();
    return q.normalized().toRotationMatrix();
  }

 private:
  std::mt19937 engine_;
};

struct ModelShape {
  int side = 24;  // source points per side of the square (spacing 1)
  float patch_radius = 4.0f;
  float centre_step = 3.0f;  // distance between neighbouring patch centres
  int codewords = 5;
  bool normals = true;
  bool colours = true;
  bool full_rotations = false;  // random 3D rotations instead of rotations about the normal
  std::uint32_t seed = 7;
};

// A plane z = 0 sampled at unit spacing, cut into patches on a grid of centres; the code words
// are jittered discs of radius patch_radius, each patch an instance of one of them rotated about
// the normal (or anywhere, with full_rotations) and placed at its centre.
inline codec::EncodedModel make_plane_model(const ModelShape& s) {
  TestRng rng(s.seed);
  codec::EncodedModel m;
  m.patch_radius = s.patch_radius;
  m.coverage_radius = s.centre_step * 0.75f;
  m.spacing = 1.0f;
  m.source_points = static_cast<std::uint64_t>(s.side) * static_cast<std::uint64_t>(s.side);
  m.has_normals = s.normals;
  m.has_colours = s.colours;
  const float extent = static_cast<float>(s.side - 1);
  m.bounds = Box3f(Vec3f(0, 0, -0.1f), Vec3f(extent, extent, 0.1f));
  const int reach = static_cast<int>(std::ceil(s.patch_radius));
  for (int c = 0; c < s.codewords; ++c) {
    codec::Codeword w;
    for (int y = -reach; y <= reach; ++y) {
      for (int x = -reach; x <= reach; ++x) {
        const Vec3f p(static_cast<float>(x) + rng.range(-0.3f, 0.3f),
                      static_cast<float>(y) + rng.range(-0.3f, 0.3f), rng.range(-0.05f, 0.05f));
        if (p.norm() > s.patch_radius) continue;
        w.points.push_back(p);
        if (s.normals) {
          w.normals.push_back(
              Vec3f(rng.range(-0.1f, 0.1f), rng.range(-0.1f, 0.1f), 1).normalized());
        }
        if (s.colours) {
          w.colours.push_back(Rgb8{static_cast<std::uint8_t>(rng.below(256)),
                                  static_cast<std::uint8_t>(rng.below(256)),
                                  static_cast<std::uint8_t>(rng.below(256))});
        }
      }
    }
    m.codebook.push_back(std::move(w));
  }
  // Centres row by row: a simple spatial order.
  for (float y = 0; y <= extent + 1e-3f; y += s.centre_step) {
    for (float x = 0; x <= extent + 1e-3f; x += s.centre_step) {
      codec::PatchInstance p;
      p.codeword = rng.below(static_cast<std::uint32_t>(s.codewords));
      if (s.full_rotations) {
        p.world_from_codeword.rotation = rng.rotation();
      } else {
        p.world_from_codeword.rotation =
            Eigen::AngleAxisf(rng.range(-3.14159f, 3.14159f), Vec3f::UnitZ()).toRotationMatrix();
      }
      p.world_from_codeword.translation = Vec3f(x, y, 0);
      m.patches.push_back(p);
    }
  }
  return m;
}

}  // namespace sspc::test
