// sspc.eval (the paper's §6 metrics, MPEG D1/D2 and colour PSNR, docs/METRICS.md) and
// sspc.synthetic.
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <filesystem>
#include <optional>
#include <string>

#include "conversions.hpp"
#include "sspc/metrics.hpp"
#include "sspc/normals.hpp"
#include "sspc/synthetic.hpp"

namespace sspc::python {
namespace {

py::dict direction(const DirectedError& e) {
  py::dict d;
  d["rms"] = e.rms;
  d["hausdorff"] = e.hausdorff;
  d["d1_mse"] = e.mse_d1;
  if (e.has_d2) d["d2_mse"] = e.mse_d2;
  if (e.has_colour) d["colour_mse"] = e.mse_colour;
  return d;
}

// The size of `compressed`: bytes-like, or a path to the file.
std::uint64_t compressed_size(const py::object& compressed) {
  if (py::isinstance<py::bytes>(compressed) || py::isinstance<py::bytearray>(compressed) ||
      py::isinstance<py::memoryview>(compressed)) {
    return py::len(compressed);
  }
  const auto path = compressed.cast<std::filesystem::path>();
  std::error_code ec;
  const std::uintmax_t bytes = std::filesystem::file_size(path, ec);
  if (ec) raise_status(io_error(path.string() + ": " + ec.message()));
  return bytes;
}

// The decisions and keys of `sspc eval --json`, over clouds in memory. The CLI also moves both
// files' own double-precision values to a common origin; arrays in memory are float32 already,
// so they are compared as they are.
py::dict evaluate_clouds(const py::object& original, const py::object& decoded, std::optional<double> peak,
                         bool estimate_ref_normals, const py::object& compressed, int threads) {
  // The clouds as given, copied only when normals must be added to REF or taken from TEST.
  PointCloud ref_storage, test_storage;
  const PointCloud* ref = &cloud_ref(original, "original", ref_storage);
  const PointCloud* test = &cloud_ref(decoded, "decoded", test_storage);
  check(ref->validate());
  check(test->validate());
  ThreadLimit limit(threads);
  const bool ref_had_normals = ref->has_normals();
  if (!ref_had_normals && estimate_ref_normals) {
    if (ref != &ref_storage) ref = &(ref_storage = *ref);
    NormalOptions options;
    options.mode = NormalMode::kEstimate;
    check(without_gil([&] { return ensure_normals(ref_storage, options); }));
  }
  // Normal errors compare the clouds' own normals, never estimated ones.
  if (test->has_normals() && !ref_had_normals) {
    if (test != &test_storage) test = &(test_storage = *test);
    test_storage.normals.clear();
  }
  EvalOptions options;
  options.peak = peak;
  const EvalReport r = value_or_raise(without_gil([&] { return evaluate(*ref, *test, options); }));

  py::dict d;
  d["ref_points"] = r.ref_points;
  d["test_points"] = r.test_points;
  d["ref_diagonal"] = r.ref_diagonal;
  d["peak"] = r.peak;
  d["ref_normals"] = ref_had_normals ? "file" : (ref->has_normals() ? "estimated" : "none");
  d["ref_to_test"] = direction(r.ref_to_test);
  d["test_to_ref"] = direction(r.test_to_ref);
  d["rms"] = r.rms_max;
  d["hausdorff"] = r.hausdorff;
  d["psnr"] = r.psnr_paper;  // inf for identical clouds (the CLI's JSON writes null)
  d["d1_mse"] = r.d1_mse;
  d["d1_psnr"] = r.d1_psnr;
  if (r.has_d2) {
    d["d2_mse"] = r.d2_mse;
    d["d2_psnr"] = r.d2_psnr;
  }
  d["identical"] = r.rms_max == 0.0;
  if (r.has_colour) {
    d["colour_mse"] = r.colour_mse;
    d["colour_psnr"] = r.colour_psnr;  // inf for identical colours (the CLI's JSON writes null)
  }
  if (r.has_normal_error) {
    d["normal_angle_mean_deg"] = r.normal_angle_mean_deg;
    d["normal_angle_p95_deg"] = r.normal_angle_p95_deg;
  }
  if (!compressed.is_none()) {
    const std::uint64_t bytes = compressed_size(compressed);
    d["compressed_bytes"] = bytes;
    d["bits_per_point"] = bits_per_point(bytes, r.ref_points);
  }
  return d;
}

synthetic::Options synthetic_options(std::uint64_t seed, bool normals, double noise) {
  synthetic::Options o;
  o.seed = seed;
  o.normals = normals;
  o.noise = noise;
  return o;
}

void bind_synthetic(py::module_& m) {
  py::module_ s = m.def_submodule("synthetic", R"doc(
Seeded synthetic surfaces for tests and examples: the same seed gives the same points on every
platform. Each takes seed=1, normals=True (exact analytic normals) and noise=0.0 (Gaussian sigma
along the normal, in model units) and returns a PointCloud.)doc");
  s.def(
      "plane",
      [](std::size_t points, double size, std::uint64_t seed, bool normals, double noise) {
        return synthetic::plane(points, size, synthetic_options(seed, normals, noise));
      },
      py::arg("points"), py::arg("size") = 1.0, py::kw_only(), py::arg("seed") = 1, py::arg("normals") = true,
      py::arg("noise") = 0.0, "Random points on the square [-size/2, size/2]^2 in the z = 0 plane, normal +z.");
  s.def(
      "sphere",
      [](std::size_t points, double radius, std::uint64_t seed, bool normals, double noise) {
        return synthetic::sphere(points, radius, synthetic_options(seed, normals, noise));
      },
      py::arg("points"), py::arg("radius") = 1.0, py::kw_only(), py::arg("seed") = 1, py::arg("normals") = true,
      py::arg("noise") = 0.0, "Uniform random points on a sphere about the origin, outward normals.");
  s.def(
      "torus",
      [](std::size_t points, double major_radius, double minor_radius, std::uint64_t seed, bool normals,
         double noise) {
        return synthetic::torus(points, major_radius, minor_radius, synthetic_options(seed, normals, noise));
      },
      py::arg("points"), py::arg("major_radius") = 1.0, py::arg("minor_radius") = 0.3, py::kw_only(),
      py::arg("seed") = 1, py::arg("normals") = true, py::arg("noise") = 0.0,
      "Area-uniform points on a torus about the z axis, outward normals.");
  s.def(
      "bumps",
      [](std::size_t points, double size, int bumps_per_side, double height, std::uint64_t seed, bool normals,
         double noise) {
        return synthetic::bumps(points, size, bumps_per_side, height, synthetic_options(seed, normals, noise));
      },
      py::arg("points"), py::arg("size") = 1.0, py::arg("bumps_per_side") = 4, py::arg("height") = 0.05,
      py::kw_only(), py::arg("seed") = 1, py::arg("normals") = true, py::arg("noise") = 0.0,
      "A size x size plane covered by a grid of identical Gaussian bumps: a surface built to be self-similar, "
      "the codec's best case.");
}

}  // namespace

void bind_metrics(py::module_& m) {
  m.def("eval", &evaluate_clouds, py::arg("original"), py::arg("decoded"), py::kw_only(),
        py::arg("peak") = py::none(), py::arg("estimate_normals") = true, py::arg("compressed") = py::none(),
        py::arg("threads") = 0, R"doc(
Distortion of `decoded` against the reference `original`, as `sspc eval --json` reports it.

Both are PointClouds or (N, 3) position arrays. Returns a dict with the CLI's keys: ref_points,
test_points, ref_diagonal, peak, ref_normals ("file", "estimated" or "none"), ref_to_test and
test_to_ref (rms, hausdorff, d1_mse, d2_mse, colour_mse), rms, hausdorff, psnr (the paper's, 20
log10(d_B / rms); inf for identical clouds where the CLI writes null), d1_mse, d1_psnr, d2_mse and
d2_psnr (when the reference has normals, its own or, with estimate_normals=True, estimated ones),
identical, colour_mse and colour_psnr (when both clouds have colours: RGB, 10 log10(255^2 /
colour_mse); inf for identical colours), normal_angle_mean_deg and normal_angle_p95_deg (when both clouds have their own
normals), and with `compressed` (bytes, or the path of the compressed file) compressed_bytes and
bits_per_point. peak is MPEG's D1/D2 peak (default: the reference's bounding-box diagonal). The formulas are
in the repository's docs/METRICS.md. The GIL is released while computing.)doc");
  bind_synthetic(m);
}

}  // namespace sspc::python
