// sspc info FILE: what a point cloud holds (count, attributes, bounds, spacing).
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "command.hpp"
#include "sspc/io.hpp"
#include "sspc/neighbours.hpp"

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
    case PointCloudFormat::kLas: return "las";
    case PointCloudFormat::kXyzRgb: return "xyzrgb";
    case PointCloudFormat::kXyzN: return "xyzn";
    case PointCloudFormat::kAuto: break;
  }
  return "detected from content";
}

std::string format_vec3(const Vec3d& v) {
  char buf[128];
  std::snprintf(buf, sizeof buf, "%.15g %.15g %.15g", v.x(), v.y(), v.z());
  return buf;
}

// The attributes line: the model's, then a LAS file's own fields.
std::string attribute_names(const PointCloud& cloud) {
  std::string out = "positions";
  if (cloud.has_normals()) out += " normals";
  if (cloud.has_colours()) out += " colours";
  if (!cloud.las.empty()) out += "; LAS: " + cloud.las.names();
  return out;
}

void print_las_source(const PointCloud& cloud) {
  const LasSource& las = *cloud.metadata.las;
  std::printf("las         version %d.%d, point format %d, by '%s'\n", las.version_major,
              las.version_minor, las.point_format, las.generating_software.c_str());
  std::printf("las scale   %s\n", format_vec3(las.scale).c_str());
  std::printf("las offset  %s\n", format_vec3(las.offset).c_str());
}

std::string crs_summary(const CloudMetadata& m) {
  if (!m.crs_wkt.empty()) {
    const std::size_t bracket = m.crs_wkt.find('[');
    return "WKT " + m.crs_wkt.substr(0, std::min<std::size_t>(bracket == std::string::npos ? 40 : bracket + 40, 80)) +
           (m.crs_wkt.size() > 80 ? "..." : "");
  }
  if (!m.crs_records.empty()) {
    return "GeoTIFF keys (" + std::to_string(m.crs_records.size()) + " records)";
  }
  return "none";
}

int run_info(const InfoOptions& options, const GlobalOptions& global) {
  if (is_sspc_file(options.input)) return run_info_sspc(options.input, options.json);
  auto progress = make_progress(global);
  progress_stages(progress.get(), 1);
  ReadOptions read_options;
  read_options.progress = progress.get();
  auto cloud = read_cloud(options.input, read_options);
  if (!cloud.ok()) return report_failure(cloud.status());

  std::error_code ec;
  std::uintmax_t file_bytes = 0;
  if (is_stdio(options.input)) {
    file_bytes = stdin_bytes()->size();  // read already
  } else {
    file_bytes = std::filesystem::file_size(options.input, ec);
  }
  const Box3f local_box = cloud->bounding_box();
  const Box3d box(cloud->origin + local_box.min().cast<double>(),
                  cloud->origin + local_box.max().cast<double>());
  const double diagonal = bounding_box_diagonal(*cloud);
  const double spacing = nominal_spacing(*cloud);
  const char* format = format_name(is_stdio(options.input) ? PointCloudFormat::kAuto : format_from_extension(options.input));

  if (options.json) {
    Json json = json_report("info");
    json["file"] = options.input;
    json["format"] = format;
    json["file_bytes"] = static_cast<std::uint64_t>(ec ? 0 : file_bytes);
    json["points"] = cloud->size();
    json["normals"] = cloud->has_normals();
    json["colours"] = cloud->has_colours();
    json["las_attributes"] = cloud->las.names();
    json["origin"] = json_vec3(cloud->origin);
    json["crs"] = cloud->metadata.has_crs();
    json["comments"] = cloud->metadata.comments.size();
    if (cloud->metadata.las) {
      const LasSource& las = *cloud->metadata.las;
      json["las_version"] = std::to_string(las.version_major) + "." + std::to_string(las.version_minor);
      json["las_point_format"] = las.point_format;
      json["las_scale"] = json_vec3(las.scale);
      json["las_offset"] = json_vec3(las.offset);
    }
    json["bbox_min"] = json_vec3(box.min());
    json["bbox_max"] = json_vec3(box.max());
    json["diagonal"] = diagonal;
    json["spacing"] = spacing;
    print_json(json);
    return kExitOk;
  }
  const std::string attributes = attribute_names(*cloud);
  std::printf("file        %s (%llu bytes, %s)\n", is_stdio(options.input) ? kStdinName : options.input.c_str(),
              static_cast<unsigned long long>(ec ? 0 : file_bytes), format);
  std::printf("points      %zu\n", cloud->size());
  std::printf("attributes  %s\n", attributes.c_str());
  if (cloud->metadata.las) print_las_source(*cloud);
  std::printf("crs         %s\n", crs_summary(cloud->metadata).c_str());
  if (cloud->origin != Vec3d::Zero()) {
    std::printf("origin      %s (positions are kept relative to it)\n",
                format_vec3(cloud->origin).c_str());
  }
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
                  "Point cloud (.ply, .las, .xyz/.pts/.xyzrgb/.xyzn, .pcd) or compressed model (.sspc); '-' reads "
                  "stdin")
      ->required();
  app->add_flag("--json", options->json, "Machine-readable output on stdout (keys: docs/CLI.md)");
  app->footer("Example: sspc info scan.ply   (or: sspc decode model.sspc - | sspc info -)");
  return {app, [options, &global] { return run_info(*options, global); }};
}

}  // namespace sspc::cli
