// sspc convert IN OUT: a point cloud from one format to another (reads every format sspc reads,
// writes PLY or LAS by OUT's extension), keeping what both formats hold: the origin, comments,
// the CRS and, LAS to LAS, every field and the stored integers.
#include <chrono>
#include <cstdio>
#include <memory>
#include <string>

#include "command.hpp"
#include "json_writer.hpp"
#include "sspc/io.hpp"

namespace sspc::cli {
namespace {

struct ConvertOptions {
  std::string input;
  std::string output;
  bool ascii = false;
  bool force = false;
  bool json = false;
};

// What a PLY output cannot hold of a LAS input, named so that nothing is lost silently.
void warn_dropped(const PointCloud& cloud, const std::string& output) {
  if (format_from_extension(output) == PointCloudFormat::kLas) return;
  std::string dropped = cloud.las.names();
  if (!dropped.empty()) {
    std::fprintf(stderr, "sspc: warning: %s: PLY output keeps positions and colours; dropped %s\n",
                 output.c_str(), dropped.c_str());
  }
  if (!cloud.metadata.crs_records.empty() && cloud.metadata.crs_wkt.empty()) {
    std::fprintf(stderr,
                 "sspc: warning: %s: the CRS is GeoTIFF keys, which PLY cannot hold; dropped\n",
                 output.c_str());
  }
}

int run_convert(const ConvertOptions& o, const GlobalOptions& global) {
  if (Status s = check_outputs({o.input}, {o.output}, o.force); !s.ok()) return report_failure(s);
  const auto start = std::chrono::steady_clock::now();
  auto progress = make_progress(global);
  ReadOptions read;
  read.progress = progress.get();
  auto cloud = read_cloud(o.input, read);
  if (!cloud.ok()) return report_failure(cloud.status());
  warn_dropped(*cloud, o.output);
  PlyWriteOptions ply;
  ply.encoding = o.ascii ? PlyEncoding::kAscii : PlyEncoding::kBinaryLittleEndian;
  const Status written = write_point_cloud(*cloud, o.output, ply);
  if (!written.ok()) return report_failure(written);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (o.json) {
    JsonWriter json;
    json.begin_object();
    json.field("input", o.input).field("output", o.output);
    json.field("points", static_cast<std::uint64_t>(cloud->size()));
    json.key("origin");
    write_vec3(json, cloud->origin);
    json.field("crs", cloud->metadata.has_crs());
    json.field("seconds", seconds);
    json.end_object();
    print_line(json.str());
  } else {
    std::fprintf(stderr, "%s: %zu points in %.3f s\n", o.output.c_str(), cloud->size(), seconds);
  }
  return kExitOk;
}

}  // namespace

Command add_convert_command(CLI::App& root, const GlobalOptions& global) {
  auto o = std::make_shared<ConvertOptions>();
  CLI::App* app = root.add_subcommand(
      "convert", "Convert a point cloud between formats (writes .ply or .las by extension)");
  app->add_option("input", o->input, "Point cloud (.ply, .las, .xyz/.pts/.xyzrgb/.xyzn, .pcd)")
      ->required();
  app->add_option("output", o->output, "Point cloud to write (.ply or .las)")->required();
  app->add_flag("--ascii", o->ascii, "Write ASCII PLY instead of binary");
  app->add_flag("-f,--force", o->force, "Overwrite the output if it exists");
  app->add_flag("--json", o->json, "Machine-readable summary on stdout");
  return {app, [o, &global] { return run_convert(*o, global); }};
}

}  // namespace sspc::cli
