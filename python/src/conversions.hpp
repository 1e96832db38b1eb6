// What every binding of the sspc Python module shares: Status to Python exceptions, numpy arrays
// to and from the point-cloud model, the GIL released around library calls, the progress
// callback, and the worker-thread limit. The Python API itself is described in the README's
// "Python" section and in the docstrings.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <tbb/global_control.h>

#include "sspc/point_cloud.hpp"
#include "sspc/progress.hpp"
#include "sspc/status.hpp"

namespace sspc::python {

namespace py = pybind11;

// Raises the Python exception for a failed Status, its message the library's own: ValueError for
// kInvalidArgument, FileNotFoundError for kNotFound, OSError for kIoError, RuntimeError (the
// message prefixed by the code's name, "corrupt: ...") for the rest. Needs the GIL.
[[noreturn]] void raise_status(const Status& status);

inline void check(const Status& status) {
  if (!status.ok()) raise_status(status);
}

template <typename T>
T value_or_raise(StatusOr<T>&& result) {
  if (!result.ok()) raise_status(result.status());
  return std::move(result).value();
}

// Runs `f` with the GIL released and returns what it returns; the GIL is held again by the time
// the caller sees the result (or raises from it). `f` must not touch Python objects.
template <typename F>
auto without_gil(F&& f) {
  py::gil_scoped_release release;
  return f();
}

// --- numpy arrays and the point-cloud model ----------------------------------------------------

// An (N, 3) float array of any real dtype (or anything numpy.asarray takes), converted to float32
// and copied once into the model's layout. `what` names the argument in errors: TypeError for a
// dtype that is not a real number, ValueError for a shape that is not (N, 3).
std::vector<Vec3f> vec3_rows(py::handle array, std::string_view what);
// An (N, 3) array of integers in 0..255, copied into RGB8.
std::vector<Rgb8> rgb_rows(py::handle array, std::string_view what);
// A 3-vector from any sequence of three numbers.
Vec3f vec3(py::handle value, std::string_view what);

// Read-only (N, cols) views of a vector's memory, kept alive by `owner` (the Python object that
// holds the vector): no copy.
py::array float_rows_view(const std::vector<Vec3f>& rows, py::handle owner);
py::array rgb_rows_view(const std::vector<Rgb8>& rows, py::handle owner);
// A 1-D array of integers in 0..max (one per point: LAS intensity, classification, returns).
template <typename T>
std::vector<T> integer_column(py::handle array, std::string_view what, std::int64_t max);
// A read-only 1-D view of `values`, kept alive by `owner`.
template <typename T>
py::array column_view(const std::vector<T>& values, py::handle owner);

// Moves `values` to the heap and returns an array over them that owns them through a capsule:
// no copy. `shape` and `strides` in elements of T's scalar type.
template <typename Scalar, typename Vector>
py::array owning_array(Vector&& values, std::vector<py::ssize_t> shape) {
  auto* heap = new Vector(std::forward<Vector>(values));
  py::capsule owner(heap, [](void* p) { delete static_cast<Vector*>(p); });
  return py::array_t<Scalar>(std::move(shape), reinterpret_cast<const Scalar*>(heap->data()), owner);
}

// The cloud behind a PointCloud object, or a cloud of positions only built from an (N, 3)
// array (one copy).
PointCloud cloud_from(py::handle cloud_or_positions, std::string_view what);
// The same without a copy when the argument is a PointCloud (which Python code cannot modify):
// a reference to it, or to `storage` filled from positions. The caller keeps the argument alive.
const PointCloud& cloud_ref(py::handle cloud_or_positions, std::string_view what, PointCloud& storage);

// --- threads and progress ----------------------------------------------------------------------

// `threads` > 0 caps the library's worker threads for as long as the object lives (the CLI's
// --threads); 0 leaves TBB's default, all cores. The cap is process-wide while it lasts.
class ThreadLimit {
 public:
  explicit ThreadLimit(int threads);

 private:
  std::optional<tbb::global_control> control_;
};

// A Progress that calls a Python callable as callback(stage, fraction): at the start of each
// stage with 0.0, at its end with 1.0, and in between at most every 50 ms with the fraction done
// (NaN when the stage's size is unknown). The library calls advance() from its worker threads;
// the GIL is taken only for the callback itself. An exception raised by the callback stops
// further calls and is raised again by rethrow() once the library call returns.
class CallbackProgress final : public Progress {
 public:
  explicit CallbackProgress(py::object callback);
  ~CallbackProgress() override;

  // This, or nullptr when the callback is None: the library then skips reporting altogether.
  Progress* get() { return callback_.is_none() ? nullptr : this; }
  // With the GIL: raises what the callback raised, if it did.
  void rethrow();

  void begin_stage(std::string_view name, std::uint64_t total, std::string_view unit) override;
  void advance(std::uint64_t done) override;
  void end_stage() override;

 private:
  using Clock = std::chrono::steady_clock;
  void report(double fraction);

  py::object callback_;
  std::string stage_;
  std::uint64_t total_ = 0;
  std::atomic<std::uint64_t> done_{0};
  std::atomic<std::int64_t> next_report_ns_{0};
  std::mutex mutex_;  // one callback at a time, from whichever thread
  std::atomic<bool> failed_{false};
  std::unique_ptr<py::error_already_set> error_;
};

// --- the module's parts, each in its own file ---------------------------------------------------

void bind_point_cloud(py::module_& m);  // point_cloud_bindings.cpp: PointCloud, I/O, normals
void bind_metrics(py::module_& m);      // metrics_bindings.cpp: eval, synthetic surfaces
void bind_codec(py::module_& m);        // codec_bindings.cpp: encode, CompressedModel
void bind_render(py::module_& m);       // render_bindings.cpp: render, Scene, write_png

}  // namespace sspc::python
