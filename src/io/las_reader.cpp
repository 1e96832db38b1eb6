// read_las: LAS 1.0-1.4, point data record formats 0-10 (ASPRS LAS specification R15).
//
// Positions. A LAS point stores integers X, Y, Z; its place is offset + scale · X per axis
// (§2.4). float32 cannot hold georeferenced values to the scale's step, so the reader chooses
// per axis an origin on the scale's grid, origin = offset + scale · K for an integer K near the
// middle of the file's integers, and keeps local = float(scale · (X − K)). A writer given the
// same scale and offset recovers X exactly when |X − K| < 2^22: float32 then moves the local
// value by at most 2^22 · |scale| · 2^-24 = |scale| / 4, and X = K + round(local / scale).
// An axis whose integers span 2^23 steps or more cannot keep that bound for every point; the
// reader then warns how far from exact the points may come back. An axis whose values are all
// below 2^22 steps from zero needs no origin (the same bound holds from 0).
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <mutex>
#include <string>

#include "core/byte_reader.hpp"
#include "core/parallel.hpp"
#include "io/las_format.hpp"
#include "io/las_header.hpp"
#include "io/reader_common.hpp"
#include "io/scalar_type.hpp"

namespace sspc {

namespace io {

namespace {

constexpr double kExactSteps = 4194304.0;  // 2^22

struct IntegerRange {
  std::int64_t min[3] = {std::numeric_limits<std::int64_t>::max(),
                         std::numeric_limits<std::int64_t>::max(),
                         std::numeric_limits<std::int64_t>::max()};
  std::int64_t max[3] = {std::numeric_limits<std::int64_t>::min(),
                         std::numeric_limits<std::int64_t>::min(),
                         std::numeric_limits<std::int64_t>::min()};
  void merge(const IntegerRange& o) {
    for (int k = 0; k < 3; ++k) {
      min[k] = std::min(min[k], o.min[k]);
      max[k] = std::max(max[k], o.max[k]);
    }
  }
};

IntegerRange integer_range(const std::byte* records, std::size_t count, std::size_t stride) {
  IntegerRange total;
  std::mutex merge_mutex;
  parallel_for_ranges(0, count, 1 << 16, [&](std::size_t b, std::size_t e) {
    IntegerRange part;
    for (std::size_t i = b; i < e; ++i) {
      for (int k = 0; k < 3; ++k) {
        const std::int64_t v = load<std::int32_t>(
            records + i * stride + 4 * static_cast<std::size_t>(k), Endian::kLittle);
        part.min[k] = std::min(part.min[k], v);
        part.max[k] = std::max(part.max[k], v);
      }
    }
    const std::lock_guard lock(merge_mutex);
    total.merge(part);
  });
  return total;
}

// Whether an axis's values lie 2^22 steps or more from zero; then the cloud gets an origin.
// The origin of one axis: a round number on the scale's grid
// near the middle of [lo, hi] (whole metres, or tens or thousands of them, when the grid has
// one within reach), as `anchor`, the integer K with origin = offset + scale · K.
struct AxisOrigin {
  double origin = 0;
  std::int64_t anchor = 0;
};

bool axis_needs_origin(std::int64_t lo, std::int64_t hi, double scale, double offset) {
  const double far = std::max(std::abs(offset + scale * static_cast<double>(lo)),
                              std::abs(offset + scale * static_cast<double>(hi)));
  return !(far / std::abs(scale) < kExactSteps);
}

AxisOrigin choose_axis_origin(std::int64_t lo, std::int64_t hi, double scale, double offset) {
  AxisOrigin out;
  const std::int64_t mid = lo + (hi - lo) / 2;
  out.anchor = mid;
  out.origin = offset + scale * static_cast<double>(mid);
  const double centre = out.origin;
  for (int p = 6; p >= 0; --p) {
    const double unit = std::pow(10.0, p);
    const double round_value = std::round(centre / unit) * unit;
    const double k = (round_value - offset) / scale;
    const double k_int = std::round(k);
    if (std::abs(k - k_int) > 1e-6 || std::abs(k_int) > 9e15) continue;
    const auto anchor = static_cast<std::int64_t>(k_int);
    if (std::abs(static_cast<double>(hi - anchor)) < kExactSteps &&
        std::abs(static_cast<double>(lo - anchor)) < kExactSteps) {
      out.anchor = anchor;
      out.origin = round_value;
      break;
    }
  }
  return out;
}

std::string axis_warning(std::string_view name, int axis, std::int64_t lo, std::int64_t hi,
                         double scale) {
  const char* axes = "xyz";
  const double steps = static_cast<double>(hi - lo) / 2;
  const double worst = std::ldexp(steps * std::abs(scale), -24);
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "the points span %.0f steps of the scale %g on %c, more than float32 holds "
                "exactly (2^23): they come back within %.3g of their values, not bit for bit",
                static_cast<double>(hi - lo), scale, axes[axis], worst);
  return std::string(name) + ": " + buf;
}

// Drops an array whose values are all zero: the field is in every record of the format, and an
// all-zero one (no user data, no point source) says nothing that a writer would not restore.
template <typename T>
void drop_if_zero(std::vector<T>& values) {
  if (std::all_of(values.begin(), values.end(), [](const T& v) { return v == T{}; })) {
    values = {};
  }
}

// Single returns (1 of 1) everywhere are what a writer without return numbers writes.
void drop_if_single_returns(LasPointAttributes& a) {
  for (std::size_t i = 0; i < a.return_number.size(); ++i) {
    if (a.return_number[i] != 1 || a.number_of_returns[i] != 1) return;
  }
  a.return_number = {};
  a.number_of_returns = {};
}

void decode_records(const std::byte* records, const LasHeader& h, const std::int64_t* anchor,
                    PointCloud& cloud) {
  const int format = h.source.point_format;
  const las::PointLayout layout = las::point_layout(format);
  const std::size_t n = static_cast<std::size_t>(h.point_count);
  const std::size_t stride = h.record_length;
  const std::size_t extra = stride - las::kMinRecordLength[static_cast<std::size_t>(format)];
  LasPointAttributes& a = cloud.las;
  cloud.positions.resize(n);
  a.intensity.resize(n);
  a.return_number.resize(n);
  a.number_of_returns.resize(n);
  a.classification.resize(n);
  a.classification_flags.resize(n);
  a.scan_angle.resize(n);
  a.scan_flags.resize(n);
  a.user_data.resize(n);
  a.point_source_id.resize(n);
  if (layout.gps >= 0) a.gps_time.resize(n);
  if (layout.rgb >= 0) a.rgb.resize(n);
  if (layout.nir >= 0) a.nir.resize(n);
  a.extra_bytes_per_point = extra;
  a.extra_bytes.resize(n * extra);
  const Vec3d scale = h.source.scale;
  const Vec3d offset = h.source.offset;
  constexpr Endian le = Endian::kLittle;
  parallel_for_ranges(0, n, 1 << 15, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) {
      const std::byte* r = records + i * stride;
      for (int k = 0; k < 3; ++k) {
        const std::int64_t v = load<std::int32_t>(r + 4 * static_cast<std::size_t>(k), le);
        const double local = anchor != nullptr ? scale[k] * static_cast<double>(v - anchor[k])
                                               : offset[k] + scale[k] * static_cast<double>(v);
        cloud.positions[i][k] = narrow_to_float(local);  // beyond float's range: refused below
      }
      a.intensity[i] = load<std::uint16_t>(r + 12, le);
      const auto bits = std::to_integer<std::uint8_t>(r[14]);
      if (!layout.extended) {
        a.return_number[i] = bits & 7u;
        a.number_of_returns[i] = (bits >> 3) & 7u;
        a.scan_flags[i] = static_cast<std::uint8_t>(bits >> 6);
        const auto cls = std::to_integer<std::uint8_t>(r[15]);
        a.classification[i] = cls & 31u;
        a.classification_flags[i] = static_cast<std::uint8_t>(cls >> 5);
        a.scan_angle[i] = static_cast<float>(load<std::int8_t>(r + 16, le));
        a.user_data[i] = std::to_integer<std::uint8_t>(r[17]);
        a.point_source_id[i] = load<std::uint16_t>(r + 18, le);
      } else {
        a.return_number[i] = bits & 15u;
        a.number_of_returns[i] = static_cast<std::uint8_t>(bits >> 4);
        const auto flags = std::to_integer<std::uint8_t>(r[15]);
        a.classification_flags[i] = flags & 15u;
        // scan direction and edge (bits 6, 7) to bits 0, 1; scanner channel (bits 4, 5) to 2, 3
        a.scan_flags[i] =
            static_cast<std::uint8_t>(((flags >> 6) & 3u) | (((flags >> 4) & 3u) << 2));
        a.classification[i] = std::to_integer<std::uint8_t>(r[16]);
        a.user_data[i] = std::to_integer<std::uint8_t>(r[17]);
        a.scan_angle[i] = static_cast<float>(load<std::int16_t>(r + 18, le) * 0.006);
        a.point_source_id[i] = load<std::uint16_t>(r + 20, le);
      }
      if (layout.gps >= 0) a.gps_time[i] = load<double>(r + layout.gps, le);
      if (layout.rgb >= 0) {
        for (std::size_t c = 0; c < 3; ++c) {
          a.rgb[i][c] = load<std::uint16_t>(r + layout.rgb + 2 * static_cast<int>(c), le);
        }
      }
      if (layout.nir >= 0) a.nir[i] = load<std::uint16_t>(r + layout.nir, le);
      if (extra != 0) {
        std::memcpy(a.extra_bytes.data() + i * extra, r + (stride - extra), extra);
      }
    }
  });
}

// 16-bit colours to the cloud's 8-bit ones: the high bytes, unless every value is below 256
// (writers that store 8-bit values unscaled, which the specification's "normalised to 16 bits"
// rules out but many files do).
void set_colours(PointCloud& cloud) {
  const auto& rgb = cloud.las.rgb;
  if (rgb.empty()) return;
  bool wide = false;
  for (const auto& c : rgb) wide = wide || std::max({c[0], c[1], c[2]}) > 255;
  cloud.colours.resize(rgb.size());
  const unsigned shift = wide ? 8 : 0;
  for (std::size_t i = 0; i < rgb.size(); ++i) {
    cloud.colours[i] = Rgb8{static_cast<std::uint8_t>(rgb[i][0] >> shift),
                           static_cast<std::uint8_t>(rgb[i][1] >> shift),
                           static_cast<std::uint8_t>(rgb[i][2] >> shift)};
  }
}

// The CRS and the extra-bytes description are kept; other records are named as dropped.
void keep_records(const LasHeader& h, PointCloud& cloud, std::string& dropped) {
  for (const LasRecord& r : h.vlrs) {
    if (r.user_id == las::kUserProjection && r.record_id == las::kRecordWkt) {
      std::string wkt = r.data;
      if (const auto end = wkt.find('\0'); end != std::string::npos) wkt.resize(end);
      cloud.metadata.crs_wkt = wkt;
    } else if (r.user_id == las::kUserProjection &&
               (r.record_id == las::kRecordGeoKeys || r.record_id == las::kRecordGeoDoubles ||
                r.record_id == las::kRecordGeoAscii)) {
      cloud.metadata.crs_records.push_back(r);
    } else if (r.user_id == las::kUserSpec && r.record_id == las::kRecordExtraBytes) {
      cloud.metadata.extra_bytes_records.push_back(r);
    } else {
      dropped += dropped.empty() ? "" : ", ";
      dropped += "'" + r.user_id + "' " + std::to_string(r.record_id);
    }
  }
}

}  // namespace

StatusOr<PointCloud> read_las_with_options(std::span<const std::byte> data, std::string_view name,
                                           const ReadOptions& options) {
  SSPC_ASSIGN_OR_RETURN(const LasHeader h, parse_las_header(data, name));
  if (h.point_count > std::numeric_limits<std::size_t>::max() / 64) {
    return error_in(StatusCode::kResourceExhausted, name, "too many points");
  }
  const std::byte* records = data.data() + h.point_data_offset;
  const auto n = static_cast<std::size_t>(h.point_count);
  const IntegerRange range = integer_range(records, n, h.record_length);

  PointCloud cloud;
  std::vector<std::string> notes;
  std::int64_t anchor[3] = {0, 0, 0};
  bool any_origin = false;
  for (int k = 0; k < 3 && n != 0; ++k) {
    any_origin = any_origin || axis_needs_origin(range.min[k], range.max[k], h.source.scale[k],
                                                 h.source.offset[k]);
  }
  // Every axis then gets one, so that no axis keeps a large offset in its local values.
  for (int k = 0; k < 3 && any_origin; ++k) {
    const AxisOrigin axis =
        choose_axis_origin(range.min[k], range.max[k], h.source.scale[k], h.source.offset[k]);
    anchor[k] = axis.anchor;
    cloud.origin[k] = axis.origin;
    if (static_cast<double>(range.max[k] - range.min[k]) >= 2 * kExactSteps) {
      notes.push_back(axis_warning(name, k, range.min[k], range.max[k], h.source.scale[k]));
    }
  }
  decode_records(records, h, any_origin ? anchor : nullptr, cloud);
  progress_advance(options.progress, data.size());

  cloud.metadata.las = h.source;
  std::string dropped;
  keep_records(h, cloud, dropped);
  if (!dropped.empty()) {
    notes.push_back(std::string(name) +
                    ": dropped variable-length records sspc does not carry: " + dropped);
  }
  if (las::point_layout(h.source.point_format).wave >= 0) {
    notes.push_back(std::string(name) +
                    ": dropped the waveform packet descriptors of point format " +
                    std::to_string(h.source.point_format));
  }
  LasPointAttributes& a = cloud.las;
  drop_if_zero(a.intensity);
  drop_if_zero(a.classification);
  drop_if_zero(a.classification_flags);
  drop_if_zero(a.scan_angle);
  drop_if_zero(a.scan_flags);
  drop_if_zero(a.user_data);
  drop_if_zero(a.point_source_id);
  drop_if_single_returns(a);
  set_colours(cloud);

  if (const auto bad = first_non_finite_point(cloud)) {
    return non_finite_error(
        name, cloud, *bad,
        "byte offset " + std::to_string(h.point_data_offset + *bad * h.record_length));
  }
  SSPC_RETURN_IF_ERROR(finish_cloud(cloud, name));
  if (options.positions_f64 != nullptr) {
    options.positions_f64->resize(cloud.size());
    for (std::size_t i = 0; i < cloud.size(); ++i) (*options.positions_f64)[i] = cloud.world(i);
  }
  if (options.warnings != nullptr) {
    for (std::string& note : notes) options.warnings->push_back(std::move(note));
  }
  return cloud;
}

}  // namespace io

StatusOr<PointCloud> read_las(std::span<const std::byte> data, std::string_view name) {
  return io::read_las_with_options(data, name, {});
}

}  // namespace sspc
