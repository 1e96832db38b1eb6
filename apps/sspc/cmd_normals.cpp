// sspc normals IN OUT: give a point cloud consistently oriented unit normals (include/sspc/normals.hpp).
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "command.hpp"
#include "sspc/io.hpp"
#include "sspc/normals.hpp"

namespace sspc::cli {
namespace {

struct NormalsOptions {
  std::string input;
  std::string output;
  NormalMode mode = NormalMode::kEstimate;
  int k = 16;
  std::string viewpoint;
  bool ascii = false;
  bool force = false;
  bool json = false;
};

int run_normals(const NormalsOptions& options, const GlobalOptions& global) {
  if (Status s = check_json_and_stdout(options.json, {options.output}); !s.ok()) return report_usage_error(s);
  if (Status s = check_outputs({options.input}, {options.output}, options.force); !s.ok()) return report_failure(s);
  auto progress = make_progress(global);
  progress_stages(progress.get(), options.mode == NormalMode::kKeep ? 1 : 4);
  const auto t0 = std::chrono::steady_clock::now();
  ReadOptions read_options;
  read_options.progress = progress.get();
  auto cloud = read_cloud(options.input, read_options);
  if (!cloud.ok()) return report_failure(cloud.status());
  const bool had_normals = cloud->has_normals();
  const bool estimate = options.mode == NormalMode::kEstimate || (options.mode == NormalMode::kAuto && !had_normals);
  progress_stages(progress.get(), estimate ? 4 : 1);
  const auto t1 = std::chrono::steady_clock::now();

  NormalOptions normal_options;
  normal_options.mode = options.mode;
  normal_options.k = options.k;
  normal_options.viewpoint = parse_vec3(options.viewpoint);
  normal_options.progress = progress.get();
  Status status = ensure_normals(*cloud, normal_options);
  if (!status.ok()) return report_failure(status.with_context(options.input));
  const auto t2 = std::chrono::steady_clock::now();

  PlyWriteOptions write_options;
  write_options.encoding = options.ascii ? PlyEncoding::kAscii : PlyEncoding::kBinaryLittleEndian;
  progress.reset();  // finish the progress line before the summary
  status = write_output(options.output, ".ply", [&](const std::filesystem::path& path) {
    return write_ply(*cloud, path, write_options);
  });
  if (!status.ok()) return report_failure(status);
  const auto t3 = std::chrono::steady_clock::now();

  const auto seconds = [](auto a, auto b) { return std::chrono::duration<double>(b - a).count(); };
  const bool estimated = estimate;
  const double normal_seconds = seconds(t1, t2);
  const double rate = normal_seconds > 0 ? static_cast<double>(cloud->size()) / normal_seconds : 0;
  if (options.json) {
    Json json = json_report("normals");
    json["input"] = options.input;
    json["output"] = options.output;
    json["points"] = cloud->size();
    json["estimated"] = estimated;
    json["k"] = options.k;
    json["read_seconds"] = seconds(t0, t1);
    json["normals_seconds"] = normal_seconds;
    json["normals_points_per_second"] = rate;
    json["write_seconds"] = seconds(t2, t3);
    print_json(json);
  } else if (!global.quiet) {
    std::fprintf(summary_stream({options.output}), "%s: %zu points, normals %s in %.3f s (%.3g points/s), written to %s\n",
                 is_stdio(options.input) ? kStdinName : options.input.c_str(), cloud->size(),
                 estimated ? "estimated" : "kept", normal_seconds, rate,
                 is_stdio(options.output) ? "stdout" : options.output.c_str());
  }
  return kExitOk;
}

}  // namespace

Command add_normals_command(CLI::App& root, const GlobalOptions& global) {
  auto options = std::make_shared<NormalsOptions>();
  CLI::App* app = root.add_subcommand(
      "normals", "Estimate and orient normals (PCA over k neighbours, Hoppe MST orientation)");
  app->add_option("input", options->input, "Point cloud to read ('-' reads stdin)")->required();
  app->add_option("output", options->output, "PLY file to write ('-' writes stdout)")->required();
  const std::map<std::string, NormalMode> modes{
      {"auto", NormalMode::kAuto}, {"keep", NormalMode::kKeep}, {"estimate", NormalMode::kEstimate}};
  app->add_option("--normals", options->mode,
                  "auto: keep the file's normals if any; keep: require them; estimate: recompute")
      ->transform(CLI::CheckedTransformer(modes, CLI::ignore_case).description(""))
      ->type_name("auto|keep|estimate")
      ->default_str("estimate");
  app->add_option("-k,--neighbours", options->k, "Neighbours for the PCA")
      ->check(CLI::Range(3, 256).description(""))
      ->type_name("3..256")
      ->capture_default_str();
  app->add_option("--viewpoint", options->viewpoint,
                  "Orient normals towards this point (scanner position) instead of propagating")
      ->check(kVec3Validator)->type_name("X,Y,Z");
  app->add_flag("--ascii", options->ascii, "Write ascii PLY (default: binary little-endian)");
  app->add_flag("-f,--force", options->force, "Overwrite an existing output file");
  app->add_flag("--json", options->json, "Machine-readable statistics on stdout (keys: docs/CLI.md)");
  app->footer("Example: sspc normals scan.ply with_normals.ply --viewpoint 0,0,100");
  return {app, [options, &global] { return run_normals(*options, global); }};
}

}  // namespace sspc::cli
