// sspc render IN -o OUT.png: ray-trace the MLS surface of a point cloud, or of a compressed model
// directly, without decoding it (SPEC step 10, paper §5).
#include <cstdio>
#include <map>
#include <memory>
#include <string>

#include "command.hpp"
#include "json_writer.hpp"
#include "sspc/io.hpp"
#include "sspc/normals.hpp"
#include "sspc/render.hpp"

namespace sspc::cli {
namespace {

struct RenderCliOptions {
  std::string input;
  std::string output;
  std::string size = "1024x1024";
  std::string eye, target, up;
  float fov = 40;
  float bandwidth = 1.5f;
  Shade shade = Shade::kLambert;
  bool force = false;
  bool json = false;
};

bool parse_size(const std::string& text, int& w, int& h) {
  const auto x = text.find('x');
  if (x == std::string::npos) return false;
  try {
    std::size_t used = 0;
    w = std::stoi(text.substr(0, x), &used);
    if (used != x) return false;
    h = std::stoi(text.substr(x + 1), &used);
    return used == text.size() - x - 1;
  } catch (...) {
    return false;
  }
}

int run_render(const RenderCliOptions& o, const GlobalOptions& global) {
  std::error_code ec;
  if (!o.force && std::filesystem::exists(o.output, ec)) {
    return report_failure(invalid_argument(o.output + ": exists; pass -f/--force to overwrite it"));
  }
  RenderOptions options;
  if (!parse_size(o.size, options.width, options.height)) {
    return report_failure(invalid_argument("--size must be WIDTHxHEIGHT, got '" + o.size + "'"));
  }
  auto progress = make_progress(global);
  options.shade = o.shade;
  options.bandwidth = o.bandwidth;
  options.progress = progress.get();
  const auto set_camera = [&](const Box3f& bounds) {
    options.camera = frame_bounds(bounds, o.fov);
    if (auto v = parse_vec3(o.eye)) options.camera.eye = *v;
    if (auto v = parse_vec3(o.target)) options.camera.target = *v;
    if (auto v = parse_vec3(o.up)) options.camera.up = *v;
  };
  RenderStats stats;
  StatusOr<Image> image = invalid_argument("nothing rendered");
  std::uint64_t points = 0;
  if (is_sspc_file(o.input)) {
    auto model = CompressedModel::open(o.input);
    if (!model.ok()) return report_failure(model.status());
    const ModelInfo info = model->info();
    points = info.source_points;
    set_camera(info.bounds);
    image = render_compressed(*model, options, &stats);
  } else {
    ReadOptions read;
    read.progress = progress.get();
    auto cloud = read_point_cloud(o.input, read);
    if (!cloud.ok()) return report_failure(cloud.status());
    NormalOptions normals;
    normals.progress = progress.get();
    if (Status s = ensure_normals(*cloud, normals); !s.ok()) return report_failure(s.with_context(o.input + ": "));
    points = cloud->size();
    set_camera(cloud->bounding_box());
    image = render_point_cloud(*cloud, options, &stats);
  }
  if (!image.ok()) return report_failure(image.status().with_context(o.input + ": "));
  if (Status s = write_png(*image, o.output); !s.ok()) return report_failure(s);

  const double rays_per_second = stats.render_seconds > 0 ? static_cast<double>(stats.rays) / stats.render_seconds : 0;
  if (o.json) {
    JsonWriter json;
    json.begin_object()
        .field("input", o.input)
        .field("output", o.output)
        .field("points", points)
        .field("width", options.width)
        .field("height", options.height)
        .field("rays", stats.rays)
        .field("hits", stats.hits)
        .field("evaluations_per_hit", stats.hits > 0 ? static_cast<double>(stats.evaluations) / static_cast<double>(stats.hits) : 0.0)
        .field("build_seconds", stats.build_seconds)
        .field("render_seconds", stats.render_seconds)
        .field("rays_per_second", rays_per_second)
        .field("scene_bytes", stats.scene_bytes)
        .field("scene_bytes_per_point", points > 0 ? static_cast<double>(stats.scene_bytes) / static_cast<double>(points) : 0.0)
        .end_object();
    print_line(json.str());
  } else {
    std::printf("%s: %llu points -> %s (%dx%d), %llu of %llu rays hit, build %.2f s, render %.2f s (%.3g rays/s)\n",
                o.input.c_str(), static_cast<unsigned long long>(points), o.output.c_str(), options.width, options.height,
                static_cast<unsigned long long>(stats.hits), static_cast<unsigned long long>(stats.rays),
                stats.build_seconds, stats.render_seconds, rays_per_second);
  }
  return kExitOk;
}

}  // namespace

Command add_render_command(CLI::App& root, const GlobalOptions& global) {
  auto o = std::make_shared<RenderCliOptions>();
  CLI::App* app = root.add_subcommand("render", "Ray-trace a point cloud's or a compressed model's MLS surface into a PNG");
  app->add_option("input", o->input, "Point cloud (PLY, XYZ/PTS, PCD) or compressed model (.sspc)")->required();
  app->add_option("-o,--output", o->output, "PNG file to write")->required();
  app->add_option("--size", o->size, "Image size WIDTHxHEIGHT")->capture_default_str();
  app->add_option("--eye", o->eye, "Camera position x,y,z (default: framing the cloud from +z)")->check(kVec3Validator);
  app->add_option("--target", o->target, "Point the camera looks at (default: the cloud's centre)")->check(kVec3Validator);
  app->add_option("--up", o->up, "Camera up vector (default: +y)")->check(kVec3Validator);
  app->add_option("--fov", o->fov, "Vertical field of view in degrees")->check(CLI::Range(1.0f, 170.0f))->capture_default_str();
  app->add_option("--bandwidth", o->bandwidth, "MLS bandwidth h in point spacings")->check(CLI::Range(0.5f, 20.0f))->capture_default_str();
  const std::map<std::string, Shade> shades{{"lambert", Shade::kLambert},
                                            {"normal", Shade::kNormal},
                                            {"depth", Shade::kDepth},
                                            {"codeword", Shade::kCodeword}};
  app->add_option("--shade", o->shade, "lambert, normal, depth, or codeword (a colour per code word)")
      ->transform(CLI::CheckedTransformer(shades, CLI::ignore_case))
      ->default_str("lambert");
  app->add_flag("-f,--force", o->force, "Overwrite an existing output file");
  app->add_flag("--json", o->json, "Machine-readable statistics on stdout");
  return {app, [o, &global] { return run_render(*o, global); }};
}

}  // namespace sspc::cli
