// sspc encode IN OUT.sspc: compress a point cloud by its self-similarity (paper §4;
// docs/FORMAT.md). IN or OUT may be "-" (stdin, stdout).
#include <algorithm>
#include <chrono>
#include <cstring>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "command.hpp"
#include "sspc/encoder.hpp"
#include "sspc/io.hpp"
#include "sspc/metrics.hpp"
#include "sspc/tiled_encoder.hpp"

namespace sspc::cli {
namespace {

struct EncodeCliOptions {
  std::vector<std::string> inputs;
  std::string output;
  int level = 5;
  int patch_points = 0;
  float epsilon = 0;
  float tau = 0;
  int position_bits = 0;
  float step = 0;
  NormalMode normals = NormalMode::kAuto;
  std::string viewpoint;
  bool store_normals = false;
  bool full_spheres = false;
  bool keep_duplicates = false;
  std::string resample = "auto";
  std::string attributes = "all";
  int colour_quality = EncodeOptions().colour_quality;
  int intensity_step = 1;
  std::uint64_t tile_points = 0;
  std::optional<std::string> memory_limit;  // given, even as '', is parsed
  bool force = false;
  bool json = false;
};

// --attributes: "all", "none" or a comma-separated list of names.
StatusOr<unsigned> parse_attributes(const std::string& text) {
  if (text == "all") return kAllAttributes;
  if (text == "none") return 0u;
  static const std::map<std::string, unsigned> names{{"colour", kAttributeColour},
                                                     {"intensity", kAttributeIntensity},
                                                     {"classification", kAttributeClassification},
                                                     {"returns", kAttributeReturns}};
  unsigned bits = 0;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t end = std::min(text.find(',', start), text.size());
    const std::string name = text.substr(start, end - start);
    const auto it = names.find(name);
    if (it == names.end()) {
      return invalid_argument("--attributes: unknown attribute '" + name +
                              "' (all, none, or a list of colour, intensity, classification, returns)");
    }
    bits |= it->second;
    start = end + 1;
  }
  return bits;
}

// --memory-limit: bytes, or a number with K, M, G or T (powers of 1024; "2G", "1.5G", "512MiB").
StatusOr<std::uint64_t> parse_size(const std::string& text) {
  std::size_t used = 0;
  double value = 0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  std::string unit = text.substr(used);
  for (const char* suffix : {"iB", "B"}) {
    if (unit.size() > 1 && unit.ends_with(suffix)) unit.resize(unit.size() - std::strlen(suffix));
  }
  static const std::map<std::string, double> units{{"", 1.0}, {"K", 0x1p10}, {"k", 0x1p10}, {"M", 0x1p20},
                                                   {"G", 0x1p30}, {"T", 0x1p40}};
  const auto it = units.find(unit);
  const double bytes = value * (it == units.end() ? 0.0 : it->second);
  if (used == 0 || it == units.end() || !(bytes >= 1) || bytes > 0x1p62) {
    return invalid_argument("--memory-limit: '" + text + "' is not a size (bytes, or a number with K, M, G or T)");
  }
  return static_cast<std::uint64_t>(bytes);
}

// The stages encode() begins (src/encoder): normals when it estimates them (neighbours, PCA,
// orientation), the patch centres (three), patches and descriptors, the code book, writing.
int encode_stages(const PointCloud& cloud, NormalMode mode) {
  const bool estimate = mode == NormalMode::kEstimate || (mode == NormalMode::kAuto && !cloud.has_normals());
  return (estimate ? 3 : 0) + 3 + 1 + 1 + 1;
}

int run_encode(const EncodeCliOptions& o, const GlobalOptions& global) {
  if (Status s = check_json_and_stdout(o.json, {o.output}); !s.ok()) return report_usage_error(s);
  if (o.inputs.size() > 1 && std::count_if(o.inputs.begin(), o.inputs.end(), is_stdio) > 0) {
    return report_usage_error(invalid_argument("'-' (stdin) cannot be one of several inputs"));
  }
  std::vector<std::filesystem::path> files{std::filesystem::path(o.inputs.front())};
  if (!is_stdio(o.inputs.front())) {
    auto listed = input_files(o.inputs);
    if (!listed.ok()) return report_failure(listed.status());
    files = std::move(*listed);
  }
  std::vector<std::string> names;
  for (const auto& file : files) names.push_back(file.string());
  if (Status s = check_outputs(names, {o.output}, o.force); !s.ok()) return report_failure(s);
  if (!is_stdio(o.output) && format_from_extension(o.output) != PointCloudFormat::kAuto) {
    // Every reader would take the model for a point cloud of that format and refuse it.
    return report_usage_error(invalid_argument(o.output + ": a compressed model under a point-cloud extension ('" +
                                               std::filesystem::path(o.output).extension().string() +
                                               "'); name it .sspc"));
  }
  const auto start = std::chrono::steady_clock::now();
  auto progress = make_progress(global);
  // With --normals auto the count depends on the file: unknown until it is read.
  if (o.normals != NormalMode::kAuto) progress_stages(progress.get(), 1 + encode_stages(PointCloud(), o.normals));
  auto keep = parse_attributes(o.attributes);
  if (!keep.ok()) return report_usage_error(keep.status());
  EncodeOptions options;
  options.level = o.level;
  if (o.patch_points > 0) options.patch_points = o.patch_points;
  if (o.epsilon > 0) options.epsilon = o.epsilon;
  if (o.tau > 0) options.tau = o.tau;
  if (o.position_bits > 0) options.position_bits = o.position_bits;
  if (o.step > 0) options.step = o.step;
  options.store_normals = o.store_normals;
  options.full_spheres = o.full_spheres;
  options.keep_duplicates = o.keep_duplicates;
  options.resample = o.resample == "auto" ? -1 : o.resample == "off" ? 0 : std::stoi(o.resample);
  options.attributes = *keep;
  options.colour_quality = o.colour_quality;
  options.intensity_step = o.intensity_step;
  options.tile_points = o.tile_points;
  options.normals.mode = o.normals;
  options.normals.viewpoint = parse_vec3(o.viewpoint);
  options.progress = progress.get();
  if (o.memory_limit) {
    auto limit = parse_size(*o.memory_limit);
    if (!limit.ok()) return report_usage_error(limit.status());
    if (is_stdio(o.inputs.front())) {
      return report_usage_error(invalid_argument("--memory-limit reads its input in passes: give a file, not stdin"));
    }
    options.memory_limit = *limit;
  }
  ReadOptions read;
  read.progress = progress.get();
  const std::string input_name = is_stdio(names.front())  ? std::string(kStdinName)
                                 : names.size() == 1      ? names.front()
                                                          : names.front() + " and " + std::to_string(names.size() - 1) +
                                                           (names.size() == 2 ? " more file" : " more files");
  StatusOr<EncodeStats> stats = invalid_argument("nothing encoded");
  Status written;
  double read_seconds = 0;  // with --memory-limit the passes over the input are the plan's
  if (options.memory_limit > 0) {
    // Tiles sized to the limit, the input read in passes and never held (TiledEncoder::plan_files).
    written = write_output(o.output, ".sspc", [&](const std::filesystem::path& path) {
      const std::filesystem::path dir = path.parent_path().empty() ? std::filesystem::path(".") : path.parent_path();
      auto tiled = TiledEncoder::plan_files(files, options, read, dir);
      if (!tiled.ok()) return tiled.status().with_context(input_name);
      if (!tiled->dropped_fields().empty()) {
        std::fprintf(stderr, "sspc: warning: %s: not kept in the .sspc model: %s\n", input_name.c_str(),
                     tiled->dropped_fields().c_str());
      }
      stats = tiled->run(path, progress.get());
      return stats.ok() ? Status() : stats.status().with_context(input_name);
    });
  } else {
    auto cloud = read_clouds(files, read);
    if (!cloud.ok()) return report_failure(cloud.status());
    // The fields the codec does not keep, or was told not to, are named, not lost silently.
    if (const std::string dropped = drop_unkept_attributes(*cloud, *keep); !dropped.empty()) {
      std::fprintf(stderr, "sspc: warning: %s: not kept in the .sspc model: %s\n", input_name.c_str(),
                   dropped.c_str());
    }
    progress_stages(progress.get(), 1 + encode_stages(*cloud, o.normals));
    read_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    written = write_output(o.output, ".sspc", [&](const std::filesystem::path& path) {
      stats = encode(std::move(*cloud), path, options);
      return stats.ok() ? Status() : stats.status().with_context(input_name);
    });
  }
  if (!written.ok()) return report_failure(written);
  progress.reset();  // finish the progress line before the summary
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double rate = seconds > 0 ? static_cast<double>(stats->points) / seconds : 0;

  if (o.json) {
    Json json = json_report("encode");
    json["input"] = o.inputs.front();
    json["input_files"] = files.size();
    json["output"] = o.output;
    json["level"] = o.level;
    json["points"] = stats->points;
    json["patches"] = stats->patches;
    json["codewords"] = stats->codewords;
    json["codebook_ratio"] = stats->codebook_ratio;
    json["codeword_points"] = stats->codeword_points;
    json["untrimmed_codeword_points"] = stats->untrimmed_codeword_points;
    json["position_bits"] = stats->position_bits;
    json["position_step"] = stats->position_step;
    json["resample"] = stats->resample;
    json["spacing"] = stats->spacing;
    json["patch_radius"] = stats->patch_radius;
    json["coverage_radius"] = stats->coverage_radius;
    json["max_coverage_distance"] = stats->max_coverage_distance;
    json["covered"] = stats->max_coverage_distance <= stats->coverage_radius;
    json["candidates_tested"] = stats->candidates_tested;
    json["file_bytes"] = stats->file_bytes;
    json["codebook_bytes"] = stats->codebook_bytes;
    json["patch_bytes"] = stats->patch_bytes;
    json["attribute_bytes"] = stats->attribute_bytes;
    json["colour_bytes"] = stats->colour_bytes;
    json["intensity_bytes"] = stats->intensity_bytes;
    json["classification_bytes"] = stats->classification_bytes;
    json["returns_bytes"] = stats->returns_bytes;
    json["colour_step"] = stats->colour_step;
    json["tiles"] = stats->tiles;
    json["geometry_bits_per_point"] =
        bits_per_point(stats->file_bytes - stats->attribute_bytes, stats->points);
    json["bits_per_point"] = stats->bits_per_point;
    json["read_seconds"] = read_seconds;
    json["normals_seconds"] = stats->seconds_normals;
    json["centres_seconds"] = stats->seconds_centres;
    json["codebook_seconds"] = stats->seconds_codebook;
    json["descriptors_seconds"] = stats->seconds_descriptors;
    json["clustering_seconds"] = stats->seconds_codebook - stats->seconds_descriptors;
    json["write_seconds"] = stats->seconds_writing;
    json["seconds"] = seconds;
    json["points_per_second"] = rate;
    print_json(json);
  } else if (!global.quiet) {
    std::fprintf(summary_stream({o.output}),
                 "%s: %llu points -> %s: %llu bytes (%.3f bits per point), %llu patches, %llu code words (ratio %.1f), "
                 "%.2f s (%.3g points/s)\n",
                 input_name.c_str(), static_cast<unsigned long long>(stats->points),
                 is_stdio(o.output) ? "stdout" : o.output.c_str(), static_cast<unsigned long long>(stats->file_bytes),
                 stats->bits_per_point, static_cast<unsigned long long>(stats->patches),
                 static_cast<unsigned long long>(stats->codewords), stats->codebook_ratio, seconds, rate);
  }
  return kExitOk;
}

}  // namespace

Command add_encode_command(CLI::App& root, const GlobalOptions& global) {
  auto o = std::make_shared<EncodeCliOptions>();
  CLI::App* app = root.add_subcommand("encode", "Compress a point cloud into an .sspc file");
  // One positional list, the last the output: CLI11 gives a list positional every argument, the
  // output's too.
  app->add_option("input", o->inputs,
                  "Point clouds to read (PLY, LAS, XYZ/PTS, PCD; '-' reads stdin), then the compressed model to write "
                  "(.sspc; '-' writes stdout). Several files, a folder or a quoted pattern ('tiles/*.las') are read as "
                  "one cloud, in name order")
      ->type_name("IN... OUT")
      ->required()
      ->expected(2, -1);
  app->add_option("-l,--level", o->level, "0 (most detail) .. 9 (smallest file)")
      ->check(CLI::Range(0, 9).description(""))
      ->type_name("0..9")
      ->capture_default_str();
  app->add_option("--patch-points", o->patch_points, "Expected points per patch sphere (overrides the level's, which doubles past 4.2M points and again past 8.4M, and at levels 8 and 9 once more)")
      ->check(CLI::Range(8, kMaxPatchPoints).description(""))
      ->type_name("8.." + std::to_string(kMaxPatchPoints));
  app->add_option("--epsilon", o->epsilon, "Descriptor L1 radius (overrides the level)")
      ->check(number_in(0, 1000, true))
      ->type_name("0<X<=1000");
  app->add_option("--tau", o->tau, "MLS error threshold in point spacings (overrides the level)")
      ->check(number_in(0, 1000, true))
      ->type_name("0<X<=1000");
  app->add_option("--step", o->step, "Code-word grid step in point spacings (overrides the level; at most an eighth of the patch radius)")
      ->check(number_in(0, 1000, true))
      ->type_name("0<X<=1000");
  app->add_option("--position-bits", o->position_bits,
                  "Code-word grid: 2 patch radii in 2^bits steps (overrides the level's step)")
      ->check(CLI::Range(4, 16).description(""))
      ->type_name("4..16");
  app->add_flag("--store-normals", o->store_normals,
                "Store the code words' normals too (positions only by default)");
  app->add_flag("--full-spheres", o->full_spheres,
                "Keep each code word's whole sphere (the paper's layout); by default points no "
                "instance decodes are dropped");
  app->add_flag("--keep-duplicates", o->keep_duplicates,
                "Store every point, also several in one cell of the code words' grid (by default a cell keeps one)");
  app->add_option("--resample", o->resample,
                  "Decoded points a stored point stands for, per side, on its code word's surface "
                  "(docs/FORMAT.md, \"Resampling\"): auto (the m that decodes closest to the input, "
                  "measured on a sample of patches), off, or 1-4")
      ->check(CLI::IsMember({"auto", "off", "1", "2", "3", "4"}).description(""))
      ->type_name("auto|off|1..4")
      ->capture_default_str();
  app->add_option("--tile-points", o->tile_points,
                  "Encode in octree tiles of at most N points, each with a margin of its neighbours', "
                  "joined into one model (0: the whole cloud at once)")
      ->check(CLI::NonNegativeNumber.description(""))
      ->type_name("N");
  app->add_option("--memory-limit", o->memory_limit,
                  "Hold at most about SIZE bytes (e.g. 2G): the input is read in passes, never whole, and "
                  "encoded in octree tiles sized to the limit, which wait in files beside the output")
      ->type_name("SIZE");
  app->add_option("--attributes", o->attributes,
                  "Per-point attributes to keep, of those the input has: all, none, or a list of "
                  "colour, intensity, classification, returns")
      ->type_name("LIST")
      ->capture_default_str();
  app->add_option("--colour-quality", o->colour_quality,
                  "Colour quality: 100 is lossless, every ~17 less halves the colour step")
      ->check(CLI::Range(0, 100).description(""))
      ->type_name("0..100")
      ->capture_default_str();
  app->add_option("--intensity-step", o->intensity_step, "LAS intensity quantisation step (1: lossless)")
      ->check(CLI::Range(1, 4096).description(""))
      ->type_name("1..4096")
      ->capture_default_str();
  const std::map<std::string, NormalMode> modes{
      {"auto", NormalMode::kAuto}, {"keep", NormalMode::kKeep}, {"estimate", NormalMode::kEstimate}};
  app->add_option("--normals", o->normals,
                  "auto: the file's normals if any, else estimate them; keep: require the file's; estimate: "
                  "always estimate")
      ->transform(CLI::CheckedTransformer(modes, CLI::ignore_case).description(""))
      ->type_name("auto|keep|estimate")
      ->default_str("auto");
  app->add_option("--viewpoint", o->viewpoint, "Orient estimated normals towards this point")
      ->check(kVec3Validator)->type_name("X,Y,Z");
  app->add_flag("-f,--force", o->force, "Overwrite an existing output file");
  app->add_flag("--json", o->json, "Machine-readable statistics on stdout (keys: docs/CLI.md)");
  app->footer("Example: sspc encode scan.ply model.sspc --level 7   (or: cat scan.ply | sspc encode - model.sspc)");
  return {app, [o, &global] {
            o->output = o->inputs.back();
            o->inputs.pop_back();
            return run_encode(*o, global);
          }};
}

}  // namespace sspc::cli
