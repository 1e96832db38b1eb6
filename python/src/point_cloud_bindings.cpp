// sspc.PointCloud, sspc.read, sspc.write, sspc.estimate_normals.
#include <pybind11/stl/filesystem.h>

#include <filesystem>
#include <string>
#include <vector>

#include "conversions.hpp"
#include "sspc/io.hpp"
#include "sspc/normals.hpp"

namespace sspc::python {
namespace {

PointCloud make_cloud(const py::object& positions, const py::object& normals, const py::object& colours,
                      const py::object& intensity, const py::object& classification,
                      const py::object& return_number, const py::object& number_of_returns) {
  PointCloud cloud;
  cloud.positions = vec3_rows(positions, "positions");
  if (!normals.is_none()) cloud.normals = vec3_rows(normals, "normals");
  if (!colours.is_none()) cloud.colours = rgb_rows(colours, "colours");
  if (!intensity.is_none()) cloud.las.intensity = integer_column<std::uint16_t>(intensity, "intensity", 65535);
  if (!classification.is_none()) {
    cloud.las.classification = integer_column<std::uint8_t>(classification, "classification", 255);
  }
  if (return_number.is_none() != number_of_returns.is_none()) {
    throw py::value_error("return_number and number_of_returns go together");
  }
  if (!return_number.is_none()) {
    cloud.las.return_number = integer_column<std::uint8_t>(return_number, "return_number", 15);
    cloud.las.number_of_returns = integer_column<std::uint8_t>(number_of_returns, "number_of_returns", 15);
  }
  // validate() checks the lengths agree and every coordinate is finite (float64 values beyond
  // float32's range arrive here as infinities).
  check(cloud.validate());
  return cloud;
}

std::string repr(const PointCloud& cloud) {
  std::string text = "<sspc.PointCloud " + std::to_string(cloud.size()) + " points";
  if (cloud.has_normals()) text += ", normals";
  if (cloud.has_colours()) text += ", colours";
  if (!cloud.las.empty()) text += ", " + cloud.las.names();
  return text + ">";
}

PointCloud read_cloud(const std::filesystem::path& path) {
  std::vector<std::string> warnings;
  ReadOptions options;
  options.warnings = &warnings;
  PointCloud cloud = value_or_raise(without_gil([&] { return read_point_cloud(path, options); }));
  if (!warnings.empty()) {
    py::object warn = py::module_::import("warnings").attr("warn");
    for (const std::string& w : warnings) warn(w, py::handle(PyExc_UserWarning), 2);
  }
  return cloud;
}

void write_cloud(const PointCloud& cloud, const std::filesystem::path& path, bool ascii) {
  PlyWriteOptions options;
  options.encoding = ascii ? PlyEncoding::kAscii : PlyEncoding::kBinaryLittleEndian;
  check(without_gil([&] { return write_ply(cloud, path, options); }));
}

py::array estimate(const py::object& cloud_or_positions, int k, const py::object& viewpoint, int threads) {
  PointCloud cloud = cloud_from(cloud_or_positions, "positions");
  cloud.normals.clear();
  NormalOptions options;
  options.mode = NormalMode::kEstimate;
  options.k = k;
  if (!viewpoint.is_none()) options.viewpoint = vec3(viewpoint, "viewpoint");
  check(cloud.validate());
  ThreadLimit limit(threads);
  check(without_gil([&] { return ensure_normals(cloud, options); }));
  const auto n = static_cast<py::ssize_t>(cloud.size());
  return owning_array<float>(std::move(cloud.normals), {n, 3});
}

// A LAS field of the cloud as a read-only 1-D view kept alive by the cloud, or None.
template <auto kField>
py::object las_column(py::object self) {
  const auto& values = self.cast<const PointCloud&>().las.*kField;
  return values.empty() ? py::object(py::none()) : py::object(column_view(values, self));
}

}  // namespace

void bind_point_cloud(py::module_& m) {
  py::class_<PointCloud>(m, "PointCloud", R"doc(
A point cloud: float32 positions, optional unit normals, optional 8-bit RGB colours.

PointCloud(positions, normals=None, colours=None, *, intensity=None, classification=None,
           return_number=None, number_of_returns=None)

positions and normals are (N, 3) arrays of any real dtype, converted to float32; colours is an
(N, 3) array of integers in 0..255; the LAS fields are 1-D integer arrays (intensity 0..65535,
classification 0..255, returns 0..15), which `sspc.encode` keeps per point. Building one copies each array once into the library's
layout. Raises TypeError for a wrong dtype and ValueError for a wrong shape, lengths that
disagree or a coordinate that is not finite.

The attributes .positions, .normals, .colours and the LAS fields are read-only numpy views of the cloud's own
memory (no copy), valid as long as any of them or the cloud is alive; copy one to modify it.)doc")
      .def(py::init(&make_cloud), py::arg("positions"), py::arg("normals") = py::none(),
           py::arg("colours") = py::none(), py::kw_only(), py::arg("intensity") = py::none(),
           py::arg("classification") = py::none(), py::arg("return_number") = py::none(),
           py::arg("number_of_returns") = py::none())
      .def_property_readonly(
          "positions", [](py::object self) { return float_rows_view(self.cast<const PointCloud&>().positions, self); },
          "(N, 3) float32, read-only view of the cloud's memory.")
      .def_property_readonly(
          "normals",
          [](py::object self) -> py::object {
            const auto& cloud = self.cast<const PointCloud&>();
            if (!cloud.has_normals()) return py::none();
            return float_rows_view(cloud.normals, self);
          },
          "(N, 3) float32 unit normals, read-only view, or None when the cloud has none.")
      .def_property_readonly(
          "colours",
          [](py::object self) -> py::object {
            const auto& cloud = self.cast<const PointCloud&>();
            if (!cloud.has_colours()) return py::none();
            return rgb_rows_view(cloud.colours, self);
          },
          "(N, 3) uint8 RGB, read-only view, or None when the cloud has none.")
      .def_property_readonly("intensity", las_column<&LasPointAttributes::intensity>,
                             "(N,) uint16 LAS intensity, read-only view, or None.")
      .def_property_readonly("classification", las_column<&LasPointAttributes::classification>,
                             "(N,) uint8 LAS classification, read-only view, or None.")
      .def_property_readonly("return_number", las_column<&LasPointAttributes::return_number>,
                             "(N,) uint8 LAS return number, read-only view, or None.")
      .def_property_readonly("number_of_returns", las_column<&LasPointAttributes::number_of_returns>,
                             "(N,) uint8 LAS number of returns, read-only view, or None.")
      .def("__len__", &PointCloud::size, "The number of points.")
      .def("__repr__", &repr)
      .def(
          "bounds",
          [](const PointCloud& cloud) {
            const Box3f box = cloud.bounding_box();
            return py::make_tuple(py::make_tuple(box.min().x(), box.min().y(), box.min().z()),
                                  py::make_tuple(box.max().x(), box.max().y(), box.max().z()));
          },
          "((xmin, ymin, zmin), (xmax, ymax, zmax)), the axis-aligned bounds of the positions.");

  m.def("read", &read_cloud, py::arg("path"), R"doc(
Reads a point cloud: PLY (ascii or binary), XYZ/PTS text or PCD, by extension, else by content.

Returns a PointCloud. Raises FileNotFoundError for a missing file, ValueError for an empty cloud
and RuntimeError ("parse error: ...", "corrupt: ...") for a malformed file, the message naming the
file and the line or byte offset. A file whose coordinates float32 cannot hold to the cloud's
detail reads with a UserWarning saying so. The GIL is released while reading.)doc");

  m.def("write", &write_cloud, py::arg("cloud"), py::arg("path"), py::arg("ascii") = false, R"doc(
Writes `cloud` as PLY (binary little endian, or ascii=True), with its normals and colours.

The file is written to a temporary name and renamed, so a failure leaves no partial output.
Raises OSError when the file cannot be written. The GIL is released while writing.)doc");

  m.def("estimate_normals", &estimate, py::arg("cloud"), py::arg("k") = 16, py::arg("viewpoint") = py::none(),
        py::arg("threads") = 0, R"doc(
Estimates unit normals by PCA over each point's k nearest neighbours (3..256) and orients them
consistently: towards `viewpoint` (x, y, z) when given, otherwise by propagation along a minimum
spanning tree (Hoppe et al. 1992), like `sspc normals`.

`cloud` is a PointCloud (its own normals are ignored) or an (N, 3) array of positions. Returns a
new (N, 3) float32 array that owns the library's result (no copy). threads > 0 caps the worker
threads. The GIL is released while estimating.)doc");
}

}  // namespace sspc::python
