// sspc::evaluate: the distortion between an original cloud (REF) and a decoded one (TEST).
//
// Paper §6 (after Waschbüsch et al. 2004): PSNR = 20·log10(d_B / max(RMS(U,C), RMS(C,U))).
// MPEG D1/D2: mpeg-pcc-dmetric (pc_error) v0.14, source/pcc_distortion.cpp: per-direction MSEs,
// the symmetric MSE as their maximum, PSNR = 10·log10(3·peak² / MSE); colour the same way, in
// RGB, with PSNR = 10·log10(255² / MSE). All formulas, sources and the points where sspc departs
// from pc_error are in docs/METRICS.md.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>

#include "core/parallel.hpp"
#include "eval/colour_error.hpp"
#include "eval/directed_error.hpp"
#include "eval/nearest_groups.hpp"
#include "eval/normal_angle.hpp"
#include "eval/normal_transfer.hpp"
#include "sspc/metrics.hpp"
#include "sspc/neighbours.hpp"

namespace sspc {

double paper_psnr(double diagonal, double rms) {
  if (rms == 0) return std::numeric_limits<double>::infinity();
  return 20.0 * std::log10(diagonal / rms);
}

double mpeg_geometry_psnr(double mse, double peak) {
  if (mse == 0) return std::numeric_limits<double>::infinity();
  return 10.0 * std::log10(3.0 * peak * peak / mse);
}

double colour_psnr(double mse) {
  if (mse == 0) return std::numeric_limits<double>::infinity();
  return 10.0 * std::log10(255.0 * 255.0 / mse);
}

namespace {

Status check_cloud(const PointCloud& cloud, const char* name) {
  if (cloud.empty()) return invalid_argument(std::string(name) + " point cloud is empty");
  // KdTree3 indexes points with 32-bit integers.
  if (cloud.size() > std::numeric_limits<std::uint32_t>::max()) {
    return resource_exhausted(std::string(name) + " point cloud has " +
                              std::to_string(cloud.size()) +
                              " points; sspc eval handles at most 2^32 - 1");
  }
  return cloud.validate().with_context(std::string(name) + " point cloud");
}

StatusOr<double> choose_peak(const EvalOptions& options, double ref_diagonal) {
  if (options.peak.has_value()) {
    const double peak = *options.peak;
    if (!std::isfinite(peak) || peak <= 0) {
      return invalid_argument("PSNR peak must be a positive finite number, got " +
                              std::to_string(peak));
    }
    return peak;
  }
  if (!(ref_diagonal > 0)) {
    return invalid_argument(
        "REF's bounding-box diagonal is 0 (all its points coincide), so there is no default "
        "PSNR peak; give one");
  }
  return ref_diagonal;
}

}  // namespace

StatusOr<EvalReport> evaluate(const PointCloud& ref, const PointCloud& test,
                              const EvalOptions& options) {
  SSPC_RETURN_IF_ERROR(check_cloud(ref, "REF"));
  SSPC_RETURN_IF_ERROR(check_cloud(test, "TEST"));
  EvalReport report;
  report.ref_points = ref.size();
  report.test_points = test.size();
  report.ref_diagonal = bounding_box_diagonal(ref);
  SSPC_ASSIGN_OR_RETURN(report.peak, choose_peak(options, report.ref_diagonal));
  Progress* progress = options.progress;

  // nanoflann builds a tree on one thread; building the two at once uses two.
  progress_begin(progress, "eval: k-d trees", ref.size() + test.size());
  std::optional<eval::NearestGroupIndex> ref_index;
  std::optional<eval::NearestGroupIndex> test_index;
  parallel_invoke(
      [&] {
        ref_index.emplace(ref.positions);
        progress_advance(progress, ref.size());
      },
      [&] {
        test_index.emplace(test.positions);
        progress_advance(progress, test.size());
      });
  progress_end(progress);

  progress_begin(progress, "eval: nearest REF point of each TEST point", test.size());
  const eval::NearestGroups test_to_ref = ref_index->find(test.positions, progress);
  progress_end(progress);
  progress_begin(progress, "eval: nearest TEST point of each REF point", ref.size());
  const eval::NearestGroups ref_to_test = test_index->find(ref.positions, progress);
  progress_end(progress);

  report.has_d2 = ref.has_normals();
  if (report.has_d2) {
    // D2 REF→TEST projects on normals at TEST's points; pc_error derives them from REF's
    // normals rather than trusting the decoded cloud's own (eval/normal_transfer.hpp).
    progress_begin(progress, "eval: point-to-plane errors", ref.size() + test.size());
    const std::vector<Vec3d> test_normals =
        eval::transfer_normals(ref.normals, ref_to_test, test_to_ref);
    report.ref_to_test = eval::directed_error(ref.positions, test.positions, ref_to_test,
                                              std::span<const Vec3d>(test_normals));
    progress_advance(progress, ref.size());
    report.test_to_ref = eval::directed_error(test.positions, ref.positions, test_to_ref,
                                              std::span<const Vec3f>(ref.normals));
    progress_advance(progress, test.size());
    progress_end(progress);
  } else {
    report.ref_to_test = eval::directed_error(ref.positions, test.positions, ref_to_test,
                                              std::span<const Vec3f>());
    report.test_to_ref = eval::directed_error(test.positions, ref.positions, test_to_ref,
                                              std::span<const Vec3f>());
  }

  report.rms_max = std::max(report.ref_to_test.rms, report.test_to_ref.rms);
  report.hausdorff = std::max(report.ref_to_test.hausdorff, report.test_to_ref.hausdorff);
  report.psnr_paper = paper_psnr(report.ref_diagonal, report.rms_max);
  report.d1_mse = std::max(report.ref_to_test.mse_d1, report.test_to_ref.mse_d1);
  report.d1_psnr = mpeg_geometry_psnr(report.d1_mse, report.peak);
  if (report.has_d2) {
    report.d2_mse = std::max(report.ref_to_test.mse_d2, report.test_to_ref.mse_d2);
    report.d2_psnr = mpeg_geometry_psnr(report.d2_mse, report.peak);
  }

  report.has_colour = ref.has_colours() && test.has_colours();
  if (report.has_colour) {
    // The same nearest groups as the geometry: pc_error compares each point's colour with that
    // of the point D1 matched it to (the group's mean where several are equidistant).
    progress_begin(progress, "eval: colour errors", ref.size() + test.size());
    report.ref_to_test.mse_colour = eval::colour_mse(ref.colours, test.colours, ref_to_test);
    report.ref_to_test.has_colour = true;
    progress_advance(progress, ref.size());
    report.test_to_ref.mse_colour = eval::colour_mse(test.colours, ref.colours, test_to_ref);
    report.test_to_ref.has_colour = true;
    progress_advance(progress, test.size());
    progress_end(progress);
    report.colour_mse = std::max(report.ref_to_test.mse_colour, report.test_to_ref.mse_colour);
    report.colour_psnr = colour_psnr(report.colour_mse);
  }

  report.has_normal_error = ref.has_normals() && test.has_normals();
  if (report.has_normal_error) {
    const eval::NormalAngleStats angles =
        eval::normal_angle_error(test.normals, ref.normals, test_to_ref);
    report.normal_angle_mean_deg = angles.mean_deg;
    report.normal_angle_p95_deg = angles.p95_deg;
    report.normal_angle_points = angles.points;
  }
  return report;
}

}  // namespace sspc
