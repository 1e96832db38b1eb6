// Normals on the TEST cloud for the REF→TEST point-to-plane error (MPEG D2), derived from REF's
// normals as mpeg-pcc-dmetric does (source/pcc_distortion.cpp, scaleNormals, with its default
// --averageNormals=1): a TEST point takes the mean normal of the REF points whose nearest group
// contains it; a TEST point that no REF point chose takes the mean normal of its own nearest REF
// group. The means are not renormalised, as in pc_error, so that sspc's D2 is pc_error's D2.
#pragma once

#include <span>
#include <vector>

#include "eval/nearest_groups.hpp"
#include "sspc/point_cloud.hpp"

namespace sspc::eval {

// `ref_normals`: REF's normals (one per REF point). `ref_to_test`: for each REF point its nearest
// group in TEST; `test_to_ref`: for each TEST point its nearest group in REF. Returns one normal
// per TEST point, bit-identical whatever the thread count.
std::vector<Vec3d> transfer_normals(std::span<const Vec3f> ref_normals,
                                    const NearestGroups& ref_to_test,
                                    const NearestGroups& test_to_ref);

}  // namespace sspc::eval
