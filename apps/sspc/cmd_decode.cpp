// sspc decode IN.sspc OUT.ply|OUT.las: the whole model, one patch (--patch) or a box (--box), as
// PLY or LAS by the output's extension (or --format on stdout), in the source's world coordinates.
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "command.hpp"
#include "sspc/compressed_model.hpp"
#include "sspc/encoder.hpp"
#include "sspc/io.hpp"

namespace sspc::cli {
namespace {

// Points a chunk of a streamed whole decode: about 40 MB of decoded cloud and as much of PLY.
constexpr std::size_t kDecodeChunkPoints = std::size_t{1} << 20;

struct DecodeCliOptions {
  std::string input;
  std::string output;
  std::string box;
  std::string format = "ply";
  long long patch = -1;
  bool overlap = false;
  bool stored = false;
  bool ascii = false;
  bool force = false;
  bool json = false;
};

// "x0,y0,z0,x1,y1,z1" → a box (min, max corners).
std::optional<Box3f> parse_box(const std::string& text) {
  int commas = 0;
  std::size_t split = std::string::npos;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] == ',' && ++commas == 3) split = i;
  }
  if (commas != 5 || split == std::string::npos) return std::nullopt;
  const auto lo = parse_vec3(text.substr(0, split));
  const auto hi = parse_vec3(text.substr(split + 1));
  if (!lo || !hi || !(lo->array() <= hi->array()).all()) return std::nullopt;
  return Box3f(*lo, *hi);
}

// The model's per-point attributes that the output will not hold: all of them with --overlap
// (whose stored points of several patches have no attributes of their own), those PLY has no
// property for otherwise. A LAS output writes a dropped field as 0, which a reader cannot tell
// from a stored 0, so it is named.
void warn_unwritten(const ModelInfo& m, const DecodeCliOptions& o, bool to_las) {
  std::string dropped;
  auto add = [&dropped](bool present, const char* name) {
    if (!present) return;
    if (!dropped.empty()) dropped += ", ";
    dropped += name;
  };
  add(o.overlap && (m.attributes & kAttributeColour) != 0, "colours");
  add((m.attributes & kAttributeIntensity) != 0, "intensity");
  add((m.attributes & kAttributeClassification) != 0, "classification");
  add((m.attributes & kAttributeReturns) != 0, "returns");
  if (o.overlap) {
    warn_dropped(o.output, std::string("--overlap decodes positions only") + (to_las ? " (LAS writes 0 for each)" : ""),
                 dropped);
  } else if (!to_las) {
    warn_dropped(o.output, "PLY output keeps positions and colours", dropped);
  }
}

int run_decode(const DecodeCliOptions& o, const GlobalOptions& global) {
  if (Status s = check_json_and_stdout(o.json, {o.output}); !s.ok()) return report_usage_error(s);
  if (Status s = check_outputs({o.input}, {o.output}, o.force); !s.ok()) return report_failure(s);
  const auto start = std::chrono::steady_clock::now();
  auto model = open_model(o.input);
  if (!model.ok()) return report_failure(model.status());
  auto progress = make_progress(global);
  progress_stages(progress.get(), 1);
  DecodeOptions options;
  options.overlap = o.overlap;
  options.resample = o.stored ? 0 : -1;
  options.progress = progress.get();

  PlyWriteOptions ply;
  ply.encoding = o.ascii ? PlyEncoding::kAscii : PlyEncoding::kBinaryLittleEndian;
  ply.comments.push_back("decoded by sspc from " +
                         (is_stdio(o.input) ? std::string(kStdinName)
                                            : std::filesystem::path(o.input).filename().string()));
  const std::string extension = cloud_extension(o.output, o.format);
  warn_unwritten(model->info(), o, format_from_extension("decoded" + extension) == PointCloudFormat::kLas);
  std::uint64_t points = 0;
  double decode_seconds = 0;
  const auto since_start = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  if (o.patch < 0 && o.box.empty() && format_from_extension("decoded" + extension) == PointCloudFormat::kPly) {
    // A whole decode to PLY streams: chunks of whole patches go to the file as they are decoded,
    // so a model larger than memory decodes too (the same bytes as the cloud written whole).
    const Status written = write_output(o.output, extension, [&](const std::filesystem::path& path) {
      SSPC_ASSIGN_OR_RETURN(PlyStreamWriter writer, PlyStreamWriter::open(path, ply));
      SSPC_RETURN_IF_ERROR(model->decode_chunks(kDecodeChunkPoints, [&](PointCloud&& chunk) {
        chunk.metadata = model->metadata();
        return writer.write(chunk);
      }, options));
      decode_seconds = since_start();
      points = writer.points();
      return writer.finish();
    });
    progress.reset();
    if (!written.ok()) return report_failure(written);
  } else {
    StatusOr<PointCloud> cloud = invalid_argument("nothing decoded");
    if (o.patch >= 0) {
      cloud = model->decode_patch(static_cast<std::size_t>(o.patch), options);
    } else if (!o.box.empty()) {
      // The box is in world coordinates; the model answers in its local ones.
      const Box3f world = *parse_box(o.box);  // validated by CLI11
      const Vec3d origin = model->origin();
      const Box3f local((world.min().cast<double>() - origin).cast<float>(),
                        (world.max().cast<double>() - origin).cast<float>());
      cloud = model->decode_box(local, options);
    } else {
      cloud = model->decode_all(options);  // LAS: its header's scale needs the whole cloud's bounds
    }
    if (!cloud.ok()) return report_failure(cloud.status());  // names the file already
    cloud->metadata = model->metadata();
    progress.reset();  // finish the progress line before the summary
    decode_seconds = since_start();
    points = cloud->size();
    const Status written = write_output(o.output, extension, [&](const std::filesystem::path& path) {
      return write_point_cloud(*cloud, path, ply);
    });
    if (!written.ok()) return report_failure(written);
  }
  const double seconds = since_start();
  const double rate = decode_seconds > 0 ? static_cast<double>(points) / decode_seconds : 0;

  if (o.json) {
    Json json = json_report("decode");
    json["input"] = o.input;
    json["output"] = o.output;
    json["points"] = points;
    json["decode_seconds"] = decode_seconds;
    json["seconds"] = seconds;
    json["points_per_second"] = rate;
    print_json(json);
  } else if (!global.quiet) {
    std::fprintf(stderr, "%s: %llu points in %.3f s (decode %.1f M points/s)\n",
                 is_stdio(o.output) ? "stdout" : o.output.c_str(), static_cast<unsigned long long>(points), seconds,
                 rate / 1e6);
  }
  return kExitOk;
}

}  // namespace

Command add_decode_command(CLI::App& root, const GlobalOptions& global) {
  auto o = std::make_shared<DecodeCliOptions>();
  CLI::App* app =
      root.add_subcommand("decode",
                          "Decode an .sspc file (all of it, one patch or a box) to PLY or LAS");
  app->add_option("input", o->input, "Compressed model (.sspc; '-' reads stdin)")->required();
  app->add_option("output", o->output, "Point cloud to write (.ply or .las; '-' writes stdout, see --format)")
      ->required();
  add_format_option(app, o->format);
  auto* box =
      app->add_option("--box", o->box, "Only the points in this box")
          ->type_name("X0,Y0,Z0,X1,Y1,Z1")
          ->check(CLI::Validator(
              [](std::string& text) -> std::string {
                return parse_box(text) ? std::string() : "expected six finite numbers, min ≤ max";
              },
              ""));
  app->add_option("--patch", o->patch,
                  "Only patch K (its region, or all its stored points with --overlap)")
      ->type_name("K")
      ->check(CLI::Validator(
          [](std::string& text) -> std::string {
            // Checked before CLI11 converts it, which clamps a number past 2^63 to 2^63 − 1.
            const bool digits = !text.empty() && text.size() <= 18 &&
                                text.find_first_not_of("0123456789") == std::string::npos;
            return digits ? std::string() : "'" + text + "' is not a patch index (a whole number below 10^18)";
          },
          ""))
      ->excludes(box);
  app->add_flag("--overlap", o->overlap,
                "Keep every stored point of every patch, no region test (whole spheres for files "
                "encoded with --full-spheres)");
  app->add_flag("--stored", o->stored,
                "The points as stored, without the resampling a coarse model's header asks for "
                "(docs/FORMAT.md, \"Resampling\")");
  app->add_flag("--ascii", o->ascii, "Write ASCII PLY instead of binary");
  app->add_flag("-f,--force", o->force, "Overwrite the output if it exists");
  app->add_flag("--json", o->json, "Machine-readable summary on stdout (keys: docs/CLI.md)");
  app->footer("Example: sspc decode model.sspc out.ply --box 0,0,0,1,1,1   (or: sspc decode model.sspc - | sspc info -)");
  return {app, [o, &global] { return run_decode(*o, global); }};
}

}  // namespace sspc::cli
