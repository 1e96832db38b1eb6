// sspc info FILE: what a point cloud holds (count, attributes, bounds, spacing).
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "command.hpp"
#include "json_writer.hpp"
#include "sspc/io.hpp"
#include "sspc/neighbors.hpp"

namespace sspc::cli {
namespace {

struct InfoOptions {
  std::string input;
  bool json = false;
};

const char* format_name(PointCloudFormat f) {
  switch (f) {
    case PointCloudFormat::kPly: return "ply";
    case PointCloudFormat::kXyz: return "xyz";
    case PointCloudFormat::kPcd: return "pcd";
    case PointCloudFormat::kAuto: break;
  }
  return "detected from content";
}

std::string format_vec3(const Vec3f& v) {
  char buf[128];
  std::snprintf(buf, sizeof buf, "%.9g %.9g %.9g", double{v.x()}, double{v.y()}, double{v.z()});
  return buf;
}

int run_info(const InfoOptions& options, const GlobalOptions& global) {
  if (is_sspc_file(options.input)) return run_info_sspc(options.input, options.json);
  auto progress = make_progress(global);
  ReadOptions read_options;
  read_options.progress = progress.get();
  auto cloud = read_cloud(options.input, read_options);
  if (!cloud.ok()) return report_failure(cloud.status());

  std::error_code ec;
  const auto file_bytes = std::filesystem::file_size(options.input, ec);
  const Box3f box = cloud->bounding_box();
  const double diagonal = bounding_box_diagonal(*cloud);
  const double spacing = nominal_spacing(*cloud);
  const char* format = format_name(format_from_extension(options.input));

  if (options.json) {
    JsonWriter json;
    json.begin_object();
    json.field("file", options.input).field("format", format);
    json.field("file_bytes", static_cast<std::uint64_t>(ec ? 0 : file_bytes));
    json.field("points", static_cast<std::uint64_t>(cloud->size()));
    json.field("normals", cloud->has_normals()).field("colors", cloud->has_colors());
    json.key("bbox_min");
    write_vec3(json, box.min());
    json.key("bbox_max");
    write_vec3(json, box.max());
    json.field("diagonal", diagonal).field("spacing", spacing);
    json.end_object();
    print_line(json.str());
    return kExitOk;
  }
  std::string attributes = "positions";
  if (cloud->has_normals()) attributes += " normals";
  if (cloud->has_colors()) attributes += " colors";
  std::printf("file        %s (%llu bytes, %s)\n", options.input.c_str(),
              static_cast<unsigned long long>(ec ? 0 : file_bytes), format);
  std::printf("points      %zu\n", cloud->size());
  std::printf("attributes  %s\n", attributes.c_str());
  std::printf("bbox min    %s\n", format_vec3(box.min()).c_str());
  std::printf("bbox max    %s\n", format_vec3(box.max()).c_str());
  std::printf("diagonal    %.9g\n", diagonal);
  std::printf("spacing     %.9g (median nearest-neighbour distance)\n", spacing);
  return kExitOk;
}

}  // namespace

Command add_info_command(CLI::App& root, const GlobalOptions& global) {
  auto options = std::make_shared<InfoOptions>();
  CLI::App* app = root.add_subcommand("info", "Describe a point cloud: points, attributes, bounds, spacing");
  app->add_option("file", options->input,
                  "Point cloud (.ply, .xyz/.pts, .pcd) or compressed model (.sspc)")
      ->required();
  app->add_flag("--json", options->json, "Machine-readable output on stdout");
  return {app, [options, &global] { return run_info(*options, global); }};
}

}  // namespace sspc::cli
