// sspc.Scene, sspc.render and sspc.write_png: ray tracing a point cloud or a compressed model
// through its MLS surface (Hubo et al. 2007, §5).
#include <pybind11/stl/filesystem.h>

#include <cstring>
#include <filesystem>
#include <memory>
#include <string>

#include "conversions.hpp"
#include "sspc/normals.hpp"
#include "sspc/render.hpp"

namespace sspc::python {
namespace {

Shade shade_from(const std::string& name) {
  if (name == "lambert") return Shade::kLambert;
  if (name == "normal") return Shade::kNormal;
  if (name == "depth") return Shade::kDepth;
  if (name == "codeword") return Shade::kCodeword;
  throw py::value_error("shade must be 'lambert', 'normal', 'depth' or 'codeword', got '" + name + "'");
}

// A RenderScene built once and rendered from any number of cameras.
class Scene {
 public:
  Scene(const py::object& source, float bandwidth, double memory_budget_mib, int threads, const py::object& progress) {
    if (!(memory_budget_mib >= 1 && memory_budget_mib <= 1e7)) {
      throw py::value_error("memory_budget_mib must be in [1, 1e7]");
    }
    CallbackProgress reporter(progress);
    ThreadLimit limit(threads);
    SceneOptions options;
    options.bandwidth = bandwidth;
    options.memory_budget_bytes = static_cast<std::uint64_t>(memory_budget_mib * 1024 * 1024);
    options.progress = reporter.get();
    StatusOr<std::unique_ptr<RenderScene>> scene = invalid_argument("no scene");
    if (py::isinstance<CompressedModel>(source)) {
      // The scene shares the model, which the Python object owns: the scene keeps that object
      // alive and holds a pointer that owns nothing.
      keep_alive_ = source;
      std::shared_ptr<const CompressedModel> model(&source.cast<const CompressedModel&>(), [](const CompressedModel*) {});
      scene = without_gil([&] { return RenderScene::from_compressed(model, options); });
    } else {
      PointCloud copy;
      const PointCloud* cloud = &cloud_ref(source, "source", copy);
      check(cloud->validate());
      // The MLS surface needs unit normals: the cloud's own, else estimated (on a copy), like
      // `sspc render`.
      NormalOptions normals;
      normals.progress = reporter.get();
      if (!cloud->has_normals() && cloud != &copy) cloud = &(copy = *cloud);
      scene = without_gil([&]() -> StatusOr<std::unique_ptr<RenderScene>> {
        if (!cloud->has_normals()) SSPC_RETURN_IF_ERROR(ensure_normals(copy, normals));
        return RenderScene::from_point_cloud(*cloud, options);
      });
    }
    reporter.rethrow();
    scene_ = value_or_raise(std::move(scene));
  }

  py::object render(int width, int height, const py::object& eye, const py::object& target, const py::object& up,
                    float fov, const std::string& shade, float lod, bool depth, int threads,
                    const py::object& progress) const {
    FrameOptions options;
    options.width = width;
    options.height = height;
    options.shade = shade_from(shade);
    options.level_of_detail = lod;
    options.camera = frame_bounds(scene_->bounds(), fov);
    if (!eye.is_none()) options.camera.eye = vec3(eye, "eye");
    if (!target.is_none()) options.camera.target = vec3(target, "target");
    if (!up.is_none()) options.camera.up = vec3(up, "up");
    CallbackProgress reporter(progress);
    options.progress = reporter.get();
    ThreadLimit limit(threads);
    auto image = without_gil([&] { return scene_->render(options); });
    reporter.rethrow();
    return image_arrays(value_or_raise(std::move(image)), depth);
  }

  py::tuple bounds() const {
    const Box3f b = scene_->bounds();
    return py::make_tuple(py::make_tuple(b.min().x(), b.min().y(), b.min().z()),
                          py::make_tuple(b.max().x(), b.max().y(), b.max().z()));
  }
  double build_seconds() const { return scene_->build_seconds(); }
  std::uint64_t memory_bytes() const { return scene_->memory_bytes(); }

 private:
  // The image's own buffers, owned by the arrays through one capsule: no copy.
  static py::object image_arrays(Image&& image, bool with_depth) {
    auto* heap = new Image(std::move(image));
    py::capsule owner(heap, [](void* p) { delete static_cast<Image*>(p); });
    const py::ssize_t h = heap->height, w = heap->width;
    py::array rgb = py::array_t<std::uint8_t>({h, w, py::ssize_t{3}}, heap->rgb.data(), owner);
    if (!with_depth) return rgb;
    if (heap->depth.size() != heap->rgb.size() / 3) throw std::runtime_error("internal: the renderer gave no depth");
    py::array z = py::array_t<float>({h, w}, heap->depth.data(), owner);
    return py::make_tuple(rgb, z);
  }

  py::object keep_alive_;  // declared before scene_, so destroyed after it
  std::unique_ptr<RenderScene> scene_;
};

void write_png_array(const py::array& array, const std::filesystem::path& path) {
  if (array.dtype().kind() != 'u' || array.itemsize() != 1 || array.ndim() != 3 || array.shape(2) != 3) {
    throw py::value_error("the image must be an (H, W, 3) uint8 array");
  }
  auto pixels = py::array_t<std::uint8_t, py::array::c_style>::ensure(array);
  Image image;
  image.height = static_cast<int>(pixels.shape(0));
  image.width = static_cast<int>(pixels.shape(1));
  image.rgb.resize(static_cast<std::size_t>(pixels.size()));
  if (!image.rgb.empty()) std::memcpy(image.rgb.data(), pixels.data(), image.rgb.size());
  check(without_gil([&] { return write_png(image, path); }));
}

constexpr const char* kRenderArguments = R"doc(
width, height: the image size in pixels. eye, target, up: the camera, (x, y, z) each; by default
the camera frames the scene's bounds from the +z side (eye and target), with up = +y. fov: the
vertical field of view in degrees. shade: 'lambert', 'normal', 'depth' or 'codeword' (each pixel
coloured by the code word of the patch that contributed most; a point cloud is one colour).
lod: level of detail for a CompressedModel, as `sspc render --lod` (0 off; 0.5 keeps the image
closest to a supersampled one): where its points lie denser than the pixels, the surface is
intersected from a coarser form whose samples span at most lod pixels. depth=True returns (rgb, depth) with depth an (H, W) float32 array of the ray parameter of each
hit, inf where the ray missed. The arrays own the renderer's buffers (no copy). threads > 0 caps
the worker threads; progress as in encode(). The GIL is released while rendering.)doc";

}  // namespace

void bind_render(py::module_& m) {
  static const std::string scene_render_doc =
      std::string("Renders one frame: an (H, W, 3) uint8 RGB array, rows from the top.\n") + kRenderArguments;
  static const std::string render_doc =
      std::string("Ray-traces the MLS surface of a PointCloud (or (N, 3) positions) or of a CompressedModel in one "
                  "call, like `sspc render`: Scene(source, bandwidth, memory_budget_mib).render(...). Returns an (H, W, 3) "
                  "uint8 RGB array.\n") +
      kRenderArguments;
  py::class_<Scene>(m, "Scene", R"doc(
What the renderer traces, built once and rendered from any number of cameras.

Scene(source, bandwidth=1.5, memory_budget_mib=512, threads=0, progress=None)

source: a CompressedModel, rendered directly: the MLS surface of its decoded points, seamless
across instances, built brick by brick as rays reach them through the model's random-access
decoding and cached within memory_budget_mib; or a PointCloud or (N, 3) position array, whose
normals are estimated when it has none. bandwidth: the MLS bandwidth h in point spacings.)doc")
      .def(py::init<const py::object&, float, double, int, const py::object&>(), py::arg("source"),
           py::arg("bandwidth") = 1.5f, py::arg("memory_budget_mib") = 512.0, py::arg("threads") = 0,
           py::arg("progress") = py::none())
      .def("render", &Scene::render, py::kw_only(), py::arg("width") = 1024, py::arg("height") = 1024,
           py::arg("eye") = py::none(), py::arg("target") = py::none(), py::arg("up") = py::none(),
           py::arg("fov") = 40.0f, py::arg("shade") = "lambert", py::arg("lod") = 0.0f, py::arg("depth") = false,
           py::arg("threads") = 0, py::arg("progress") = py::none(), scene_render_doc.c_str())
      .def("bounds", &Scene::bounds, "((xmin, ymin, zmin), (xmax, ymax, zmax)) of the scene.")
      .def_property_readonly("build_seconds", &Scene::build_seconds, "Seconds spent building the scene.")
      .def_property_readonly("memory_bytes", &Scene::memory_bytes,
                             "Bytes the scene holds once built (a compressed model's brick cache, up to its budget, "
                             "comes on top).");

  m.def(
      "render",
      [](const py::object& source, int width, int height, const py::object& eye, const py::object& target,
         const py::object& up, float fov, const std::string& shade, float lod, float bandwidth,
         double memory_budget_mib, bool depth, int threads, const py::object& progress) {
        const Scene scene(source, bandwidth, memory_budget_mib, threads, progress);
        return scene.render(width, height, eye, target, up, fov, shade, lod, depth, threads, progress);
      },
      py::arg("source"), py::kw_only(), py::arg("width") = 1024, py::arg("height") = 1024,
      py::arg("eye") = py::none(), py::arg("target") = py::none(), py::arg("up") = py::none(), py::arg("fov") = 40.0f,
      py::arg("shade") = "lambert", py::arg("lod") = 0.0f, py::arg("bandwidth") = 1.5f, py::arg("memory_budget_mib") = 512.0,
      py::arg("depth") = false, py::arg("threads") = 0, py::arg("progress") = py::none(),
      render_doc.c_str());

  m.def("write_png", &write_png_array, py::arg("image"), py::arg("path"), R"doc(
Writes an (H, W, 3) uint8 RGB array (as render() returns) as an 8-bit PNG, atomically. The pixels
are copied once into the library's image. Raises ValueError for another shape or dtype, OSError
when the file cannot be written.)doc");
}

}  // namespace sspc::python
