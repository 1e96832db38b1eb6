// sspc render IN -o OUT.png: ray-trace the MLS surface of a point cloud, or of a compressed model
// directly, decoding only the bricks its rays reach (paper §5; docs/ARCHITECTURE.md, "Rendering").
#include <sys/resource.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <sstream>
#include <string>
#include <vector>

#include "core/atomic_file.hpp"

#include "command.hpp"
#include "sspc/allocator.hpp"
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
  double budget_mib = 0;
  float lod = 0;
  std::string page_dir;
  std::string camera_path;
  int orbit = 0;
  std::string times;
  std::string compare;
  bool force = false;
  bool json = false;
};

// One camera of a camera path: what its line gives (up and the field of view are optional).
struct CameraLine {
  Vec3f eye, target;
  std::optional<Vec3f> up;
  std::optional<float> fov;

  Camera with_defaults(const Camera& defaults) const {
    Camera c = defaults;
    c.eye = eye;
    c.target = target;
    if (up) c.up = *up;
    if (fov) c.fov_degrees = *fov;
    return c;
  }
};

// One camera per line: eye x y z, target x y z, then optionally up x y z and the vertical field of
// view in degrees; numbers separated by spaces or commas; '#' starts a comment. Read before the
// scene is built, so that every frame's file is known (and checked) before anything is written.
StatusOr<std::vector<CameraLine>> read_camera_path(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    return invalid_argument(path + ": the camera path is not a regular file");
  }
  std::ifstream in(path);
  if (!in) return not_found(path + ": cannot open the camera path");
  std::vector<CameraLine> cameras;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (const auto hash = line.find('#'); hash != std::string::npos) line.erase(hash);
    for (char& c : line) {
      if (c == ',' || c == '\t' || c == '\r') c = ' ';
    }
    std::istringstream fields(line);
    std::vector<float> v;
    std::string word;
    while (fields >> word) {
      try {
        std::size_t used = 0;
        v.push_back(std::stof(word, &used));
        if (used != word.size()) throw std::invalid_argument(word);
      } catch (...) {
        return invalid_argument(path + ":" + std::to_string(number) + ": '" + word + "' is not a number");
      }
    }
    if (v.empty()) continue;
    if (v.size() != 6 && v.size() != 9 && v.size() != 10) {
      return invalid_argument(path + ":" + std::to_string(number) +
                              ": a camera is eye x y z, target x y z [, up x y z [, fov]]: 6, 9 or 10 numbers, got " +
                              std::to_string(v.size()));
    }
    for (const float x : v) {
      if (!std::isfinite(x)) return invalid_argument(path + ":" + std::to_string(number) + ": a number is not finite");
    }
    CameraLine c{Vec3f(v[0], v[1], v[2]), Vec3f(v[3], v[4], v[5]), std::nullopt, std::nullopt};
    if (v.size() >= 9) c.up = Vec3f(v[6], v[7], v[8]);
    if (v.size() == 10) c.fov = v[9];
    cameras.push_back(c);
    if (cameras.size() > 100000) return invalid_argument(path + ": more than 100000 cameras");
  }
  if (cameras.empty()) return invalid_argument(path + ": no camera in the camera path");
  return cameras;
}

// `frames` cameras on a circle around the target, at the framing camera's distance and height.
std::vector<Camera> orbit_cameras(const Camera& start, int frames) {
  std::vector<Camera> cameras;
  const Vec3f up = start.up.normalized();
  const Vec3f offset = start.eye - start.target;
  const Vec3f along = up * up.dot(offset);
  const Vec3f radial = offset - along;
  const Vec3f side = up.cross(radial);
  for (int f = 0; f < frames; ++f) {
    const float angle = 2.0f * 3.14159265f * static_cast<float>(f) / static_cast<float>(frames);
    Camera c = start;
    c.eye = start.target + along + std::cos(angle) * radial + std::sin(angle) * side;
    cameras.push_back(c);
  }
  return cameras;
}

// Frame f's file: OUT.png becomes OUT_0000.png, OUT_0001.png, ...
std::string frame_path(const std::string& output, std::size_t f) {
  const std::filesystem::path p(output);
  char index[16];
  std::snprintf(index, sizeof index, "_%04zu", f);
  return (p.parent_path() / (p.stem().string() + index + p.extension().string())).string();
}

std::string default_times_path(const std::string& output) {
  std::filesystem::path p(output);
  return p.replace_extension(".csv").string();
}

// CPU seconds of the whole process so far, every thread, user and system: a frame's CPU time is
// what rays per CPU-second compare across renderers whatever their thread counts
// (scripts/bench_render.sh against Embree's discs).
double cpu_seconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  const auto seconds = [](const timeval& t) {
    return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec);
  };
  return seconds(usage.ru_utime) + seconds(usage.ru_stime);
}

// "WIDTHxHEIGHT", each side 1..16384 pixels.
bool parse_size(const std::string& text, int& w, int& h) {
  const auto x = text.find('x');
  if (x == std::string::npos) return false;
  const auto side = [](const char* begin, const char* end, int& v) {
    const auto r = std::from_chars(begin, end, v);
    return r.ec == std::errc() && r.ptr == end && v >= 1 && v <= 16384;
  };
  return side(text.data(), text.data() + x, w) && side(text.data() + x + 1, text.data() + text.size(), h);
}

int run_render(const RenderCliOptions& o, const GlobalOptions& global) {
  FrameOptions options;
  if (!parse_size(o.size, options.width, options.height)) {
    return report_failure(internal_error("--size passed its validator but does not parse: " + o.size));
  }
  const bool sequence = !o.camera_path.empty() || o.orbit > 0;
  if (sequence && is_stdio(o.output)) {
    return report_usage_error(invalid_argument("-o -: stdout takes one image; a sequence needs a file name for its frames"));
  }
  if (Status s = check_json_and_stdout(o.json, {o.output}); !s.ok()) return report_usage_error(s);
  std::vector<CameraLine> path_cameras;
  if (!o.camera_path.empty()) {
    auto lines = read_camera_path(o.camera_path);
    if (!lines.ok()) return report_failure(lines.status());
    path_cameras = std::move(lines).value();
  }
  const std::size_t frame_count = !o.camera_path.empty() ? path_cameras.size() : o.orbit > 0 ? static_cast<std::size_t>(o.orbit) : 1;
  const std::string times = o.times.empty() ? default_times_path(o.output) : o.times;
  std::vector<std::string> outputs;
  for (std::size_t f = 0; f < (sequence ? frame_count : 1); ++f) outputs.push_back(sequence ? frame_path(o.output, f) : o.output);
  if (sequence) outputs.push_back(times);
  std::vector<std::string> inputs{o.input};
  if (!o.camera_path.empty()) inputs.push_back(o.camera_path);
  if (!o.compare.empty()) inputs.push_back(o.compare);
  // The image to compare with, read before the scene is built: a bad one fails at once.
  std::optional<Image> reference;
  if (!o.compare.empty()) {
    auto read = read_png(o.compare);
    if (!read.ok()) return report_failure(read.status());
    // The render's size, or a whole multiple of it each way: a supersampled reference.
    const int k = read->width / options.width;
    if (k < 1 || read->width != k * options.width || read->height != k * options.height) {
      return report_failure(invalid_argument(o.compare + ": " + std::to_string(read->width) + "x" +
                                             std::to_string(read->height) + " pixels, but the render is " + o.size +
                                             " (a reference must be its size, or a whole multiple of it each way)"));
    }
    reference = std::move(read).value();
  }
  if (Status s = check_outputs(inputs, outputs, o.force); !s.ok()) return report_failure(s);
  if (sequence) {
    // Every frame and the times CSV are staged beside them and moved into place together at the
    // end: a sequence that fails leaves nothing behind. They must then share one folder.
    for (const std::string& out : outputs) {
      std::error_code a, b;
      if (std::filesystem::weakly_canonical(std::filesystem::path(out).parent_path(), a) !=
          std::filesystem::weakly_canonical(std::filesystem::path(outputs.front()).parent_path(), b)) {
        return report_failure(invalid_argument(times + ": the times file must be in the frames' folder"));
      }
    }
  }
  auto progress = make_progress(global);
  options.shade = o.shade;
  options.level_of_detail = o.lod;
  SceneOptions scene_options;
  scene_options.bandwidth = o.bandwidth;
  scene_options.progress = progress.get();

  // The scene, built once for every frame.
  StatusOr<std::unique_ptr<RenderScene>> scene = invalid_argument("no scene");
  std::uint64_t points = 0;
  std::size_t resident_before = 0;  // before the scene is built, its input read
  if (is_sspc_file(o.input)) {
    auto model = open_model(o.input);
    if (!model.ok()) return report_failure(model.status());
    resident_before = resident_bytes();
    progress_stages(progress.get(), 2);  // the scene's patches, the image's tiles
    points = model->info().source_points;
    if (o.budget_mib > 0) scene_options.memory_budget_bytes = static_cast<std::uint64_t>(o.budget_mib * 1024 * 1024);
    scene = RenderScene::from_compressed(std::make_shared<const CompressedModel>(std::move(model).value()),
                                         scene_options);
  } else {
    // A point cloud is rendered from its points at every distance: say so rather than ignore it.
    if (o.lod > 0 && !global.quiet) {
      std::fprintf(stderr, "sspc: warning: %s: --lod applies to compressed models (.sspc) only; ignored\n",
                   o.input.c_str());
    }
    ReadOptions read;
    read.progress = progress.get();
    progress_stages(progress.get(), 3);
    auto cloud = read_cloud(o.input, read);
    if (!cloud.ok()) return report_failure(cloud.status());
    // Reading, normals when the cloud has none (three), the scene (two when paged), the image.
    progress_stages(progress.get(), 1 + (cloud->has_normals() ? 0 : 3) + (o.budget_mib > 0 ? 2 : 1) + 1);
    NormalOptions normals;
    normals.progress = progress.get();
    if (Status s = ensure_normals(*cloud, normals); !s.ok()) return report_failure(s.with_context(o.input));
    points = cloud->size();
    resident_before = resident_bytes();
    if (o.budget_mib > 0) {
      scene_options.memory_budget_bytes = static_cast<std::uint64_t>(o.budget_mib * 1024 * 1024);
      const std::filesystem::path dir =
          o.page_dir.empty() ? std::filesystem::temp_directory_path() : std::filesystem::path(o.page_dir);
      scene = RenderScene::from_point_cloud_paged(*cloud, dir, scene_options);
    } else {
      scene = RenderScene::from_point_cloud(*cloud, scene_options);
    }
  }
  if (!scene.ok()) return report_failure(scene.status().with_context(o.input));

  Camera framing = frame_bounds((*scene)->bounds(), o.fov);
  if (auto v = parse_vec3(o.eye)) framing.eye = *v;
  if (auto v = parse_vec3(o.target)) framing.target = *v;
  if (auto v = parse_vec3(o.up)) framing.up = *v;
  std::vector<Camera> cameras{framing};
  if (!o.camera_path.empty()) {
    cameras.clear();
    for (const CameraLine& line : path_cameras) cameras.push_back(line.with_defaults(framing));
  } else if (o.orbit > 0) {
    cameras = orbit_cameras(framing, o.orbit);
  }
  StagingDirectory staging;
  if (sequence) {
    if (Status s = staging.open(std::filesystem::path(outputs.front()).parent_path()); !s.ok()) return report_failure(s);
  }

  std::vector<RenderStats> frames;
  double render_cpu_seconds = 0;
  std::optional<ImageComparison> comparison;
  if (sequence) progress_begin(progress.get(), "render", cameras.size(), "frames");
  std::string csv =
      "frame,eye_x,eye_y,eye_z,target_x,target_y,target_z,render_seconds,rays,hits,evaluations,rays_per_second,"
      "bytes_read,pages_read\n";
  for (std::size_t f = 0; f < cameras.size(); ++f) {
    options.camera = cameras[f];
    options.progress = cameras.size() == 1 ? progress.get() : nullptr;
    RenderStats stats;
    const double cpu_start = cpu_seconds();
    auto image = (*scene)->render(options, &stats);
    render_cpu_seconds += cpu_seconds() - cpu_start;
    if (!image.ok()) {
      return report_failure(image.status().with_context(o.input + (sequence ? " frame " + std::to_string(f) : "")));
    }
    if (reference) {
      auto compared = compare_images(*image, *reference);
      if (!compared.ok()) return report_failure(compared.status().with_context(o.compare));
      comparison = *compared;
    }
    const std::string path = sequence ? staging.stage(frame_path(o.output, f)).string() : o.output;
    const Status png = write_output(path, ".png", [&](const std::filesystem::path& p) { return write_png(*image, p); });
    if (!png.ok()) return report_failure(png);
    const double rps = stats.render_seconds > 0 ? static_cast<double>(stats.rays) / stats.render_seconds : 0;
    char row[512];
    const Camera& c = cameras[f];
    std::snprintf(row, sizeof row, "%zu,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.6f,%llu,%llu,%llu,%.6g,%llu,%llu\n", f,
                  static_cast<double>(c.eye.x()), static_cast<double>(c.eye.y()), static_cast<double>(c.eye.z()),
                  static_cast<double>(c.target.x()), static_cast<double>(c.target.y()), static_cast<double>(c.target.z()),
                  stats.render_seconds, static_cast<unsigned long long>(stats.rays),
                  static_cast<unsigned long long>(stats.hits), static_cast<unsigned long long>(stats.evaluations), rps,
                  static_cast<unsigned long long>(stats.bytes_read), static_cast<unsigned long long>(stats.pages_read));
    csv += row;
    if (sequence) progress_advance(progress.get(), 1);
    frames.push_back(stats);
  }
  if (sequence) progress_end(progress.get());
  progress.reset();  // finish the progress line before the summary
  if (sequence) {
    const std::filesystem::path staged = staging.stage(times);
    if (Status s = write_file_atomically(staged, std::as_bytes(std::span(csv.data(), csv.size()))); !s.ok()) {
      return report_failure(s);
    }
    if (Status s = staging.commit(); !s.ok()) return report_failure(s);
  }

  // The scene still held, each frame's buffers and comparison freed, and what the allocator
  // keeps of freed blocks given back (malloc_trim), so that the growth is what the scene holds
  // resident. Kept, the freed buffers of a --compare (the reference's and the frame's pixels)
  // counted as scene: autzen level 5 at 1024² under 64 MiB grew 10.1 bytes a point with one and
  // 7.2 without, against 6.3 counted.
  release_freed_memory();
  const std::size_t resident_after = resident_bytes();
  RenderStats total;
  std::vector<double> seconds;
  std::uint64_t bytes = (*scene)->memory_bytes();
  std::uint64_t largest_frame = 0;
  for (const RenderStats& f : frames) {
    bytes = std::max(bytes, f.scene_bytes);
    largest_frame = std::max(largest_frame, f.frame_bytes);
    total.bytes_read += f.bytes_read;
    total.pages_read += f.pages_read;
    total.rays += f.rays;
    total.hits += f.hits;
    total.evaluations += f.evaluations;
    total.render_seconds += f.render_seconds;
    seconds.push_back(f.render_seconds);
  }
  std::sort(seconds.begin(), seconds.end());
  const double median = seconds[seconds.size() / 2];
  const double build = (*scene)->build_seconds();
  const double rays_per_second = total.render_seconds > 0 ? static_cast<double>(total.rays) / total.render_seconds : 0;
  if (o.json) {
    Json json = json_report("render");
    json["input"] = o.input;
    json["output"] = o.output;
    json["points"] = points;
    json["width"] = options.width;
    json["height"] = options.height;
    json["frames"] = frames.size();
    json["rays"] = total.rays;
    json["hits"] = total.hits;
    json["evaluations"] = total.evaluations;
    json["evaluations_per_hit"] =
        total.hits > 0 ? static_cast<double>(total.evaluations) / static_cast<double>(total.hits) : 0.0;
    json["build_seconds"] = build;
    json["render_seconds"] = total.render_seconds;
    json["frame_seconds_median"] = median;
    json["rays_per_second"] = rays_per_second;
    json["render_cpu_seconds"] = render_cpu_seconds;
    json["rays_per_cpu_second"] =
        render_cpu_seconds > 0 ? static_cast<double>(total.rays) / render_cpu_seconds : 0.0;
    json["scene_bytes"] = bytes;
    json["scene_bytes_per_point"] = points > 0 ? static_cast<double>(bytes) / static_cast<double>(points) : 0.0;
    json["frame_bytes"] = largest_frame;
    json["resident_growth_bytes"] =
        resident_after > resident_before ? static_cast<std::uint64_t>(resident_after - resident_before) : 0;
    json["bytes_read"] = total.bytes_read;
    json["pages_read"] = total.pages_read;
    if (o.budget_mib > 0) {
      json["memory_budget_bytes"] = static_cast<std::uint64_t>(o.budget_mib * 1024 * 1024);
      json["within_budget"] = static_cast<double>(bytes) <= o.budget_mib * 1024 * 1024;
    }
    if (!sequence) {
      // The camera as rendered, the automatic one included, so that another render (of a
      // decode, whose bounding box is not its source's) can be given the same one.
      const auto vec = [](const Vec3f& v) {
        Json a = Json::array();
        for (int k = 0; k < 3; ++k) a.push_back(static_cast<double>(v[k]));
        return a;
      };
      json["eye"] = vec(cameras.front().eye);
      json["target"] = vec(cameras.front().target);
      json["up"] = vec(cameras.front().up);
      json["fov_degrees"] = static_cast<double>(cameras.front().fov_degrees);
    }
    if (comparison) {
      json["compare"] = o.compare;
      json["psnr_hit_db"] = comparison->psnr_hit;
      json["hit_both"] = comparison->hit_both;
      json["hit_first_only"] = comparison->hit_first_only;
      json["hit_second_only"] = comparison->hit_second_only;
      json["hit_one_only_fraction"] = comparison->one_only_fraction();
    }
    if (sequence) {
      json["times"] = times;
      Json frame_seconds = Json::array();
      Json frame_bytes = Json::array();
      Json frame_pages = Json::array();
      for (const RenderStats& f : frames) {
        frame_seconds.push_back(f.render_seconds);
        frame_bytes.push_back(f.bytes_read);
        frame_pages.push_back(f.pages_read);
      }
      json["frame_seconds"] = std::move(frame_seconds);
      json["frame_bytes_read"] = std::move(frame_bytes);
      json["frame_pages_read"] = std::move(frame_pages);
    }
    print_json(json);
  } else if (!global.quiet && sequence) {
    std::printf("%s: %llu points -> %zu frames %s (%dx%d), build %.2f s, frame median %.3f s (%.3g rays/s), times in %s\n",
                o.input.c_str(), static_cast<unsigned long long>(points), frames.size(), frame_path(o.output, 0).c_str(),
                options.width, options.height, build, median, rays_per_second, times.c_str());
  } else if (!global.quiet) {
    std::fprintf(summary_stream({o.output}),
                 "%s: %llu points -> %s (%dx%d), %llu of %llu rays hit, build %.2f s, render %.2f s (%.3g rays/s)\n",
                o.input.c_str(), static_cast<unsigned long long>(points), o.output.c_str(), options.width, options.height,
                static_cast<unsigned long long>(total.hits), static_cast<unsigned long long>(total.rays), build,
                total.render_seconds, rays_per_second);
  }
  if (comparison && !o.json && !global.quiet) {
    std::printf("against %s: image PSNR %.2f dB over the %llu pixels both hit; %llu pixels hit here only, %llu there "
                "only (%.3f%% of those hit)\n",
                o.compare.c_str(), comparison->psnr_hit, static_cast<unsigned long long>(comparison->hit_both),
                static_cast<unsigned long long>(comparison->hit_first_only),
                static_cast<unsigned long long>(comparison->hit_second_only), 100.0 * comparison->one_only_fraction());
  }
  return kExitOk;
}

}  // namespace

Command add_render_command(CLI::App& root, const GlobalOptions& global) {
  auto o = std::make_shared<RenderCliOptions>();
  CLI::App* app = root.add_subcommand("render", "Ray-trace a point cloud's or a compressed model's MLS surface into a PNG");
  app->add_option("input", o->input, "Point cloud (PLY, LAS, XYZ/PTS, PCD) or compressed model (.sspc); '-' reads stdin")
      ->required();
  app->add_option("-o,--output", o->output, "PNG file to write ('-' writes stdout)")->type_name("FILE")->required();
  app->add_option("--size", o->size, "Image size WIDTHxHEIGHT, 1..16384 pixels a side")
      ->check(CLI::Validator(
          [](std::string& text) -> std::string {
            int w = 0, h = 0;
            return parse_size(text, w, h) ? std::string() : "expected WIDTHxHEIGHT, each 1..16384, got '" + text + "'";
          },
          ""))
      ->type_name("WxH")
      ->capture_default_str();
  app->add_option("--eye", o->eye, "Camera position x,y,z (default: framing the cloud from +z)")->check(kVec3Validator)->type_name("X,Y,Z");
  app->add_option("--target", o->target, "Point the camera looks at (default: the cloud's centre)")->check(kVec3Validator)->type_name("X,Y,Z");
  app->add_option("--up", o->up, "Camera up vector (default: +y)")->check(kVec3Validator)->type_name("X,Y,Z");
  app->add_option("--fov", o->fov, "Vertical field of view in degrees")->check(number_in(1, 170))
      ->type_name("1..170")->capture_default_str();
  app->add_option("--bandwidth", o->bandwidth, "MLS bandwidth h in point spacings")->check(number_in(0.5, 20))
      ->type_name("0.5..20")->capture_default_str();
  const std::map<std::string, Shade> shades{{"lambert", Shade::kLambert},
                                            {"normal", Shade::kNormal},
                                            {"depth", Shade::kDepth},
                                            {"codeword", Shade::kCodeword}};
  app->add_option("--shade", o->shade,
                  "lambert: diffuse shading; normal: the normal as a colour; depth: nearer is brighter; "
                  "codeword: a colour per code word (compressed models)")
      ->transform(CLI::CheckedTransformer(shades, CLI::ignore_case).description(""))
      ->type_name("lambert|normal|depth|codeword")
      ->default_str("lambert");
  app->add_option("--memory-budget", o->budget_mib,
                  "MiB the scene may hold: a point cloud's points are paged in from a file through a cache of that "
                  "size; a compressed model's decoded bricks are cached within it (default 512)")
      ->check(number_in(1, 1e7))
      ->type_name("1..1e7");
  app->add_option("--lod", o->lod,
                  "Level of detail for a compressed model: where its points lie denser than the pixels, intersect a "
                  "coarser form whose samples span at most this many pixels (0: off, every point)")
      ->check(number_in(0, 64))
      ->type_name("0..64")
      ->capture_default_str();
  app->add_option("--page-dir", o->page_dir, "Folder for the page file of --memory-budget (default: the temp folder)")
      ->check(CLI::Validator(CLI::ExistingDirectory).description(""))
      ->type_name("DIR");
  app->add_option("--camera-path", o->camera_path,
                  "Render a sequence: one camera a line (eye x y z, target x y z [, up x y z [, fov]]); "
                  "frames go to OUT_0000.png, ... and each frame's time to a CSV")
      ->check(CLI::Validator(CLI::ExistingFile).description(""))
      ->type_name("FILE");
  app->add_option("--orbit", o->orbit, "Render a sequence of N frames circling the target (as --camera-path)")
      ->check(CLI::Range(1, 100000).description(""))
      ->type_name("1..100000")
      ->excludes("--camera-path");
  app->add_option("--times", o->times, "The sequence's per-frame CSV (default: OUT with .csv)")->type_name("FILE");
  app->add_option("--compare", o->compare,
                  "A PNG of the same size (or a whole multiple of it each way: a supersampled reference, box-filtered) "
                  "to compare the render with: image PSNR over the pixels both hit, and the "
                  "pixels hit in one only (docs/METRICS.md)")
      ->check(CLI::Validator(CLI::ExistingFile).description(""))
      ->type_name("FILE")
      ->excludes("--camera-path")
      ->excludes("--orbit");
  app->add_flag("-f,--force", o->force, "Overwrite existing output files");
  app->add_flag("--json", o->json, "Machine-readable statistics on stdout (keys: docs/CLI.md)");
  app->footer("Example: sspc render model.sspc -o model.png --size 512x512 --shade codeword");
  return {app, [o, &global] { return run_render(*o, global); }};
}

}  // namespace sspc::cli
