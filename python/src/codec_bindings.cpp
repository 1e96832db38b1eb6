// sspc.encode and sspc.CompressedModel: the codec of the paper's §4 and the random access of the
// .sspc format (docs/FORMAT.md).
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>
#include <unistd.h>

#include "conversions.hpp"
#include "sspc/allocator.hpp"
#include "sspc/compressed_model.hpp"
#include "sspc/encoder.hpp"
#include "sspc/tiled_encoder.hpp"

namespace sspc::python {
namespace {

NormalMode normal_mode(const std::string& name) {
  if (name == "auto") return NormalMode::kAuto;
  if (name == "keep") return NormalMode::kKeep;
  if (name == "estimate") return NormalMode::kEstimate;
  throw py::value_error("normals must be 'auto', 'keep' or 'estimate', got '" + name + "'");
}

// The keys of `sspc encode --json`, less the input and the reading time.
py::dict encode_stats(const EncodeStats& s, int level, double seconds) {
  py::dict d;
  d["level"] = level;
  d["points"] = s.points;
  d["patches"] = s.patches;
  d["codewords"] = s.codewords;
  d["codebook_ratio"] = s.codebook_ratio;
  d["codeword_points"] = s.codeword_points;
  d["untrimmed_codeword_points"] = s.untrimmed_codeword_points;
  d["position_bits"] = s.position_bits;
  d["position_step"] = s.position_step;
  d["resample"] = s.resample;
  d["spacing"] = s.spacing;
  d["patch_radius"] = s.patch_radius;
  d["coverage_radius"] = s.coverage_radius;
  d["max_coverage_distance"] = s.max_coverage_distance;
  d["covered"] = s.max_coverage_distance <= s.coverage_radius;
  d["candidates_tested"] = s.candidates_tested;
  d["file_bytes"] = s.file_bytes;
  d["codebook_bytes"] = s.codebook_bytes;
  d["patch_bytes"] = s.patch_bytes;
  d["attribute_bytes"] = s.attribute_bytes;
  d["colour_bytes"] = s.colour_bytes;
  d["intensity_bytes"] = s.intensity_bytes;
  d["classification_bytes"] = s.classification_bytes;
  d["returns_bytes"] = s.returns_bytes;
  d["colour_step"] = s.colour_step;
  d["tiles"] = s.tiles;
  d["bits_per_point"] = s.bits_per_point;
  d["normals_seconds"] = s.seconds_normals;
  d["centres_seconds"] = s.seconds_centres;
  d["codebook_seconds"] = s.seconds_codebook;
  d["descriptors_seconds"] = s.seconds_descriptors;
  d["clustering_seconds"] = s.seconds_codebook - s.seconds_descriptors;
  d["write_seconds"] = s.seconds_writing;
  d["seconds"] = seconds;
  d["points_per_second"] = seconds > 0 ? static_cast<double>(s.points) / seconds : 0.0;
  return d;
}

// The library writes .sspc files only; bytes are encoded to a private temporary file, read back
// and the file removed.
class ScratchFile {
 public:
  ScratchFile() {
    static std::atomic<unsigned> counter{0};
    path_ = std::filesystem::temp_directory_path() /
            ("sspc-python-" + std::to_string(::getpid()) + "-" + std::to_string(counter++) + ".sspc");
  }
  ~ScratchFile() {
    std::error_code ec;
    std::filesystem::remove(path_, ec);
  }
  ScratchFile(const ScratchFile&) = delete;
  ScratchFile& operator=(const ScratchFile&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

StatusOr<std::string> read_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  if (!in || !bytes) return io_error(path.string() + ": cannot read back the encoded file");
  return std::move(bytes).str();
}

// "all", "none", or names among colour, intensity, classification, returns (a list or a
// comma-separated string), as `sspc encode --attributes`.
unsigned attribute_bits(const py::object& value) {
  std::vector<std::string> names;
  if (py::isinstance<py::str>(value)) {
    const std::string text = value.cast<std::string>();
    if (text == "all") return kAllAttributes;
    if (text == "none") return 0;
    std::size_t start = 0;
    while (start <= text.size()) {
      const std::size_t end = std::min(text.find(',', start), text.size());
      names.push_back(text.substr(start, end - start));
      start = end + 1;
    }
  } else {
    for (const py::handle item : value) names.push_back(py::str(item).cast<std::string>());
  }
  unsigned bits = 0;
  for (const std::string& name : names) {
    if (name == "colour") bits |= kAttributeColour;
    else if (name == "intensity") bits |= kAttributeIntensity;
    else if (name == "classification") bits |= kAttributeClassification;
    else if (name == "returns") bits |= kAttributeReturns;
    else throw py::value_error("attributes: unknown attribute '" + name +
                               "' (all, none, or colour, intensity, classification, returns)");
  }
  return bits;
}

// A str or os.PathLike argument as a path.
std::filesystem::path file_path(py::handle h) { return h.cast<std::filesystem::path>(); }

bool is_path(const py::handle& h) { return py::isinstance<py::str>(h) || py::hasattr(h, "__fspath__"); }

// A path, or a list or tuple of paths (several files read as one cloud): the files, expanded as
// `sspc encode` expands its arguments (folders, patterns); nullopt for anything else (a cloud).
std::optional<std::vector<std::filesystem::path>> input_paths(const py::object& given) {
  std::vector<std::string> args;
  if (is_path(given)) {
    args.push_back(file_path(given).string());
  } else if (py::isinstance<py::list>(given) || py::isinstance<py::tuple>(given)) {
    const py::sequence items = py::reinterpret_borrow<py::sequence>(given);
    if (items.size() == 0 || !std::all_of(items.begin(), items.end(), [](const py::handle& h) { return is_path(h); })) {
      return std::nullopt;
    }
    for (const py::handle& item : items) args.push_back(file_path(item).string());
  } else {
    return std::nullopt;
  }
  return value_or_raise(input_files(args));
}

// resample='auto', 'off' or 1..4, as `sspc encode --resample` (EncodeOptions::resample).
int resample_option(const py::object& value) {
  if (py::isinstance<py::str>(value)) {
    const std::string name = value.cast<std::string>();
    if (name == "auto") return -1;
    if (name == "off") return 0;
  } else if (py::isinstance<py::int_>(value) && !py::isinstance<py::bool_>(value)) {
    const long long m = value.cast<long long>();
    if (m >= 0 && m <= 4) return static_cast<int>(m);
  }
  throw py::value_error("resample: 'auto', 'off' or 0..4, not " + py::repr(value).cast<std::string>());
}

// The options encode() and TiledEncoder take, from their shared keyword arguments (option_args).
EncodeOptions make_options(int level, std::optional<int> patch_points, std::optional<float> epsilon,
                           std::optional<float> tau, std::optional<float> step, std::optional<int> position_bits,
                           bool store_normals, bool full_spheres, bool keep_duplicates, const py::object& resample,
                           const py::object& attributes, int colour_quality, int intensity_step, std::uint64_t tile_points, std::uint64_t memory_limit,
                           const std::string& normals, const py::object& viewpoint, std::uint64_t seed) {
  EncodeOptions options;
  options.level = level;
  options.patch_points = patch_points;
  options.epsilon = epsilon;
  options.tau = tau;
  options.step = step;
  options.position_bits = position_bits;
  options.store_normals = store_normals;
  options.full_spheres = full_spheres;
  options.keep_duplicates = keep_duplicates;
  options.resample = resample_option(resample);
  options.attributes = attribute_bits(attributes);
  options.colour_quality = colour_quality;
  options.intensity_step = intensity_step;
  options.tile_points = tile_points;
  options.memory_limit = memory_limit;
  options.normals.mode = normal_mode(normals);
  if (!viewpoint.is_none()) options.normals.viewpoint = vec3(viewpoint, "viewpoint");
  options.seed = seed;
  return options;
}

auto option_args() {
  return std::make_tuple(
      py::arg("level") = 5, py::arg("patch_points") = py::none(), py::arg("epsilon") = py::none(),
      py::arg("tau") = py::none(), py::arg("step") = py::none(), py::arg("position_bits") = py::none(),
      py::arg("store_normals") = false, py::arg("full_spheres") = false, py::arg("keep_duplicates") = false,
      py::arg("resample") = "auto", py::arg("attributes") = "all", py::arg("colour_quality") = EncodeOptions().colour_quality,
      py::arg("intensity_step") = 1, py::arg("tile_points") = 0, py::arg("memory_limit") = 0, py::arg("normals") = "auto",
      py::arg("viewpoint") = py::none(), py::arg("seed") = 1);
}

py::object encode_cloud(const py::object& cloud_or_positions, const std::optional<std::filesystem::path>& path,
                        int level, std::optional<int> patch_points, std::optional<float> epsilon,
                        std::optional<float> tau, std::optional<float> step, std::optional<int> position_bits, bool store_normals,
                        bool full_spheres, bool keep_duplicates, const py::object& resample,
                        const py::object& attributes, int colour_quality,
                        int intensity_step, std::uint64_t tile_points, std::uint64_t memory_limit, const std::string& normals,
                        const py::object& viewpoint,
                        std::uint64_t seed, int threads, const py::object& progress) {
  // Files: encode_files reads them (in passes, never whole, under memory_limit).
  const std::optional<std::vector<std::filesystem::path>> inputs = input_paths(cloud_or_positions);
  const bool from_file = inputs.has_value();
  PointCloud cloud;
  if (!from_file) {
    if (memory_limit > 0) {
      throw py::value_error("memory_limit reads the input in passes: give the cloud as a file's path (or a list of "
                            "paths), not in memory, where it is held whole already");
    }
    cloud = cloud_from(cloud_or_positions, "cloud");
    check(cloud.validate());
  } else if (memory_limit == 0) {
    cloud = value_or_raise(without_gil([&] { return read_point_clouds(*inputs); }));
  }
  EncodeOptions options = make_options(level, patch_points, epsilon, tau, step, position_bits, store_normals,
                                       full_spheres, keep_duplicates, resample, attributes, colour_quality, intensity_step,
                                       tile_points, memory_limit, normals, viewpoint, seed);
  CallbackProgress reporter(progress);
  options.progress = reporter.get();
  ThreadLimit limit(threads);

  std::optional<ScratchFile> scratch;
  if (!path) scratch.emplace();
  const std::filesystem::path& output = path ? *path : scratch->path();
  const auto start = std::chrono::steady_clock::now();
  auto stats = without_gil([&] {
    return from_file && memory_limit > 0 ? encode_files(*inputs, output, options)
                                         : encode(std::move(cloud), output, options);
  });
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  reporter.rethrow();
  const EncodeStats s = value_or_raise(std::move(stats));
  if (path) return encode_stats(s, level, seconds);
  const std::string bytes = value_or_raise(without_gil([&] { return read_bytes(output); }));
  return py::bytes(bytes);
}

py::dict model_info(const CompressedModel& model) {
  const ModelInfo m = model.info();
  py::dict d;
  d["format"] = "sspc";
  d["version"] = m.version;
  d["file_bytes"] = m.file_bytes;
  d["normals"] = m.has_normals;
  d["colours"] = m.has_colours;
  d["intensity"] = (m.attributes & kAttributeIntensity) != 0;
  d["classification"] = (m.attributes & kAttributeClassification) != 0;
  d["returns"] = (m.attributes & kAttributeReturns) != 0;
  d["colour_step"] = m.colour_step;
  d["intensity_step"] = m.intensity_step;
  d["attribute_bytes"] = m.attribute_bytes;
  d["source_points"] = m.source_points;
  d["patches"] = m.patches;
  d["codewords"] = m.codewords;
  d["codeword_points"] = m.codeword_points;
  d["overlap_points"] = m.overlap_points;
  d["codebook_ratio"] = m.codebook_ratio;
  d["bits_per_point"] = m.bits_per_point;
  d["patch_radius"] = m.patch_radius;
  d["coverage_radius"] = m.coverage_radius;
  d["codeword_radius"] = m.codeword_radius;
  d["spacing"] = m.spacing;
  d["bbox_min"] = py::make_tuple(m.bounds.min().x(), m.bounds.min().y(), m.bounds.min().z());
  d["bbox_max"] = py::make_tuple(m.bounds.max().x(), m.bounds.max().y(), m.bounds.max().z());
  d["position_bits"] = m.position_bits;
  d["normal_bits"] = m.normal_bits;
  d["rotation_bits"] = m.rotation_bits;
  d["translation_step"] = m.translation_step;
  d["resample"] = m.resample;
  d["patches_per_block"] = m.patches_per_block;
  d["codewords_per_block"] = m.codewords_per_block;
  py::list sections;
  py::dict header;
  header["name"] = "header";
  header["offset"] = 0;
  header["bytes"] = m.header_bytes;
  sections.append(header);
  for (const SectionInfo& s : m.sections) {
    py::dict section;
    section["name"] = s.name;
    section["offset"] = s.offset;
    section["bytes"] = s.bytes;
    section["raw_bytes"] = s.raw_bytes;
    section["blocks"] = s.blocks;
    sections.append(section);
  }
  d["sections"] = sections;
  return d;
}

std::size_t checked_index(py::ssize_t i, std::size_t count, const char* what) {
  if (i < 0 || static_cast<std::size_t>(i) >= count) {
    throw py::index_error(std::string(what) + " " + std::to_string(i) + " out of range: the model has " +
                          std::to_string(count));
  }
  return static_cast<std::size_t>(i);
}

py::dict patch_record(const CompressedModel& model, py::ssize_t k) {
  const std::size_t index = checked_index(k, model.patch_count(), "patch");
  const PatchRecord p = value_or_raise(model.patch(index));
  py::array_t<float> rotation({py::ssize_t{3}, py::ssize_t{3}});
  auto r = rotation.mutable_unchecked<2>();
  for (py::ssize_t i = 0; i < 3; ++i) {
    for (py::ssize_t j = 0; j < 3; ++j) r(i, j) = p.rotation(i, j);
  }
  py::array_t<float> translation(py::ssize_t{3});
  for (py::ssize_t i = 0; i < 3; ++i) translation.mutable_at(i) = p.translation(i);
  py::dict d;
  d["codeword"] = p.codeword;
  d["rotation"] = rotation;
  d["translation"] = translation;
  return d;
}

py::dict codeword(const CompressedModel& model, py::ssize_t c) {
  const std::size_t index = checked_index(c, model.codeword_count(), "code word");
  CodewordData data = value_or_raise(without_gil([&] { return model.codeword(index); }));
  py::dict d;
  d["points"] = py::cast(std::move(data.points));
  d["radius"] = data.radius;
  return d;
}

// The buffer's bytes in logical order: a strided or reversed view (numpy's a[::-1], a[::2]) is
// gathered through its strides by CPython's PyBuffer_ToContiguous, never read as if contiguous
// from its first element (which, for a negative stride, lies at the end of its memory).
std::string buffer_bytes(const py::buffer& buffer) {
  Py_buffer view;
  if (PyObject_GetBuffer(buffer.ptr(), &view, PyBUF_FULL_RO) != 0) throw py::error_already_set();
  std::string bytes;
  try {
    bytes.resize(static_cast<std::size_t>(view.len));
  } catch (...) {
    PyBuffer_Release(&view);
    throw;
  }
  const int copied = PyBuffer_ToContiguous(bytes.data(), &view, view.len, 'C');
  PyBuffer_Release(&view);
  if (copied != 0) throw py::error_already_set();
  return bytes;
}

CompressedModel from_buffer(const py::buffer& buffer) {
  std::string bytes = buffer_bytes(buffer);
  return value_or_raise(without_gil([&] { return CompressedModel::from_bytes(std::move(bytes)); }));
}

DecodeOptions decode_options(bool overlap, bool stored) {
  DecodeOptions options;
  options.overlap = overlap;
  options.resample = stored ? 0 : -1;
  return options;
}

void bind_compressed_model(py::module_& m) {
  py::class_<CompressedModel>(m, "CompressedModel", R"doc(
An .sspc file opened for random access: one patch, one code word, one box or the whole model,
decoded without reading more of the file than the answer needs (the file is memory-mapped).

Build one with CompressedModel.open(path) or CompressedModel.from_bytes(data). Every method may
be called from several Python threads at once; each releases the GIL while it decodes. A corrupt
file raises RuntimeError ("corrupt: ...") naming the section, block and byte offset.)doc")
      .def_static(
          "open",
          [](const std::filesystem::path& path) {
            return value_or_raise(without_gil([&] { return CompressedModel::open(path); }));
          },
          py::arg("path"),
          "Maps the file and checks its header and seek tables (not the blocks: see verify()). Raises "
          "FileNotFoundError for a missing file.")
      .def_static("from_bytes", &from_buffer, py::arg("data"),
                  "The same over bytes in memory (any buffer: bytes, bytearray, memoryview), copied once "
                  "into the model.")
      .def_property_readonly("patch_count", &CompressedModel::patch_count, "The number of patches.")
      .def_property_readonly("codeword_count", &CompressedModel::codeword_count, "The number of code words.")
      .def_property(
          "cache_budget", &CompressedModel::cache_budget,
          [](const CompressedModel& model, std::uint64_t bytes) { model.set_cache_budget(bytes); },
          "Bytes of decoded blocks kept for random queries (decode_patch, decode_box, patch, codeword), the least "
          "recently used evicted; 64 MiB unless set. A smaller budget evicts at once; 0 keeps only the blocks last "
          "used. A render Scene of the model sets it to an eighth of its memory budget.")
      .def_property_readonly("cache_bytes", &CompressedModel::cache_bytes,
                             "Bytes of decoded blocks the cache holds now.")
      .def("info", &model_info, R"doc(
The model's header as `sspc info --json` prints it: a dict with format, version, file_bytes,
normals, colours, source_points, patches, codewords, codeword_points, overlap_points,
codebook_ratio, bits_per_point, patch_radius, coverage_radius, codeword_radius, spacing, bbox_min,
bbox_max, position_bits, normal_bits, rotation_bits, translation_step, resample, patches_per_block,
codewords_per_block and sections. The encoder's level is not stored in the file.)doc")
      .def("patch", &patch_record, py::arg("k"), R"doc(
Patch k as stored: a dict with its code word's index ("codeword"), and the transform
world_from_codeword x -> rotation @ x + translation ((3, 3) and (3,) float32), the translation
being the patch's region centre. Raises IndexError out of range.)doc")
      .def("codeword", &codeword, py::arg("c"),
           "Code word c, decoded in its own frame: a dict with \"points\" (a PointCloud) and \"radius\" (the "
           "instances' bounding sphere). Raises IndexError out of range.")
      .def(
          "decode_patch",
          [](const CompressedModel& model, py::ssize_t k, bool overlap, bool stored) {
            const std::size_t index = checked_index(k, model.patch_count(), "patch");
            return value_or_raise(without_gil([&] { return model.decode_patch(index, decode_options(overlap, stored)); }));
          },
          py::arg("k"), py::kw_only(), py::arg("overlap") = false, py::arg("stored") = false,
          "Patch k's points in the world: exactly its part of decode_all(), in the same order. overlap=True: "
          "every stored point of the instance, not only those of the patch's own region. stored=True: the points "
          "as stored, without the resampling the model's header asks for (info()['resample']).")
      .def(
          "decode_box",
          [](const CompressedModel& model, const py::object& lo, const py::object& hi, bool overlap, bool stored,
             int threads) {
            const Box3f box(vec3(lo, "lo"), vec3(hi, "hi"));
            ThreadLimit limit(threads);
            return value_or_raise(without_gil([&] { return model.decode_box(box, decode_options(overlap, stored)); }));
          },
          py::arg("lo"), py::arg("hi"), py::kw_only(), py::arg("overlap") = false, py::arg("stored") = false,
          py::arg("threads") = 0,
          "Exactly the points of decode_all() inside the box [lo, hi] (inclusive; lo and hi are (x, y, z)), in the "
          "same order, decoding only the patches near it.")
      .def(
          "decode_all",
          [](const CompressedModel& model, bool overlap, bool stored, int threads, const py::object& progress) {
            DecodeOptions options = decode_options(overlap, stored);
            CallbackProgress reporter(progress);
            options.progress = reporter.get();
            ThreadLimit limit(threads);
            auto cloud = without_gil([&] { return model.decode_all(options); });
            reporter.rethrow();
            return value_or_raise(std::move(cloud));
          },
          py::kw_only(), py::arg("overlap") = false, py::arg("stored") = false, py::arg("threads") = 0,
          py::arg("progress") = py::none(),
          "The whole model as a PointCloud, patches in file order; parallel and deterministic. stored: see "
          "decode_patch(). The decoded "
          "buffers become the PointCloud's without a copy. progress: see encode().")
      .def(
          "decode_chunks",
          [](const CompressedModel& model, const py::object& sink, std::size_t chunk_points, bool overlap,
             bool stored, int threads) {
            ThreadLimit limit(threads);
            std::unique_ptr<py::error_already_set> raised;
            const Status s = without_gil([&] {
              return model.decode_chunks(chunk_points, [&](PointCloud&& chunk) {
                py::gil_scoped_acquire gil;
                try {
                  sink(py::cast(std::move(chunk)));
                } catch (py::error_already_set& e) {
                  raised = std::make_unique<py::error_already_set>(std::move(e));
                  return Status(StatusCode::kCancelled, "the sink raised");
                }
                return Status();
              }, decode_options(overlap, stored));
            });
            if (raised) throw std::move(*raised);
            check(s);
          },
          py::arg("sink"), py::kw_only(), py::arg("chunk_points") = std::size_t{1} << 20, py::arg("overlap") = false,
          py::arg("stored") = false, py::arg("threads") = 0,
          "decode_all()'s points handed to sink(PointCloud) in chunks of whole patches, about chunk_points each, "
          "in order: for a model whose decoded cloud does not fit in memory (write each chunk on, or reduce it). "
          "Memory stays about one chunk. What the sink raises stops the decode and is raised here.")
      .def(
          "verify", [](const CompressedModel& model) { check(without_gil([&] { return model.verify(); })); },
          "Checks every checksum and decodes every block; raises RuntimeError (\"corrupt: ...\") on the first "
          "problem.")
      .def("__repr__", [](const CompressedModel& model) {
        return "<sspc.CompressedModel " + std::to_string(model.patch_count()) + " patches, " +
               std::to_string(model.codeword_count()) + " code words>";
      });
}

TiledEncoder plan_tiled(const py::object& cloud_or_positions, int level, std::optional<int> patch_points,
                        std::optional<float> epsilon, std::optional<float> tau, std::optional<float> step,
                        std::optional<int> position_bits, bool store_normals, bool full_spheres,
                        bool keep_duplicates, const py::object& resample, const py::object& attributes,
                        int colour_quality, int intensity_step,
                        std::uint64_t tile_points, std::uint64_t memory_limit, const std::string& normals, const py::object& viewpoint,
                        std::uint64_t seed, const py::object& work_dir) {
  const EncodeOptions options = make_options(level, patch_points, epsilon, tau, step, position_bits, store_normals,
                                             full_spheres, keep_duplicates, resample, attributes, colour_quality,
                                             intensity_step, tile_points, memory_limit, normals, viewpoint, seed);
  if (const auto inputs = input_paths(cloud_or_positions)) {
    const std::filesystem::path dir = work_dir.is_none() ? std::filesystem::temp_directory_path() : file_path(work_dir);
    return value_or_raise(without_gil([&] { return TiledEncoder::plan_files(*inputs, options, {}, dir); }));
  }
  PointCloud cloud = cloud_from(cloud_or_positions, "cloud");
  return value_or_raise(without_gil([&] { return TiledEncoder::plan(std::move(cloud), options); }));
}

constexpr const char* kEncodeDoc = R"doc(
Compresses a point cloud by its self-similarity (Hubo et al. 2007, §4), like `sspc encode`.

cloud: a PointCloud, an (N, 3) position array (copied once: the encoder adds normals), a file's path,
or a list of paths (files, folders, patterns such as 'tiles/*.las') read as one cloud in order.
path: the .sspc file to write (atomically); the statistics of `sspc encode --json` come back as a
dict (level, points, patches, codewords, bits_per_point, file_bytes, ..., seconds). None: the
file's bytes come back instead (encoded through a temporary file, then read into one bytes object).

The keyword arguments mirror `sspc encode --help`: level 0 (most detail) .. 9 (smallest);
patch_points (8..131072), epsilon, tau, step (grid step in spacings), position_bits (4..16) override
single fields of the level;
store_normals keeps the code words' normals; full_spheres keeps each code word's whole sphere;
keep_duplicates stores every point, also several in one cell of the code words' grid;
resample ('auto', 'off' or 1..4) asks the decoder to replace each decoded point by m × m points on
its code word's surface (docs/FORMAT.md, "Resampling"; 'auto': the m that decodes closest to the cloud, measured on a sample of patches);
attributes ('all', 'none', or names among colour, intensity, classification, returns) chooses the
per-point attributes kept, each coded per patch; colour_quality 0..100 (100: lossless) and
intensity_step 1..4096 (1: lossless) set their rates; tile_points > 0 encodes in octree tiles of
at most that many points, each with a margin of its neighbours', joined into one model;
memory_limit (bytes) with `cloud` a file's path (or several) reads it in passes, never whole, and
encodes in tiles sized to the limit (sspc encode --memory-limit; ValueError for a cloud in memory);
normals is 'auto' (the cloud's own if any, else estimated), 'keep' or 'estimate'; viewpoint
orients estimated normals towards a point; seed; threads > 0 caps the worker threads.

progress: None or a callable progress(stage, fraction) called with the stage's name and the
fraction done (0.0 at its start, 1.0 at its end, NaN where the stage's size is unknown), at most
every 50 ms, possibly from a worker thread; only the callback holds the GIL, which the encoder
releases. An exception it raises stops the reports and is raised once the encoder returns.

Raises ValueError for options out of range or a cloud of fewer than 16 points, OSError when the
file cannot be written.)doc";

void bind_tiled_encoder(py::module_& m) {
  std::apply(
      [&](auto... options) {
        py::class_<TiledEncoder>(m, "TiledEncoder", R"doc(
A tiled encode split into jobs that may run elsewhere (sspc.distributed runs them on Dask).

TiledEncoder(cloud, *, tile_points, level=5, ...) takes encode's keyword arguments; tile_points
(> 0) bounds a tile's own points. `cloud` may be a file's path (or a list of paths, read as one cloud): it is then read in passes and
never held whole, its tiles waiting in files of a hidden folder in work_dir (default: the
system's temporary folder), and memory_limit (bytes) sizes the tiles when tile_points is 0.
job(t) gives tile t's self-contained input as bytes, which sspc.run_tile_job turns into the
tile's result on any machine running this sspc; begin(path), add(t, result) in any order and
finish() write the model (write(path, results) does all three), returning encode's statistics.
The file is byte for byte encode(cloud, path, tile_points=..., ...)'s.)doc")
            .def(py::init(&plan_tiled), py::arg("cloud"), py::kw_only(), options..., py::arg("work_dir") = py::none())
            .def_property_readonly("tile_count", &TiledEncoder::tile_count, "The number of tiles.")
            .def("tile_points", &TiledEncoder::tile_points, py::arg("t"), "Tile t's own points.")
            .def_property_readonly("points", &TiledEncoder::points, "The whole cloud's points.")
            .def_property_readonly("dropped_fields", &TiledEncoder::dropped_fields,
                                   "A file's fields that are not kept (comma-separated names; '' for none).")
            .def(
                "begin",
                [](TiledEncoder& e, const std::filesystem::path& path) {
                  check(without_gil([&] { return e.begin(path); }));
                },
                py::arg("path"), "Starts writing the model to `path` (atomically: it appears at finish()).")
            .def(
                "add",
                [](TiledEncoder& e, std::size_t t, const py::object& result) {
                  if (py::isinstance<py::bytes>(result)) {
                    std::string bytes = result.cast<py::bytes>();
                    check(without_gil([&] { return e.add(t, std::move(bytes)); }));
                    return;
                  }
                  const std::filesystem::path path = file_path(result);
                  check(without_gil([&] { return e.add_file(t, path); }));
                },
                py::arg("t"), py::arg("result"),
                "Tile t's result, in any order: bytes, or the path of a file run_tile_job wrote (read when its turn "
                "comes, then removed); written as soon as every tile before it is.")
            .def(
                "finish",
                [](TiledEncoder& e) {
                  const auto start = std::chrono::steady_clock::now();
                  const EncodeStats s = value_or_raise(without_gil([&] { return e.finish(); }));
                  const double seconds =
                      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
                  return encode_stats(s, e.level(), seconds);
                },
                "Writes the rest of the model once every tile's result is added; encode's statistics (seconds: "
                "this call's).")
            .def(
                "job",
                [](const TiledEncoder& e, std::size_t t) {
                  if (t >= e.tile_count()) throw py::index_error("tile " + std::to_string(t) + " out of range");
                  return py::bytes(value_or_raise(without_gil([&] { return e.job(t); })));
                },
                py::arg("t"), "Tile t's job: bytes for sspc.run_tile_job.")
            .def(
                "write_job",
                [](const TiledEncoder& e, std::size_t t, const py::object& path) {
                  if (t >= e.tile_count()) throw py::index_error("tile " + std::to_string(t) + " out of range");
                  const std::filesystem::path file = file_path(path);
                  check(without_gil([&] { return e.write_job(t, file); }));
                },
                py::arg("t"), py::arg("path"),
                "Tile t's job written to a file (atomically), for a worker that shares storage with this machine.")
            .def(
                "write",
                [](TiledEncoder& e, const std::filesystem::path& path, const std::vector<std::string>& results) {
                  const auto start = std::chrono::steady_clock::now();
                  const EncodeStats s = value_or_raise(without_gil([&] { return e.write(path, results); }));
                  const double seconds =
                      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
                  return encode_stats(s, e.level(), seconds);
                },
                py::arg("path"), py::arg("results"),
                "Joins the jobs' results (bytes, in tile order) and writes the model; encode's statistics.");
      },
      option_args());
  m.def(
      "run_tile_job",
      [](const py::object& job, int threads, const py::object& result) -> py::object {
        ThreadLimit limit(threads);
        if (py::isinstance<py::bytes>(job)) {
          if (!result.is_none()) throw py::value_error("run_tile_job: a result path needs the job as a path too");
          const std::string bytes = job.cast<py::bytes>();
          return py::bytes(value_or_raise(without_gil([&] { return run_tile_job(bytes); })));
        }
        if (result.is_none()) throw py::value_error("run_tile_job: a job's path needs a result path");
        const std::filesystem::path from = file_path(job), to = file_path(result);
        check(without_gil([&] { return run_tile_job_file(from, to); }));
        return py::none();
      },
      py::arg("job"), py::kw_only(), py::arg("threads") = 0, py::arg("result") = py::none(), R"doc(
Runs one tile's job (TiledEncoder.job): normals where needed, patches, code book. Returns the
tile's result as bytes for TiledEncoder.add. With `job` a file's path (TiledEncoder.write_job) and
`result` a path, reads the one and writes the other (atomically), returning None: on shared
storage the bytes are copied once each way instead of through a scheduler. Deterministic whatever
`threads` (> 0 caps the worker threads); releases the GIL.)doc");
}

}  // namespace

void bind_codec(py::module_& m) {
  bind_tiled_encoder(m);
  m.def("keep_freed_memory", &keep_freed_memory, R"doc(
Tells the C library's allocator (glibc) to keep freed memory for reuse instead of returning it
to the system and faulting it in again: a process that encodes large clouds runs faster (a
1M-point tile job 14.2 s -> 12.8 s; autzen in 2 tiles 108 s -> 77 s), but its resident size
stays near its peak and the peak grows (100M points in tiles of 5.75M: 2.47 GB instead of 1.85;
memory_limit sizes tiles with it). A process-wide setting, which sspc never makes on its own;
the sspc CLI and sspc.distributed (client and workers) make it.)doc");
  m.def("release_freed_memory", &release_freed_memory, R"doc(
Gives the freed memory the allocator keeps back to the system, wherever it lies in the heap
(glibc's malloc_trim); returns whether any was given back. Between tiles of a memory-limited
encode once the process holds more than 7/8 of its limit (the sspc CLI), and on a Dask worker
after a tile job once it holds more than 70% of the worker's Dask memory limit (sspc.distributed).)doc");
  m.def("use_one_arena", &use_one_arena, R"doc(
Tells the C library's allocator (glibc) to use one arena for every thread: what one thread frees,
another reuses, instead of each worker's arena keeping its own. For a process that renders
compressed models under a memory budget (the sspc CLI's render makes it): autzen at 32 MiB grew
by 73 MB instead of 89, the frame as fast. Call it before other threads allocate; a
process-wide setting, which sspc never makes on its own.)doc");
  m.def("resident_bytes", &resident_bytes, R"doc(
The process's resident memory now, in bytes (Linux's /proc/self/statm); 0 where unknown.)doc");
  std::apply(
      [&](auto... options) {
        m.def("encode", &encode_cloud, py::arg("cloud"), py::arg("path") = py::none(), py::kw_only(), options...,
              py::arg("threads") = 0, py::arg("progress") = py::none(), kEncodeDoc);
      },
      option_args());

  bind_compressed_model(m);
}

}  // namespace sspc::python
