// Normal estimation and consistent orientation (the patch descriptors of Hubo et al. 2007,
// §4.2.2, are histograms of normals).
//
// Normals are estimated by principal component analysis of each point's k nearest neighbours
// and oriented consistently by propagation along a minimum spanning tree of the neighbour graph
// with edge cost 1 − |n_i·n_j| (Hoppe, DeRose, Duchamp, McDonald, Stuetzle: "Surface
// reconstruction from unorganized points", SIGGRAPH 1992, section 3.3), or towards a viewpoint.
#pragma once

#include <optional>

#include "sspc/point_cloud.hpp"
#include "sspc/progress.hpp"
#include "sspc/status.hpp"

namespace sspc {

// auto: keep the file's normals when it has them, estimate otherwise.
enum class NormalMode { kAuto, kKeep, kEstimate };

struct NormalOptions {
  NormalMode mode = NormalMode::kAuto;
  int k = 16;                          // neighbours for the PCA, 3..256
  std::optional<Vec3f> viewpoint;      // orient towards this point instead of propagating
  Progress* progress = nullptr;
};

// Estimates unit normals with PCA over the k nearest neighbours, unoriented (sign arbitrary).
// Points whose neighbourhood is degenerate get the normal of the smallest-variance axis all the
// same; a cloud of fewer than 3 points is an error.
Status estimate_normals(PointCloud& cloud, const NormalOptions& options);

// Flips normals so they agree: towards `options.viewpoint` when given, otherwise by Hoppe's
// minimum-spanning-tree propagation, one tree per connected component, each seeded at its
// highest point with a normal facing +z (outwards for a closed object, up for terrain).
Status orient_normals(PointCloud& cloud, const NormalOptions& options);

// What `--normals` asks: keep, estimate and orient, or (auto) whichever applies. kKeep on a
// cloud without normals is an error.
Status ensure_normals(PointCloud& cloud, const NormalOptions& options);

}  // namespace sspc
