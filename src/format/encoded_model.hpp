// The compressed model in memory: what the encoder produces, the container writes and reads,
// and the decoder expands (paper §4.3: a code book of representative patches and, per patch, a
// code-word index and a rigid transform; the file in docs/FORMAT.md).
//
// Frames: a code word's points live in its own canonical frame, whose origin is the centre c
// of the representative patch it was taken from (not the centroid: the decoder needs the
// centre, see below). `world_from_codeword` of patch k maps that frame onto patch k.
//
// Regions: patch k's region centre is world_from_codeword.translation, i.e. where the code
// word's origin lands. By default a decoded model keeps, of each instance, the code word's
// points whose nearest region centre (among all patches) is that patch's own, ties to the lower
// patch index: the Voronoi cell of its centre. The encoder guarantees that every input point
// lies within `coverage_radius` of a region centre and that each code word holds the points
// within `patch_radius` (> coverage_radius) of its centre, so the cells are covered.
#pragma once

#include <cstdint>
#include <vector>

#include "format/metadata_section.hpp"
#include "geometry/rigid_transform.hpp"
#include "sspc/point_cloud.hpp"

namespace sspc::codec {

struct Codeword {
  std::vector<Vec3f> points;   // in the code word's frame, all within patch_radius of 0
  std::vector<Vec3f> normals;  // unit, same length as points, or empty when the model has none
  std::vector<Rgb8> colours;    // same length as points, or empty
};

struct PatchInstance {
  std::uint32_t codeword = 0;
  RigidTransform world_from_codeword;
  // The encoder built the code word from this patch's own points in this frame (not stored:
  // the writer re-expresses such code words in the frame a reader decodes, see
  // encoder/codeword_trim.hpp).
  bool representative = false;
  Vec3f region_centre() const { return world_from_codeword.translation; }
};

struct EncodedModel {
  float patch_radius = 0;     // code words hold points within this distance of their origin
  float coverage_radius = 0;  // every input point is within this distance of a region centre
  float spacing = 0;          // the input's nominal point spacing
  std::uint64_t source_points = 0;
  bool has_normals = false;
  bool has_colours = false;
  Box3f bounds;               // of the input points
  std::vector<Codeword> codebook;
  std::vector<PatchInstance> patches;  // in file order (the encoder sorts them spatially)
  ModelMetadata metadata;  // the origin of every position above, comments, CRS, LAS grid
};

}  // namespace sspc::codec
