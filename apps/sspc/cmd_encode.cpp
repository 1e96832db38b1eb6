// sspc encode IN OUT.sspc: compress a point cloud by its self-similarity (paper §4;
// docs/FORMAT.md).
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include "command.hpp"
#include "json_writer.hpp"
#include "sspc/encoder.hpp"
#include "sspc/io.hpp"

namespace sspc::cli {
namespace {

struct EncodeCliOptions {
  std::string input;
  std::string output;
  int level = 5;
  int patch_points = 0;
  float epsilon = 0;
  float tau = 0;
  int position_bits = 0;
  NormalMode normals = NormalMode::kAuto;
  std::string viewpoint;
  bool store_normals = false;
  bool full_spheres = false;
  bool force = false;
  bool json = false;
};

int run_encode(const EncodeCliOptions& o, const GlobalOptions& global) {
  if (Status s = check_outputs({o.input}, {o.output}, o.force); !s.ok()) return report_failure(s);
  const auto start = std::chrono::steady_clock::now();
  auto progress = make_progress(global);
  ReadOptions read;
  read.progress = progress.get();
  auto cloud = read_cloud(o.input, read);
  if (!cloud.ok()) return report_failure(cloud.status());
  // The codec keeps positions, normals and colours; a LAS file's own fields are named, not lost
  // silently.
  if (!cloud->las.empty()) {
    std::fprintf(stderr, "sspc: warning: %s: the .sspc model keeps positions%s; dropped %s\n",
                 o.input.c_str(), cloud->has_colors() ? " and colours" : "",
                 cloud->las.names().c_str());
    cloud->las.clear();
  }
  const double read_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  EncodeOptions options;
  options.level = o.level;
  if (o.patch_points > 0) options.patch_points = o.patch_points;
  if (o.epsilon > 0) options.epsilon = o.epsilon;
  if (o.tau > 0) options.tau = o.tau;
  if (o.position_bits > 0) options.position_bits = o.position_bits;
  options.store_normals = o.store_normals;
  options.full_spheres = o.full_spheres;
  options.normals.mode = o.normals;
  options.normals.viewpoint = parse_vec3(o.viewpoint);
  options.progress = progress.get();
  auto stats = encode(std::move(*cloud), o.output, options);
  if (!stats.ok()) return report_failure(stats.status().with_context(o.input));
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double rate = seconds > 0 ? static_cast<double>(stats->points) / seconds : 0;

  if (o.json) {
    JsonWriter json;
    json.begin_object()
        .field("input", o.input)
        .field("output", o.output)
        .field("level", o.level)
        .field("points", stats->points)
        .field("patches", stats->patches)
        .field("codewords", stats->codewords)
        .field("codebook_ratio", stats->codebook_ratio)
        .field("codeword_points", stats->codeword_points)
        .field("untrimmed_codeword_points", stats->untrimmed_codeword_points)
        .field("position_bits", stats->position_bits)
        .field("position_step", stats->position_step)
        .field("spacing", stats->spacing)
        .field("patch_radius", stats->patch_radius)
        .field("coverage_radius", stats->coverage_radius)
        .field("max_coverage_distance", stats->max_coverage_distance)
        .field("covered", stats->max_coverage_distance <= stats->coverage_radius)
        .field("candidates_tested", stats->candidates_tested)
        .field("file_bytes", stats->file_bytes)
        .field("codebook_bytes", stats->codebook_bytes)
        .field("patch_bytes", stats->patch_bytes)
        .field("bits_per_point", stats->bits_per_point)
        .field("read_seconds", read_seconds)
        .field("normals_seconds", stats->seconds_normals)
        .field("centres_seconds", stats->seconds_centres)
        .field("codebook_seconds", stats->seconds_codebook)
        .field("descriptors_seconds", stats->seconds_descriptors)
        .field("clustering_seconds", stats->seconds_codebook - stats->seconds_descriptors)
        .field("write_seconds", stats->seconds_writing)
        .field("seconds", seconds)
        .field("points_per_second", rate)
        .end_object();
    print_line(json.str());
  } else {
    std::printf("%s: %llu points -> %s: %llu bytes (%.3f bpp), %llu patches, %llu code words (ratio %.1f), %.2f s (%.3g points/s)\n",
                o.input.c_str(), static_cast<unsigned long long>(stats->points), o.output.c_str(),
                static_cast<unsigned long long>(stats->file_bytes), stats->bits_per_point,
                static_cast<unsigned long long>(stats->patches), static_cast<unsigned long long>(stats->codewords),
                stats->codebook_ratio, seconds, rate);
  }
  return kExitOk;
}

}  // namespace

Command add_encode_command(CLI::App& root, const GlobalOptions& global) {
  auto o = std::make_shared<EncodeCliOptions>();
  CLI::App* app = root.add_subcommand("encode", "Compress a point cloud into an .sspc file");
  app->add_option("input", o->input, "Point cloud to read (PLY, XYZ/PTS, PCD)")->required();
  app->add_option("output", o->output, "Compressed model to write (.sspc)")->required();
  app->add_option("-l,--level", o->level, "0 (most detail) .. 9 (smallest file)")
      ->check(CLI::Range(0, 9))
      ->capture_default_str();
  app->add_option("--patch-points", o->patch_points, "Expected points per patch (overrides the level)")
      ->check(CLI::Range(8, 4096));
  app->add_option("--epsilon", o->epsilon, "Descriptor L1 radius (overrides the level)")
      ->check(number_in(0, 1000, true));
  app->add_option("--tau", o->tau, "MLS error threshold in point spacings (overrides the level)")
      ->check(number_in(0, 1000, true));
  app->add_option("--position-bits", o->position_bits,
                  "Code-word grid: 2 patch radii in 2^bits steps (overrides the level's step)")
      ->check(CLI::Range(4, 16));
  app->add_flag("--store-normals", o->store_normals,
                "Store the code words' normals too (positions only by default)");
  app->add_flag("--full-spheres", o->full_spheres,
                "Keep each code word's whole sphere (the paper's layout); by default points no "
                "instance decodes are dropped");
  const std::map<std::string, NormalMode> modes{
      {"auto", NormalMode::kAuto}, {"keep", NormalMode::kKeep}, {"estimate", NormalMode::kEstimate}};
  app->add_option("--normals", o->normals, "auto: the file's normals if any, else estimate; keep; estimate")
      ->transform(CLI::CheckedTransformer(modes, CLI::ignore_case))
      ->default_str("auto");
  app->add_option("--viewpoint", o->viewpoint, "Orient estimated normals towards this point")
      ->check(kVec3Validator);
  app->add_flag("-f,--force", o->force, "Overwrite an existing output file");
  app->add_flag("--json", o->json, "Machine-readable statistics on stdout");
  return {app, [o, &global] { return run_encode(*o, global); }};
}

}  // namespace sspc::cli
