// The writer's choice of the header's resample byte by measurement (docs/FORMAT_NOTES.md,
// "Resampling"): the geometry as a reader decodes it, resampled with each candidate m, against
// the source around a sample of patch centres, under the paper's point-to-point error.
//
// Whether resampling helps depends on the data as well as on the grid: at a grid of 1.2
// spacings projecting each point on its code word's fit (m = 1) gains 0.45-0.67 dB on bunny
// and igea and loses 0.46 dB on dragon_scans, whose overlapping scans lie in layers that one
// fitted surface merges. A count rule (resample_for) cannot tell them apart; the source can.
#pragma once

#include <memory>
#include <span>
#include <vector>

#include "sspc/compressed_model.hpp"
#include "sspc/point_cloud.hpp"
#include "sspc/status.hpp"

namespace sspc::codec {

// Points of the source near some of the model's patch centres: a tile's cloud (with the
// margin of its neighbours' points a tiled encode gives it) and the centres to measure in it.
struct DistortionSample {
  std::shared_ptr<const PointCloud> source;
  std::vector<Vec3f> centres;
};

// What the paper's error of each candidate m ∈ [0, max_m] came to, as mean squared distances
// of the worse direction (source to decoded, decoded to source), over the spheres of `radius`
// around the centres; `geometry` is decoded with DecodeOptions::resample = m.
struct ResampleMeasurement {
  std::vector<double> error;  // per m; +inf where nothing was measured
  int chosen = 0;
};

// The m the header should ask for: the candidate of least error, if it is at least 2% (about
// 0.09 dB) below that of the points as stored; 0 otherwise, or when no sample holds points.
StatusOr<ResampleMeasurement> measure_resample(const CompressedModel& geometry,
                                               std::span<const DistortionSample> samples, float radius,
                                               int max_m);

}  // namespace sspc::codec
