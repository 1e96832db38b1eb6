// Distortion metrics between a reference cloud and a test cloud (paper §6), MPEG's D1/D2 PSNR
// as its metric software (pc_error) defines them, and the colour PSNR it defines, computed in
// RGB. Formulas and sources are in docs/METRICS.md.
#pragma once

#include <cstdint>
#include <optional>
#include <span>

#include "sspc/point_cloud.hpp"
#include "sspc/progress.hpp"
#include "sspc/status.hpp"

namespace sspc {

struct EvalOptions {
  std::optional<double> peak;   // MPEG PSNR peak; default: REF's bounding-box diagonal
  Progress* progress = nullptr;
};

// One direction A→B: over A's points, the distance to the nearest point of B.
struct DirectedError {
  double rms = 0;          // sqrt(mean d²), d point-to-point
  double hausdorff = 0;    // max d
  double mse_d1 = 0;       // mean d² (point-to-point)
  double mse_d2 = 0;       // mean of the error projected on the normal (point-to-plane)
  bool has_d2 = false;
  // Mean over A's points and over R, G, B of (a's colour − its nearest B colour)², in 8-bit
  // levels squared; the nearest colour is the mean over an equidistant group.
  double mse_colour = 0;
  bool has_colour = false;
};

struct EvalReport {
  std::uint64_t ref_points = 0;
  std::uint64_t test_points = 0;
  double ref_diagonal = 0;           // d_B, bounding-box diagonal of REF
  double peak = 0;                   // the peak used for D1/D2
  DirectedError ref_to_test;
  DirectedError test_to_ref;
  double rms_max = 0;                // max of the two RMS
  double hausdorff = 0;              // symmetric Hausdorff distance
  double psnr_paper = 0;             // 20 log10(d_B / rms_max); +inf when identical
  double d1_mse = 0;                 // max of the two directions' D1 MSE
  double d1_psnr = 0;                // 10 log10(3 peak² / d1_mse) as pc_error computes it
  bool has_d2 = false;               // REF has normals
  double d2_mse = 0;
  double d2_psnr = 0;
  bool has_normal_error = false;     // both clouds have normals
  double normal_angle_mean_deg = 0;  // over TEST's points vs their nearest REF point's normal
  double normal_angle_p95_deg = 0;
  std::uint64_t normal_angle_points = 0;  // TEST points with an angle (both normals non-zero)
  bool has_colour = false;                // both clouds have colours
  double colour_mse = 0;                  // max of the two directions' colour MSE
  double colour_psnr = 0;                 // 10 log10(255² / colour_mse); +inf when 0
};

// REF is the original, TEST the decoded cloud; colour errors are reported when both have
// colours. Errors (kInvalidArgument): an empty cloud, a cloud that fails PointCloud::validate(),
// a given peak that is not positive and finite, no peak given and REF's bounding-box diagonal 0.
// kResourceExhausted: a cloud of 2^32 points or more. Results are bit-identical whatever the
// thread count.
StatusOr<EvalReport> evaluate(const PointCloud& ref, const PointCloud& test,
                              const EvalOptions& options = {});

// REF and TEST re-expressed about one common origin, the centre of REF's bounding box, worked
// out in double from the files' own values (ReadOptions::positions_f64, index for index with
// each cloud's positions; kInvalidArgument otherwise): every position becomes (stored - origin)
// rounded to float. Every metric is unchanged by a translation common to both clouds, but
// float32 is not: at a coordinate c it keeps steps of ulp(c), so clouds kept at georeferenced
// coordinates are compared at their own detail only once moved near the origin. Returns the
// origin.
StatusOr<Vec3d> move_to_common_origin(PointCloud& ref, std::span<const Vec3d> ref_stored,
                                      PointCloud& test, std::span<const Vec3d> test_stored);

// The paper's PSNR (§6): 20·log10(diagonal / rms); +inf when rms is 0.
double paper_psnr(double diagonal, double rms);

// MPEG's geometry PSNR as pc_error computes it: 10·log10(3·peak² / mse), the 3 being the number
// of coordinates; +inf when mse is 0.
double mpeg_geometry_psnr(double mse, double peak);

// Colour PSNR of 8-bit channels: 10·log10(255² / mse), the mse per channel; +inf when mse is 0.
double colour_psnr(double mse);

// Bits per point of a compressed file of `file_bytes` bytes for a cloud of `points` points.
inline double bits_per_point(std::uint64_t file_bytes, std::uint64_t points) {
  return points == 0 ? 0.0 : 8.0 * static_cast<double>(file_bytes) / static_cast<double>(points);
}

}  // namespace sspc
