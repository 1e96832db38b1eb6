#include "io/wide_positions.hpp"

#include <cmath>
#include <cstdio>
#include <mutex>

#include "core/parallel.hpp"
#include "io/scalar_type.hpp"

namespace sspc::io {

void CoordinateStats::merge(const CoordinateStats& other) {
  min = min.cwiseMin(other.min);
  max = max.cwiseMax(other.max);
  max_error = max_error.cwiseMax(other.max_error);
}

namespace {

constexpr const char* kAxisNames[3] = {"x", "y", "z"};

// The distance between neighbouring floats at magnitude `c` (a normal float).
double float32_step(double c) {
  int exponent = 0;
  std::frexp(c, &exponent);  // c = m * 2^exponent, m in [0.5, 1)
  return std::ldexp(1.0, exponent - 24);
}

std::string format(double v, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}

}  // namespace

std::optional<std::string> float32_precision_warning(const CoordinateStats& stats,
                                                     std::string_view name) {
  double span = 0;
  for (int k = 0; k < 3; ++k) {
    if (stats.max[k] >= stats.min[k]) span = std::max(span, stats.max[k] - stats.min[k]);
  }
  if (!(span > 0)) return std::nullopt;  // one point, or all in one place
  const double tolerance = std::ldexp(span, -16);
  int worst = -1;
  for (int k = 0; k < 3; ++k) {
    if (stats.max_error[k] > tolerance &&
        (worst < 0 || stats.max_error[k] > stats.max_error[worst])) {
      worst = k;
    }
  }
  if (worst < 0) return std::nullopt;
  std::string also;
  for (int k = 0; k < 3; ++k) {
    if (k == worst || !(stats.max_error[k] > tolerance)) continue;
    also += also.empty() ? " (also on " : ", ";
    also += kAxisNames[k];
  }
  if (!also.empty()) also += ")";
  const double reach = std::max(std::abs(stats.min[worst]), std::abs(stats.max[worst]));
  const Vec3d centre = (stats.min + stats.max) / 2;
  std::string out = name.empty() ? std::string() : std::string(name) + ": ";
  out += "coordinates reach " + format(reach, 9) + " on " + kAxisNames[worst] +
         " but the cloud spans only " + format(span, 3) + ": float32 keeps steps of " +
         format(float32_step(reach), 3) + " there, so reading moves values by up to " +
         format(stats.max_error[worst], 3) + " and precision is lost" + also +
         "; subtract an origin first, such as the centre of the bounding box (" +
         format(centre.x(), 9) + ", " + format(centre.y(), 9) + ", " + format(centre.z(), 9) + ")";
  return out;
}

WidePositions::WidePositions(const ReadOptions& options, bool stored_wider)
    : stored_wider_(stored_wider),
      check_(stored_wider && options.warnings != nullptr && options.positions_f64 == nullptr),
      copy_(options.positions_f64),
      warnings_(options.warnings),
      wanted_(check_ || (stored_wider && copy_ != nullptr)) {
  if (copy_ != nullptr) copy_->clear();
}

void WidePositions::add_block(const std::byte* block, const StridedField (&fields)[3],
                              Endian endian, std::span<const Vec3f> held) {
  if (copy_ != nullptr) copy_->resize(held.size());
  std::mutex merge_mutex;
  parallel_for_ranges(0, held.size(), 1 << 16, [&](std::size_t b, std::size_t e) {
    CoordinateStats part;
    for (std::size_t i = b; i < e; ++i) {
      Vec3d stored;
      for (int k = 0; k < 3; ++k) {
        stored[k] =
            load_as_double(block + fields[k].offset + i * fields[k].stride, fields[k].type, endian);
      }
      part.add(stored, held[i]);
      if (copy_ != nullptr) (*copy_)[i] = stored;
    }
    const std::lock_guard lock(merge_mutex);
    stats_.merge(part);
  });
}

void WidePositions::finish(const PointCloud& cloud, std::string_view name) {
  if (copy_ != nullptr && !stored_wider_) {
    copy_->resize(cloud.size());
    for (std::size_t i = 0; i < cloud.size(); ++i) (*copy_)[i] = cloud.positions[i].cast<double>();
  }
  if (!check_) return;
  if (std::optional<std::string> warning = float32_precision_warning(stats_, name)) {
    warnings_->push_back(std::move(*warning));
  }
}

}  // namespace sspc::io
