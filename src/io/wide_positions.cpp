#include "io/wide_positions.hpp"

#include <cmath>
#include <cstdio>
#include <mutex>

#include "core/check.hpp"
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

// Each position again from its stored value, relative to the origin.
void narrow_from(const std::vector<Vec3d>& stored, const Vec3d& origin,
                 std::span<Vec3f> positions) {
  parallel_for_ranges(0, positions.size(), 1 << 16, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) {
      for (int k = 0; k < 3; ++k) positions[i][k] = narrow_to_float(stored[i][k] - origin[k]);
    }
  });
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

Vec3d round_origin(const CoordinateStats& stats) {
  double span = 0;
  for (int k = 0; k < 3; ++k) span = std::max(span, stats.max[k] - stats.min[k]);
  const double unit = span > 0 ? std::pow(10.0, std::floor(std::log10(span))) : 1.0;
  const Vec3d centre = (stats.min + stats.max) / 2;
  Vec3d origin;
  for (int k = 0; k < 3; ++k) origin[k] = std::round(centre[k] / unit) * unit + 0.0;  // no -0
  return origin;
}

WidePositions::WidePositions(const ReadOptions& options, bool stored_wider)
    : stored_wider_(stored_wider),
      copy_(options.positions_f64 != nullptr ? options.positions_f64 : &own_copy_),
      wanted_(stored_wider) {
  copy_->clear();
}

void WidePositions::add_block(const std::byte* block, const StridedField (&fields)[3],
                              Endian endian, std::span<const Vec3f> held) {
  const std::size_t first = copy_->size();
  copy_->resize(first + held.size());
  Vec3d* copy = copy_->data() + first;
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
      copy[i] = stored;
    }
    const std::lock_guard lock(merge_mutex);
    stats_.merge(part);
  });
}

void WidePositions::finish(PointCloud& cloud) {
  if (!stored_wider_) {
    if (copy_ == &own_copy_) return;
    copy_->resize(cloud.size());
    for (std::size_t i = 0; i < cloud.size(); ++i) (*copy_)[i] = cloud.positions[i].cast<double>();
    return;
  }
  if (copy_->size() != cloud.size()) return;
  const std::optional<Vec3d> chosen = origin();
  if (!chosen) return;
  cloud.origin = *chosen;
  narrow_from(*copy_, *chosen, cloud.positions);
}

std::optional<Vec3d> WidePositions::origin() const {
  if (!stored_wider_ || !float32_precision_warning(stats_, "")) return std::nullopt;
  const Vec3d origin = round_origin(stats_);
  // Rounding the centre moves the local values by up to half a power of ten: near float's
  // range that could take them past it, and the cloud is better kept as it was read.
  constexpr double kMax = static_cast<double>(std::numeric_limits<float>::max());
  if (!((stats_.max - origin).cwiseAbs().maxCoeff() < kMax &&
        (stats_.min - origin).cwiseAbs().maxCoeff() < kMax && origin.allFinite())) {
    return std::nullopt;
  }
  return origin;
}

void WidePositions::narrow_added(const Vec3d& origin, std::span<Vec3f> positions) {
  SSPC_DCHECK(copy_->size() == positions.size());
  narrow_from(*copy_, origin, positions);
  copy_->clear();
}

}  // namespace sspc::io
