// Point-to-plane ICP (Chen & Medioni 1992; linearised as in Low 2004), with a small
// point-to-point term, refining the alignment
// of a candidate patch to a representative from their canonical frames (paper §4.3).
// Both are in their canonical frames already, so the start is the identity and the
// refinement is small: a handful of iterations.
#pragma once

#include <span>

#include "encoder/codeword_surface.hpp"
#include "geometry/rigid_transform.hpp"

namespace sspc::codec {

struct IcpOptions {
  int max_iterations = 8;
  float max_pair_distance = 0;  // pairs farther apart are ignored; 0: no limit
  float converged_step = 0;     // stop when the translation step and the rotation step's
                                // displacement at `lever_arm` are both smaller; 0: never
  float lever_arm = 1;          // the patch radius, typically
  // Weight of the point-to-point term added to the point-to-plane one. Point-to-plane alone
  // lets a patch slide freely along flat parts, where any offset fits; the metric the codec is
  // judged by (nearest-point RMS) does see the slide, and a small point-to-point term pins it.
  float point_to_point_weight = 0.1f;
  // Give up (and report the RMS so far) when, from the fifth iteration on, the point-to-plane
  // RMS is still above this; 0: never. A caller that rejects alignments above some error can
  // stop hopeless ones early: the point-to-plane residual never exceeds the distance to the
  // nearest point.
  float abandon_rms = 0;
};

struct IcpResult {
  RigidTransform target_from_source;
  int iterations = 0;
  float rms = 0;  // point-to-plane RMS of the last iteration's pairs
};

// Aligns `source` points onto `target`'s surface. Deterministic.
IcpResult align_point_to_plane(std::span<const Vec3f> source, const CodewordSurface& target,
                               const IcpOptions& options);

}  // namespace sspc::codec
