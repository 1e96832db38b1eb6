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
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/byte_reader.hpp"
#include "core/parallel.hpp"
#include "io/las_format.hpp"
#include "io/las_header.hpp"
#include "io/point_chunks.hpp"
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

// What the fields every record holds say over the whole file. A field that is zero in every
// record (no user data, no point source) is dropped: it is in every record of the format and says
// nothing that a writer would not restore; likewise single returns (1 of 1) everywhere, which is
// what a writer without return numbers writes. Colours scale down by their high bytes unless
// every value is below 256 (writers that store 8-bit values unscaled, which the specification's
// "normalised to 16 bits" rules out but many files do). Parts merge in any order.
struct LasFieldSummary {
  bool intensity = false, classification = false, classification_flags = false;
  bool scan_angle = false, scan_flags = false, user_data = false, point_source_id = false;
  bool multiple_returns = false;
  bool rgb_above_255 = false;

  void add(const LasPointAttributes& a) {
    intensity = intensity || any_nonzero(a.intensity);
    classification = classification || any_nonzero(a.classification);
    classification_flags = classification_flags || any_nonzero(a.classification_flags);
    scan_angle = scan_angle || any_nonzero(a.scan_angle);
    scan_flags = scan_flags || any_nonzero(a.scan_flags);
    user_data = user_data || any_nonzero(a.user_data);
    point_source_id = point_source_id || any_nonzero(a.point_source_id);
    for (std::size_t i = 0; i < a.return_number.size() && !multiple_returns; ++i) {
      multiple_returns = a.return_number[i] != 1 || a.number_of_returns[i] != 1;
    }
    for (std::size_t i = 0; i < a.rgb.size() && !rgb_above_255; ++i) {
      rgb_above_255 = std::max({a.rgb[i][0], a.rgb[i][1], a.rgb[i][2]}) > 255;
    }
  }

 private:
  template <typename T>
  static bool any_nonzero(const std::vector<T>& values) {
    return std::any_of(values.begin(), values.end(), [](const T& v) { return !(v == T{}); });
  }
};

// Drops the fields the summary of the whole file finds empty and sets the 8-bit colours, in a
// cloud that is the whole file or a chunk of it.
void apply_summary(const LasFieldSummary& s, PointCloud& cloud) {
  LasPointAttributes& a = cloud.las;
  if (!s.intensity) a.intensity = {};
  if (!s.classification) a.classification = {};
  if (!s.classification_flags) a.classification_flags = {};
  if (!s.scan_angle) a.scan_angle = {};
  if (!s.scan_flags) a.scan_flags = {};
  if (!s.user_data) a.user_data = {};
  if (!s.point_source_id) a.point_source_id = {};
  if (!s.multiple_returns) {
    a.return_number = {};
    a.number_of_returns = {};
  }
  if (a.rgb.empty()) return;
  cloud.colours.resize(a.rgb.size());
  const unsigned shift = s.rgb_above_255 ? 8 : 0;
  for (std::size_t i = 0; i < a.rgb.size(); ++i) {
    cloud.colours[i] = Rgb8{static_cast<std::uint8_t>(a.rgb[i][0] >> shift),
                            static_cast<std::uint8_t>(a.rgb[i][1] >> shift),
                            static_cast<std::uint8_t>(a.rgb[i][2] >> shift)};
  }
}

// Decodes the `n` records from `records` on and appends them to `cloud`, every array of which is
// as long as its positions. `anchor`: the integers of the origin, or nullptr for none.
void decode_records(const std::byte* records, std::size_t n, const LasHeader& h,
                    const std::int64_t* anchor, PointCloud& cloud) {
  const int format = h.source.point_format;
  const las::PointLayout layout = las::point_layout(format);
  const std::size_t stride = h.record_length;
  const std::size_t extra = stride - las::kMinRecordLength[static_cast<std::size_t>(format)];
  const std::size_t m = cloud.positions.size();
  LasPointAttributes& a = cloud.las;
  cloud.positions.resize(m + n);
  a.intensity.resize(m + n);
  a.return_number.resize(m + n);
  a.number_of_returns.resize(m + n);
  a.classification.resize(m + n);
  a.classification_flags.resize(m + n);
  a.scan_angle.resize(m + n);
  a.scan_flags.resize(m + n);
  a.user_data.resize(m + n);
  a.point_source_id.resize(m + n);
  if (layout.gps >= 0) a.gps_time.resize(m + n);
  if (layout.rgb >= 0) a.rgb.resize(m + n);
  if (layout.nir >= 0) a.nir.resize(m + n);
  a.extra_bytes_per_point = extra;
  a.extra_bytes.resize((m + n) * extra);
  const Vec3d scale = h.source.scale;
  const Vec3d offset = h.source.offset;
  constexpr Endian le = Endian::kLittle;
  parallel_for_ranges(m, m + n, 1 << 15, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) {
      const std::byte* r = records + (i - m) * stride;
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

// The records of a LAS file as a PointReader (io/point_chunks.hpp), a range at a time.
// `check_finite`: refuse a position that float32 cannot hold (a first pass, whose positions are
// not used, leaves that to the pass that keeps them).
class LasRecordReader final : public PointReader {
 public:
  LasRecordReader(std::span<const std::byte> data, const LasHeader& h, const std::int64_t* anchor,
                  std::string_view name, Progress* progress, bool check_finite)
      : data_(data),
        h_(h),
        anchor_(anchor),
        name_(name),
        progress_(progress),
        check_finite_(check_finite),
        count_(static_cast<std::size_t>(h.point_count)) {}

  Status read(std::size_t max_points, PointCloud& out) override {
    const std::size_t n = std::min(count_ - next_, max_points);
    const std::size_t first = out.size();
    decode_records(data_.data() + consumed(), n, h_, anchor_, out);
    if (const auto bad = check_finite_ ? first_non_finite_point(out, first) : std::nullopt) {
      const std::size_t point = next_ + (*bad - first);
      return non_finite_error(
          name_, out, *bad,
          "byte offset " + std::to_string(h_.point_data_offset + point * h_.record_length),
          next_ - first);
    }
    const std::size_t before = next_ == 0 ? 0 : consumed();
    next_ += n;
    done_ = next_ == count_;
    // The header and the (E)VLRs count with the first and the last records.
    progress_advance(progress_, (done_ ? data_.size() : consumed()) - before);
    return Status();
  }

  bool done() const override { return done_; }
  std::size_t consumed() const override {
    return static_cast<std::size_t>(h_.point_data_offset) + next_ * h_.record_length;
  }

 private:
  std::span<const std::byte> data_;
  const LasHeader& h_;
  const std::int64_t* anchor_;
  std::string_view name_;
  Progress* progress_;
  bool check_finite_;
  std::size_t count_;
  std::size_t next_ = 0;
  bool done_ = false;
};

// The origin the integer range of every record calls for, and the warnings about axes too wide
// for float32 to keep every integer.
struct LasOrigin {
  bool any = false;
  std::int64_t anchor[3] = {0, 0, 0};
  Vec3d origin = Vec3d::Zero();
};

LasOrigin choose_origin(const IntegerRange& range, const LasHeader& h, std::string_view name,
                        std::vector<std::string>& notes) {
  LasOrigin out;
  for (int k = 0; k < 3 && h.point_count != 0; ++k) {
    out.any = out.any ||
              axis_needs_origin(range.min[k], range.max[k], h.source.scale[k], h.source.offset[k]);
  }
  // Every axis then gets one, so that no axis keeps a large offset in its local values.
  for (int k = 0; k < 3 && out.any; ++k) {
    const AxisOrigin axis =
        choose_axis_origin(range.min[k], range.max[k], h.source.scale[k], h.source.offset[k]);
    out.anchor[k] = axis.anchor;
    out.origin[k] = axis.origin;
    if (static_cast<double>(range.max[k] - range.min[k]) >= 2 * kExactSteps) {
      notes.push_back(axis_warning(name, k, range.min[k], range.max[k], h.source.scale[k]));
    }
  }
  return out;
}

// The header's part of the cloud's metadata, with notes on what is dropped.
CloudMetadata las_metadata(const LasHeader& h, std::string_view name,
                           std::vector<std::string>& notes) {
  PointCloud holder;
  holder.metadata.las = h.source;
  std::string dropped;
  keep_records(h, holder, dropped);
  if (!dropped.empty()) {
    notes.push_back(std::string(name) +
                    ": dropped variable-length records sspc does not carry: " + dropped);
  }
  if (las::point_layout(h.source.point_format).wave >= 0) {
    notes.push_back(std::string(name) +
                    ": dropped the waveform packet descriptors of point format " +
                    std::to_string(h.source.point_format));
  }
  return std::move(holder.metadata);
}

StatusOr<LasHeader> parse_and_check(std::span<const std::byte> data, std::string_view name) {
  SSPC_ASSIGN_OR_RETURN(LasHeader h, parse_las_header(data, name));
  if (h.point_count > std::numeric_limits<std::size_t>::max() / 64) {
    return error_in(StatusCode::kResourceExhausted, name, "too many points");
  }
  return h;
}

void hand_on_warnings(std::vector<std::string>& notes, const ReadOptions& options) {
  if (options.warnings == nullptr) return;
  for (std::string& note : notes) options.warnings->push_back(std::move(note));
}

}  // namespace

StatusOr<PointCloud> read_las_with_options(std::span<const std::byte> data, std::string_view name,
                                           const ReadOptions& options) {
  SSPC_ASSIGN_OR_RETURN(const LasHeader h, parse_and_check(data, name));
  const std::byte* records = data.data() + h.point_data_offset;
  const auto n = static_cast<std::size_t>(h.point_count);
  std::vector<std::string> notes;
  const LasOrigin origin =
      choose_origin(integer_range(records, n, h.record_length), h, name, notes);

  PointCloud cloud;
  LasRecordReader reader(data, h, origin.any ? origin.anchor : nullptr, name, options.progress,
                         /*check_finite=*/true);
  SSPC_RETURN_IF_ERROR(reader.read(std::numeric_limits<std::size_t>::max(), cloud));
  cloud.origin = origin.origin;
  cloud.metadata = las_metadata(h, name, notes);
  LasFieldSummary summary;
  summary.add(cloud.las);
  apply_summary(summary, cloud);

  SSPC_RETURN_IF_ERROR(finish_cloud(cloud, name));
  if (options.positions_f64 != nullptr) {
    options.positions_f64->resize(cloud.size());
    for (std::size_t i = 0; i < cloud.size(); ++i) (*options.positions_f64)[i] = cloud.world(i);
  }
  hand_on_warnings(notes, options);
  return cloud;
}

Status read_las_chunks(const ChunkedRead& in) {
  const std::span<const std::byte> data = in.file.bytes();
  SSPC_ASSIGN_OR_RETURN(const LasHeader h, parse_and_check(data, in.name));
  const std::byte* records = data.data() + h.point_data_offset;
  const std::size_t stride = h.record_length;

  // The origin depends on every record's integers, the fields kept and the colours' scale on
  // every record's values: a first pass gathers them.
  IntegerRange range;
  LasFieldSummary summary;
  LasRecordReader scan(data, h, nullptr, in.name, in.options.progress, /*check_finite=*/false);
  SSPC_RETURN_IF_ERROR(run_pass(in, Pass::kScan, scan, [&](PointCloud& chunk, std::size_t first) {
                         range.merge(integer_range(records + first * stride, chunk.size(), stride));
                         summary.add(chunk.las);
                         return Status();
                       }).status());

  std::vector<std::string> notes;
  const LasOrigin origin = choose_origin(range, h, in.name, notes);
  const CloudMetadata metadata = las_metadata(h, in.name, notes);
  LasRecordReader reader(data, h, origin.any ? origin.anchor : nullptr, in.name,
                         in.options.progress, /*check_finite=*/true);
  SSPC_ASSIGN_OR_RETURN(const std::size_t n,
                        run_pass(in, Pass::kRead, reader, [&](PointCloud& chunk, std::size_t) {
                          chunk.origin = origin.origin;
                          chunk.metadata = metadata;
                          apply_summary(summary, chunk);
                          return in.sink(std::move(chunk));
                        }));
  if (n == 0) return finish_cloud(PointCloud(), in.name);
  hand_on_warnings(notes, in.options);
  return Status();
}

}  // namespace io

StatusOr<PointCloud> read_las(std::span<const std::byte> data, std::string_view name) {
  return io::read_las_with_options(data, name, {});
}

}  // namespace sspc
