// The compiled part of the sspc Python package, imported by sspc/__init__.py as sspc._sspc.
#include "conversions.hpp"

PYBIND11_MODULE(_sspc, m) {
  m.doc() = "sspc: self-similarity compression, random-access decoding and ray tracing of point clouds "
            "(Hubo, Mertens, Haber, Bekaert, PBG 2007). Import the sspc package, not this module.";
  m.attr("__version__") = SSPC_VERSION;
  namespace python = sspc::python;
  python::bind_point_cloud(m);
  python::bind_metrics(m);
  python::bind_codec(m);  // before render: Scene takes a CompressedModel
  python::bind_render(m);
}
