// sspc eval REF TEST: distortion of TEST against the reference REF (paper §6, MPEG D1/D2, and
// colour PSNR when both files have colours).
// The formulas are in docs/METRICS.md.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "command.hpp"
#include "sspc/io.hpp"
#include "sspc/metrics.hpp"
#include "sspc/normals.hpp"

namespace sspc::cli {
namespace {

struct EvalCliOptions {
  std::string ref;
  std::string test;
  std::optional<double> peak;
  std::string compressed;
  bool no_estimate_normals = false;
  bool json = false;
};

Json direction(const DirectedError& e) {
  Json json;
  json["rms"] = e.rms;
  json["hausdorff"] = e.hausdorff;
  json["d1_mse"] = e.mse_d1;
  if (e.has_d2) json["d2_mse"] = e.mse_d2;
  if (e.has_colour) json["colour_mse"] = e.mse_colour;
  return json;
}

std::string db(double v) {
  if (std::isinf(v)) return "inf (identical)";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.4f dB", v);
  return buf;
}

int run_eval(const EvalCliOptions& options, const GlobalOptions& global) {
  if (options.peak && !(*options.peak > 0 && std::isfinite(*options.peak))) {
    return report_failure(invalid_argument("--peak must be a positive finite number"));
  }
  if (is_stdio(options.ref) && is_stdio(options.test)) {
    return report_usage_error(invalid_argument("'-' (stdin) names both clouds; stdin can be read only once"));
  }
  auto progress = make_progress(global);
  // Two reads, normals for REF when it has none, three passes (four with D2, one more with
  // colours).
  progress_stages(progress.get(), 2 + 4);
  // Both files' own values in double, about one origin: far from the origin float32 would
  // compare rounding instead of the clouds (docs/METRICS.md, "Coordinates far from the origin").
  std::vector<Vec3d> ref_stored, test_stored;
  ReadOptions read_options;
  read_options.progress = progress.get();
  read_options.positions_f64 = &ref_stored;
  auto ref = read_cloud(options.ref, read_options);
  if (!ref.ok()) return report_failure(ref.status());
  read_options.positions_f64 = &test_stored;
  auto test = read_cloud(options.test, read_options);
  if (!test.ok()) return report_failure(test.status());
  const auto origin = move_to_common_origin(*ref, ref_stored, *test, test_stored);
  if (!origin.ok()) return report_failure(origin.status());
  std::vector<Vec3d>().swap(ref_stored);  // not needed any more: free them before the k-d trees
  std::vector<Vec3d>().swap(test_stored);

  // D2 projects errors on REF's normals; a reference without them gets estimated ones so that
  // D2 is still reported (said in the output), unless the user opts out.
  const bool ref_had_normals = ref->has_normals();
  if (!ref_had_normals && !options.no_estimate_normals) {
    NormalOptions normal_options;
    normal_options.mode = NormalMode::kEstimate;
    normal_options.progress = progress.get();
    const Status status = ensure_normals(*ref, normal_options);
    if (!status.ok()) return report_failure(status.with_context(options.ref));
  }
  const bool colours = ref->has_colours() && test->has_colours();
  progress_stages(progress.get(), 2 + (ref_had_normals || options.no_estimate_normals ? 0 : 3) +
                                      (ref->has_normals() ? 4 : 3) + (colours ? 1 : 0));
  // Normal errors compare the files' own normals, never estimated ones.
  const bool compare_normals = ref_had_normals && test->has_normals();
  if (!compare_normals && test->has_normals()) test->normals.clear();
  std::optional<std::uint64_t> compressed_bytes;
  if (!options.compressed.empty()) {
    std::error_code ec;
    compressed_bytes = std::filesystem::file_size(options.compressed, ec);
    if (ec) return report_failure(io_error(options.compressed + ": " + ec.message()));
  }

  EvalOptions eval_options;
  eval_options.peak = options.peak;
  eval_options.progress = progress.get();
  auto report = evaluate(*ref, *test, eval_options);
  if (!report.ok()) return report_failure(report.status());
  progress.reset();  // finish the progress line before printing results
  const EvalReport& r = *report;
  const char* ref_normals = ref_had_normals ? "file" : (ref->has_normals() ? "estimated" : "none");

  if (options.json) {
    Json json = json_report("eval");
    json["ref"] = options.ref;
    json["test"] = options.test;
    json["ref_points"] = r.ref_points;
    json["test_points"] = r.test_points;
    json["ref_diagonal"] = r.ref_diagonal;
    json["peak"] = r.peak;
    json["ref_normals"] = ref_normals;
    json["ref_to_test"] = direction(r.ref_to_test);
    json["test_to_ref"] = direction(r.test_to_ref);
    json["rms"] = r.rms_max;
    json["hausdorff"] = r.hausdorff;
    json["psnr"] = r.psnr_paper;  // null when infinite (identical clouds)
    json["d1_mse"] = r.d1_mse;
    json["d1_psnr"] = r.d1_psnr;
    if (r.has_d2) {
      json["d2_mse"] = r.d2_mse;
      json["d2_psnr"] = r.d2_psnr;
    }
    json["identical"] = r.rms_max == 0.0;
    if (r.has_colour) {
      json["colour_mse"] = r.colour_mse;
      json["colour_psnr"] = r.colour_psnr;  // null when infinite (identical colours)
    }
    if (r.has_normal_error) {
      json["normal_angle_mean_deg"] = r.normal_angle_mean_deg;
      json["normal_angle_p95_deg"] = r.normal_angle_p95_deg;
    }
    if (compressed_bytes) {
      json["compressed"] = options.compressed;
      json["compressed_bytes"] = *compressed_bytes;
      json["bits_per_point"] = bits_per_point(*compressed_bytes, r.ref_points);
    }
    print_json(json);
    return kExitOk;
  }
  std::printf("reference  %s: %llu points, bounding-box diagonal %.9g, normals: %s\n",
              options.ref.c_str(), static_cast<unsigned long long>(r.ref_points), r.ref_diagonal,
              ref_normals);
  std::printf("test       %s: %llu points\n", options.test.c_str(),
              static_cast<unsigned long long>(r.test_points));
  std::printf("%-22s %16s %16s %16s\n", "", "REF->TEST", "TEST->REF", "symmetric");
  std::printf("%-22s %16.9g %16.9g %16.9g\n", "RMS", r.ref_to_test.rms, r.test_to_ref.rms,
              r.rms_max);
  std::printf("%-22s %16.9g %16.9g %16.9g\n", "Hausdorff", r.ref_to_test.hausdorff,
              r.test_to_ref.hausdorff, r.hausdorff);
  std::printf("%-22s %16.9g %16.9g %16.9g\n", "D1 MSE", r.ref_to_test.mse_d1, r.test_to_ref.mse_d1,
              r.d1_mse);
  if (r.has_d2) {
    std::printf("%-22s %16.9g %16.9g %16.9g\n", "D2 MSE", r.ref_to_test.mse_d2,
                r.test_to_ref.mse_d2, r.d2_mse);
  }
  if (r.has_colour) {
    std::printf("%-22s %16.9g %16.9g %16.9g\n", "colour MSE (RGB)", r.ref_to_test.mse_colour,
                r.test_to_ref.mse_colour, r.colour_mse);
  }
  std::printf("PSNR (paper, d_B)      %s\n", db(r.psnr_paper).c_str());
  std::printf("D1 PSNR (peak %.6g)  %s\n", r.peak, db(r.d1_psnr).c_str());
  if (r.has_d2) std::printf("D2 PSNR (peak %.6g)  %s\n", r.peak, db(r.d2_psnr).c_str());
  if (r.has_colour) std::printf("colour PSNR (RGB, 255) %s\n", db(r.colour_psnr).c_str());
  if (r.has_normal_error) {
    std::printf("normals angle          mean %.4f deg, 95th percentile %.4f deg\n",
                r.normal_angle_mean_deg, r.normal_angle_p95_deg);
  }
  if (compressed_bytes) {
    std::printf("bits per point         %.4f (%s, %llu bytes)\n",
                bits_per_point(*compressed_bytes, r.ref_points), options.compressed.c_str(),
                static_cast<unsigned long long>(*compressed_bytes));
  }
  return kExitOk;
}

}  // namespace

Command add_eval_command(CLI::App& root, const GlobalOptions& global) {
  auto options = std::make_shared<EvalCliOptions>();
  CLI::App* app = root.add_subcommand(
      "eval",
      "Distortion of TEST against REF: RMS, Hausdorff, PSNR (paper), MPEG D1/D2 PSNR, and "
      "colour PSNR when both have colours");
  app->add_option("ref", options->ref, "Reference (original) point cloud ('-' reads stdin)")->required();
  app->add_option("test", options->test, "Test (decoded) point cloud ('-' reads stdin)")->required();
  app->add_option("--peak", options->peak,
                  "Peak for D1/D2 PSNR (default: REF's bounding-box diagonal)")
      ->type_name("NUMBER");
  app->add_option("--compressed", options->compressed,
                  "Compressed file whose size gives bits per point (bytes x 8 / REF's points)")
      ->type_name("FILE");
  app->add_flag("--no-estimate-normals", options->no_estimate_normals,
                "Skip D2 when REF has no normals instead of estimating them");
  app->add_flag("--json", options->json, "Machine-readable output on stdout (keys: docs/CLI.md)");
  app->footer("Example: sspc eval scan.ply decoded.ply --compressed model.sspc");
  return {app, [options, &global] { return run_eval(*options, global); }};
}

}  // namespace sspc::cli
