// The writer's choice of the header's resample byte by measurement (docs/FORMAT_NOTES.md,
// "Resampling"): the geometry as a reader decodes it, resampled with each candidate m, against
// the source around a sample of patch centres, under the paper's point-to-point error.
//
// Whether resampling helps depends on the data as well as on the grid: at a grid of 1.2
// spacings projecting each point on its code word's fit (m = 1) gains 0.45-0.67 dB on bunny
// and igea and loses 0.46 dB on dragon_scans, whose overlapping scans lie in layers that one
// fitted surface merges. A count rule (resample_for) cannot tell them apart; the source can.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "sspc/compressed_model.hpp"
#include "sspc/point_cloud.hpp"
#include "sspc/status.hpp"

namespace sspc::codec {

// What the paper's error of each candidate m ∈ [0, max_m] comes to, as the mean squared
// distance of the worse direction (source to decoded, decoded to source) over spheres of
// `radius` around sampled centres, `geometry` decoded with DecodeOptions::resample = m. Fed one
// source at a time (a tile of a tiled encode, with the margin of its neighbours' points), so
// that no more than one is held.
class ResampleMeter {
 public:
  ResampleMeter(const CompressedModel& geometry, float radius, int max_m);

  // Measures the spheres around `centres` against `source`.
  Status add(const PointCloud& source, std::span<const Vec3f> centres);

  // Per m: +inf where nothing was measured.
  std::vector<double> errors() const;
  // The m the header should ask for: the candidate of least error, if it is at least 2% (about
  // 0.09 dB) below that of the points as stored; 0 otherwise, or when no sphere held points.
  int chosen() const;

 private:
  struct Sums {
    double to_decoded = 0, to_source = 0;
    std::uint64_t source_points = 0, decoded_points = 0;
  };
  const CompressedModel& geometry_;
  float radius_;
  std::size_t candidates_;
  std::vector<Sums> totals_;
};

}  // namespace sspc::codec
