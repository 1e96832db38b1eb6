// Marching a ray through an MLS surface (render/mls_surface.hpp), over one surface or over the
// bricks of a scene (render/brick_scene.hpp): the one march both use, so that a scene held in
// bricks samples a ray where the surface of the whole cloud does and finds the same hits.
//
// The march samples f(x) = n(x) · (x − a(x)) along the ray: across space near no point in one
// step, near points in steps of at least h/2 (up to 90% of |f|, the distance to the local
// plane), watching its sign; once f changes sign, regula falsi finds the root inside that
// bracket. Where it starts again after a stretch near no point it starts on a lattice of h/2
// steps along the ray, t = k · h/2, and not where that stretch was found to end: how far a step
// may skip depends on how the points are laid out in cells (the whole cloud's grid or a brick's),
// and a sample where the stretch ends would make the samples that follow, and on a rough surface
// the crossing found, depend on it. Rendered in bricks, dragon_scans' level-9 decode scored
// 33.6 dB against the same cloud rendered whole before the lattice (image PSNR over the hit
// pixels, 0.19% of pixels hit in one only); a 1% change of the bandwidth scores 34.2 dB.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>

#include "sspc/point_cloud.hpp"

namespace sspc::render {

struct SurfaceHit {
  float t = 0;        // along the ray, whose direction is a unit vector
  Vec3f normal;       // unit, facing the ray's origin
  float support = 0;  // Σ weights at the hit: how much data the surface rests on there
  int evaluations = 0;
};

namespace march {

// Refinement steps once a crossing is bracketed, and the precision they stop at, in
// bandwidths: far below a pixel's footprint at any useful zoom.
inline constexpr int kMaxIterations = 12;
inline constexpr float kTolerance = 1e-3f;
// |f| at an accepted root, in bandwidths: a continuous f is within about kTolerance·h of 0 when
// the refinement stops; one that jumped is far from it.
inline constexpr float kRootTolerance = 0.05f;
// A ray gives up after this many samples of f: far more than any surface needs (a ray grazing
// autzen's 1.3 km of ground in half-bandwidth steps takes about 5,000), and a bound on the work
// a ray can cost whatever the data.
inline constexpr int kMaxSamples = 1 << 16;
// Every step advances t by at least this many units in the last place of the ray's coordinates,
// so that a bandwidth below float32's resolution at the ray's distance cannot stall the march.
inline constexpr float kMinStepUlps = 4.0f;
// Samples in a row where the surface is undefined before the march measures how far it may skip
// (doubled after each measurement that allowed no skip). After 4, the measuring cost dragon_scans
// 10% of its rays per second uncompressed and 15% compressed; after 16, 0% and 5%; after 32,
// nothing measurable (1024², median of 3, 1.39 against 1.37 Mrays/s compressed), while a sparse
// cloud of tiny spacing (a fuzzer's 12 points, some 2e-7 apart, 1.5 across) renders 1024² in
// 0.15 s instead of taking 65,536 samples a ray.
inline constexpr int kMissesBeforeSkip = 32;

}  // namespace march

// The part [enter, leave] of the ray o + t·d that lies in the box [lo, hi] (slabs, in float as
// every grid here computes it); false when it misses the box.
inline bool clip_to_box(const Vec3f& lo, const Vec3f& hi, const Vec3f& o, const Vec3f& d, float& enter,
                        float& leave) {
  for (int k = 0; k < 3; ++k) {
    if (d[k] == 0) {
      if (o[k] < lo[k] || o[k] > hi[k]) return false;
      continue;
    }
    float near = (lo[k] - o[k]) / d[k], far = (hi[k] - o[k]) / d[k];
    if (near > far) std::swap(near, far);
    enter = std::max(enter, near);
    leave = std::min(leave, far);
  }
  return enter <= leave;
}

// Where the ray o + t·d leaves the box [lo, hi] that holds it: the nearest face ahead, at most
// `limit`.
inline float exit_from_box(const Vec3f& lo, const Vec3f& hi, const Vec3f& o, const Vec3f& d, float limit) {
  for (int k = 0; k < 3; ++k) {
    if (d[k] > 0) limit = std::min(limit, (hi[k] - o[k]) / d[k]);
    if (d[k] < 0) limit = std::min(limit, (lo[k] - o[k]) / d[k]);
  }
  return limit;
}

// The first root of f along o + t·d (|d| = 1) for t in [t_min, t_max], if any. `field` is the
// surface, asked at points of the ray:
//   bool evaluate(x, facing, a, n, support)  a(x), n(x) turned the way of `facing`, Σ w; false
//                                            where the surface is undefined;
//   float empty_until(o, d, t, t_max)        a t' > t such that no point is within reach of the
//                                            ray on [t, t'), or t itself where one may be;
//   float skip_until(o, d, t, t_max)         a t' ≥ t up to which the surface stays undefined
//                                            along the ray (a lower bound; t when unknown);
//   float bandwidth(), support_radius().
// `evaluations`, when given, gets the evaluations of f made, the ray hit or not (a hit's own
// count is also in SurfaceHit::evaluations).
template <typename Field>
std::optional<SurfaceHit> march_ray(const Field& field, const Vec3f& o, const Vec3f& d, float t_min, float t_max,
                                    std::uint64_t* evaluations = nullptr) {
  const float h = field.bandwidth();
  SurfaceHit hit;
  struct Count {  // adds the ray's evaluations to *evaluations however the march returns
    const SurfaceHit& hit;
    std::uint64_t* to;
    ~Count() {
      if (to != nullptr) *to += static_cast<std::uint64_t>(hit.evaluations);
    }
  } count{hit, evaluations};
  Vec3f a, n;
  float support = 0;
  // n(x) is turned the way of `facing`: the normal of the last sample, so that n keeps its sign
  // along the ray, or towards the ray's origin at the first sample after a gap.
  Vec3f facing = -d;
  const auto f_at = [&](float t, float& f) {
    ++hit.evaluations;
    const Vec3f x = o + t * d;
    if (!field.evaluate(x, facing, a, n, support)) return false;
    f = n.dot(x - a);
    return true;
  };
  // The smallest step that still moves t: a few units in the last place of |o| + |t|.
  const float ulp_step = march::kMinStepUlps * std::numeric_limits<float>::epsilon() *
                         (o.cwiseAbs().maxCoeff() + std::max(std::abs(t_min), std::abs(t_max)));
  const float step = std::max(0.5f * h, ulp_step);
  // The first lattice point at or after t (see the file's comment), k · step computed from k
  // alone, so that two marches that reach one lattice point by different ways hold the same t.
  const auto on_lattice = [step](float t) {
    const double k = std::ceil(static_cast<double>(t) / static_cast<double>(step));
    float at = static_cast<float>(k * static_cast<double>(step));
    if (at < t) at = static_cast<float>((k + 1) * static_cast<double>(step));
    return at;
  };
  float t = on_lattice(t_min);
  bool have_previous = false;
  float t_previous = 0, f_previous = 0;
  int samples = 0;
  int misses = 0;  // consecutive samples where the surface was undefined
  int skip_at = march::kMissesBeforeSkip;
  bool off_lattice = false;  // t is where a stretch near no point ends
  while (t <= t_max && ++samples <= march::kMaxSamples) {
    if (const float until = field.empty_until(o, d, t, t_max); until > t) {
      // No point within reach: leave in one step. (Cells near no point often come in runs, a
      // ray through a cloud's box crossing about 25 of them: the lattice waits for the run's end.)
      t = std::max(until, t + ulp_step);
      off_lattice = true;
      have_previous = false;
      facing = -d;
      continue;
    }
    if (off_lattice) {
      off_lattice = false;
      if (const float next = on_lattice(t); next != t) {
        t = next;
        continue;  // which may lie in a cell near no point again
      }
    }
    float f = 0;
    if (!f_at(t, f)) {
      // Undefined here. After a few such samples in a row, skip what lies farther than r from
      // every point (a cell far wider than r, as in a sparse cloud with a tiny spacing, would
      // otherwise cost a sample every h/2 across it).
      // The next lattice point: from one, the next one (t + step/2 rounds up to it).
      float next = on_lattice(t + 0.5f * step);
      if (++misses >= skip_at) {
        const float until = field.skip_until(o, d, t, t_max);
        if (until - t > step) {
          next = on_lattice(until);
        } else {
          skip_at = 2 * misses;
        }
      }
      t = next;
      have_previous = false;
      facing = -d;
      continue;
    }
    misses = 0;
    skip_at = march::kMissesBeforeSkip;
    if (have_previous && (f > 0) != (f_previous > 0)) {
      // f changed sign between the last two samples: the surface is in between. Regula falsi
      // with the Illinois rule (the end that stays is halved), a handful of evaluations.
      float lo = t_previous, f_lo = f_previous, hi = t, f_hi = f;
      float s = hi, f_s = f;
      bool at_s = true;  // a, n and support were last evaluated at s
      int kept = 0;      // which end stayed last: −1 lo, +1 hi
      facing = n;
      for (int it = 0; it < march::kMaxIterations; ++it) {
        s = lo - f_lo * (hi - lo) / (f_hi - f_lo);
        at_s = f_at(s, f_s);
        if (!at_s) break;
        if (std::abs(f_s) < march::kTolerance * h || hi - lo < march::kTolerance * h) break;
        if ((f_s > 0) == (f_lo > 0)) {
          lo = s;
          f_lo = f_s;
          if (kept == 1) f_hi *= 0.5f;
          kept = 1;
        } else {
          hi = s;
          f_hi = f_s;
          if (kept == -1) f_lo *= 0.5f;
          kept = -1;
        }
      }
      // A root of f, not a jump of it across the bracket (where the normals turn by more than a
      // right angle between two samples, f may change sign without passing through 0).
      if (at_s && s >= t_min && s <= t_max && std::abs(f_s) <= march::kRootTolerance * h) {
        hit.t = s;
        hit.normal = n.dot(d) > 0 ? Vec3f(-n) : n;
        hit.support = support;
        return hit;
      }
    }
    have_previous = true;
    t_previous = t;
    f_previous = f;
    facing = n;
    // At least half the bandwidth, and up to 90% of the distance to the local plane (along the
    // ray the plane is at least that far): a surface is found unless two crossings lie closer
    // than the step. The last sample is at t_max, so a crossing just before it is not lost.
    t += std::max(step, 0.9f * std::abs(f));
    if (t > t_max && t_previous < t_max) t = t_max;
  }
  return std::nullopt;
}

}  // namespace sspc::render
