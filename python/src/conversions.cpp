#include "conversions.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <stdexcept>

namespace sspc::python {

// The views below read the model's vectors as plain (N, 3) arrays.
static_assert(sizeof(Vec3f) == 3 * sizeof(float), "Vec3f must be three packed floats");
static_assert(sizeof(Rgb8) == 3, "Rgb8 must be three packed bytes");

void raise_status(const Status& status) {
  switch (status.code()) {
    case StatusCode::kInvalidArgument:
      throw py::value_error(status.message());
    case StatusCode::kNotFound:
      PyErr_SetString(PyExc_FileNotFoundError, status.message().c_str());
      throw py::error_already_set();
    case StatusCode::kIoError:
      PyErr_SetString(PyExc_OSError, status.message().c_str());
      throw py::error_already_set();
    default:
      throw std::runtime_error(status.to_string());
  }
}

namespace {

std::string shape_text(const py::array& a) {
  std::string text = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) text += (i ? ", " : "") + std::to_string(a.shape(i));
  return text + (a.ndim() == 1 ? ",)" : ")");
}

// numpy.asarray(value), then the dtype and shape checks every (N, 3) argument shares.
py::array checked_rows(py::handle value, std::string_view what, const char* kinds, const char* wanted) {
  py::array a = py::array::ensure(value);
  if (!a) throw py::type_error(std::string(what) + " must be an array, got " + std::string(py::str(py::type::of(value))));
  const char kind = a.dtype().kind();
  if (std::string_view(kinds).find(kind) == std::string_view::npos) {
    throw py::type_error(std::string(what) + " must be " + wanted + ", got dtype " + std::string(py::str(a.dtype())));
  }
  if (a.ndim() != 2 || a.shape(1) != 3) {
    throw py::value_error(std::string(what) + " must have shape (N, 3), got " + shape_text(a));
  }
  return a;
}

}  // namespace

std::vector<Vec3f> vec3_rows(py::handle array, std::string_view what) {
  py::array a = checked_rows(array, what, "fiu", "an array of real numbers");
  std::vector<Vec3f> rows(static_cast<std::size_t>(a.shape(0)));
  if (rows.empty()) return rows;
  if (a.dtype().is(py::dtype::of<float>())) {
    auto f = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(a);
    if (!f) throw py::error_already_set();
    std::memcpy(static_cast<void*>(rows.data()), f.data(), rows.size() * sizeof(Vec3f));
    return rows;
  }
  // Other dtypes through double, so that a value float32 cannot hold is named here rather than
  // cast to an infinity with numpy's overflow warning.
  auto d = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
  if (!d) throw py::error_already_set();
  const double* in = d.data();
  constexpr double kMax = std::numeric_limits<float>::max();
  for (std::size_t i = 0; i < rows.size(); ++i) {
    for (std::size_t c = 0; c < 3; ++c) {
      const double x = in[3 * i + c];
      if (std::isfinite(x) && std::abs(x) > kMax) {
        char value[32];
        std::snprintf(value, sizeof value, "%.9g", x);
        throw py::value_error(std::string(what) + ": row " + std::to_string(i) + " holds " + value +
                              ", beyond float32's range");
      }
      rows[i][static_cast<Eigen::Index>(c)] = static_cast<float>(x);
    }
  }
  return rows;
}

std::vector<Rgb8> rgb_rows(py::handle array, std::string_view what) {
  py::array a = checked_rows(array, what, "iu", "an array of integers in 0..255");
  auto v = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(a);
  if (!v) throw py::error_already_set();
  const auto n = static_cast<std::size_t>(v.shape(0));
  std::vector<Rgb8> rows(n);
  const std::int64_t* in = v.data();
  for (std::size_t i = 0; i < n; ++i) {
    std::uint8_t rgb[3];
    for (std::size_t c = 0; c < 3; ++c) {
      const std::int64_t x = in[3 * i + c];
      if (x < 0 || x > 255) {
        throw py::value_error(std::string(what) + " must lie in 0..255, got " + std::to_string(x) + " at row " +
                              std::to_string(i));
      }
      rgb[c] = static_cast<std::uint8_t>(x);
    }
    rows[i] = Rgb8{rgb[0], rgb[1], rgb[2]};
  }
  return rows;
}

Vec3f vec3(py::handle value, std::string_view what) {
  auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(value);
  if (!a || a.ndim() != 1 || a.shape(0) != 3) {
    throw py::value_error(std::string(what) + " must be three numbers (x, y, z)");
  }
  const double* d = a.data();
  const Vec3f v(static_cast<float>(d[0]), static_cast<float>(d[1]), static_cast<float>(d[2]));
  if (!v.allFinite()) throw py::value_error(std::string(what) + " must be finite");
  return v;
}

py::array float_rows_view(const std::vector<Vec3f>& rows, py::handle owner) {
  py::array_t<float> a({static_cast<py::ssize_t>(rows.size()), py::ssize_t{3}},
                       reinterpret_cast<const float*>(rows.data()), owner);
  py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}

py::array rgb_rows_view(const std::vector<Rgb8>& rows, py::handle owner) {
  py::array_t<std::uint8_t> a({static_cast<py::ssize_t>(rows.size()), py::ssize_t{3}},
                              reinterpret_cast<const std::uint8_t*>(rows.data()), owner);
  py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}

template <typename T>
std::vector<T> integer_column(py::handle array, std::string_view what, std::int64_t max) {
  const py::array given = py::array::ensure(array);
  if (!given || given.ndim() != 1) {
    PyErr_Clear();
    throw py::type_error(std::string(what) + " must be a 1-D array of integers");
  }
  if (const char kind = given.dtype().kind(); kind != 'i' && kind != 'u') {
    throw py::type_error(std::string(what) + " must be an array of integers");
  }
  auto v = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(given);
  if (!v) throw py::error_already_set();
  const auto n = static_cast<std::size_t>(v.shape(0));
  std::vector<T> out(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::int64_t x = v.data()[i];
    if (x < 0 || x > max) {
      throw py::value_error(std::string(what) + " must lie in 0.." + std::to_string(max) + ", got " +
                            std::to_string(x) + " at row " + std::to_string(i));
    }
    out[i] = static_cast<T>(x);
  }
  return out;
}
template std::vector<std::uint8_t> integer_column(py::handle, std::string_view, std::int64_t);
template std::vector<std::uint16_t> integer_column(py::handle, std::string_view, std::int64_t);

template <typename T>
py::array column_view(const std::vector<T>& values, py::handle owner) {
  py::array_t<T> a({static_cast<py::ssize_t>(values.size())}, values.data(), owner);
  py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}
template py::array column_view(const std::vector<std::uint8_t>&, py::handle);
template py::array column_view(const std::vector<std::uint16_t>&, py::handle);

PointCloud cloud_from(py::handle cloud_or_positions, std::string_view what) {
  if (py::isinstance<PointCloud>(cloud_or_positions)) return cloud_or_positions.cast<const PointCloud&>();
  PointCloud cloud;
  cloud.positions = vec3_rows(cloud_or_positions, what);
  return cloud;
}

const PointCloud& cloud_ref(py::handle cloud_or_positions, std::string_view what, PointCloud& storage) {
  if (py::isinstance<PointCloud>(cloud_or_positions)) return cloud_or_positions.cast<const PointCloud&>();
  storage.positions = vec3_rows(cloud_or_positions, what);
  return storage;
}

ThreadLimit::ThreadLimit(int threads) {
  if (threads < 0) throw py::value_error("threads must be 0 (all cores) or positive, got " + std::to_string(threads));
  if (threads > 0) control_.emplace(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
}

CallbackProgress::CallbackProgress(py::object callback) : callback_(std::move(callback)) {
  if (!callback_.is_none() && !PyCallable_Check(callback_.ptr())) {
    throw py::type_error("progress must be callable as progress(stage, fraction), or None");
  }
}

CallbackProgress::~CallbackProgress() = default;

void CallbackProgress::rethrow() {
  if (error_) throw *error_;
}

void CallbackProgress::begin_stage(std::string_view name, std::uint64_t total, std::string_view /*unit*/) {
  stage_ = name;
  total_ = total;
  done_ = 0;
  next_report_ns_ = 0;
  report(0.0);
}

void CallbackProgress::advance(std::uint64_t done) {
  const std::uint64_t so_far = done_.fetch_add(done, std::memory_order_relaxed) + done;
  if (total_ > 0 && so_far >= total_) return;  // end_stage() reports the 1.0
  const std::int64_t now = std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch()).count();
  std::int64_t next = next_report_ns_.load(std::memory_order_relaxed);
  // One thread wins each 50 ms slot; the others go back to work at once.
  if (now < next || !next_report_ns_.compare_exchange_strong(next, now + 50'000'000)) return;
  const double fraction = total_ > 0 ? static_cast<double>(so_far) / static_cast<double>(total_)
                                     : std::numeric_limits<double>::quiet_NaN();
  report(fraction);
}

void CallbackProgress::end_stage() { report(1.0); }

void CallbackProgress::report(double fraction) {
  if (failed_.load()) return;
  std::lock_guard lock(mutex_);
  if (failed_.load()) return;
  py::gil_scoped_acquire gil;
  try {
    callback_(stage_, fraction);
  } catch (py::error_already_set& e) {
    error_ = std::make_unique<py::error_already_set>(std::move(e));
    failed_ = true;
  }
}

}  // namespace sspc::python
