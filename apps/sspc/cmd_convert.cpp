// sspc convert IN OUT: a point cloud from one format to another (reads every format sspc reads,
// writes PLY or LAS by OUT's extension, or by --format on stdout), keeping what both formats
// hold: the origin, comments, the CRS and, LAS to LAS, every field and the stored integers.
#include <chrono>
#include <cstdio>
#include <memory>
#include <string>

#include "command.hpp"
#include "sspc/io.hpp"

namespace sspc::cli {
namespace {

struct ConvertOptions {
  std::string input;
  std::string output;
  std::string format = "ply";
  bool ascii = false;
  bool force = false;
  bool json = false;
};

// What a PLY output cannot hold of a LAS input, named so that nothing is lost silently.
void warn_dropped_fields(const PointCloud& cloud, const std::string& output,
                  const std::string& extension) {
  if (format_from_extension("x" + extension) == PointCloudFormat::kLas) return;
  const std::string name = is_stdio(output) ? "stdout" : output;
  cli::warn_dropped(output, "PLY output keeps positions and colours", cloud.las.names());
  if (!cloud.metadata.crs_records.empty() && cloud.metadata.crs_wkt.empty()) {
    std::fprintf(stderr,
                 "sspc: warning: %s: the CRS is GeoTIFF keys, which PLY cannot hold; dropped\n",
                 name.c_str());
  }
}

int run_convert(const ConvertOptions& o, const GlobalOptions& global) {
  if (Status s = check_json_and_stdout(o.json, {o.output}); !s.ok()) return report_usage_error(s);
  if (Status s = check_outputs({o.input}, {o.output}, o.force); !s.ok()) return report_failure(s);
  const auto start = std::chrono::steady_clock::now();
  auto progress = make_progress(global);
  progress_stages(progress.get(), 1);
  ReadOptions read;
  read.progress = progress.get();
  auto cloud = read_cloud(o.input, read);
  if (!cloud.ok()) return report_failure(cloud.status());
  const std::string extension = cloud_extension(o.output, o.format);
  warn_dropped_fields(*cloud, o.output, extension);
  PlyWriteOptions ply;
  ply.encoding = o.ascii ? PlyEncoding::kAscii : PlyEncoding::kBinaryLittleEndian;
  const Status written = write_output(o.output, extension, [&](const std::filesystem::path& path) {
    return write_point_cloud(*cloud, path, ply);
  });
  if (!written.ok()) return report_failure(written);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (o.json) {
    Json json = json_report("convert");
    json["input"] = o.input;
    json["output"] = o.output;
    json["points"] = cloud->size();
    json["origin"] = json_vec3(cloud->origin);
    json["crs"] = cloud->metadata.has_crs();
    json["seconds"] = seconds;
    print_json(json);
  } else if (!global.quiet) {
    std::fprintf(stderr, "%s: %zu points in %.3f s\n", o.output.c_str(), cloud->size(), seconds);
  }
  return kExitOk;
}

}  // namespace

Command add_convert_command(CLI::App& root, const GlobalOptions& global) {
  auto o = std::make_shared<ConvertOptions>();
  CLI::App* app = root.add_subcommand(
      "convert", "Convert a point cloud between formats (writes .ply or .las by extension)");
  app->add_option("input", o->input,
                  "Point cloud (.ply, .las, .xyz/.pts/.xyzrgb/.xyzn, .pcd; '-' reads stdin)")
      ->required();
  app->add_option("output", o->output, "Point cloud to write (.ply or .las; '-' writes stdout)")
      ->required();
  add_format_option(app, o->format);
  app->add_flag("--ascii", o->ascii, "Write ASCII PLY instead of binary");
  app->add_flag("-f,--force", o->force, "Overwrite the output if it exists");
  app->add_flag("--json", o->json, "Machine-readable summary on stdout (keys: docs/CLI.md)");
  app->footer("Example: sspc convert scan.las scan.ply");
  return {app, [o, &global] { return run_convert(*o, global); }};
}

}  // namespace sspc::cli
