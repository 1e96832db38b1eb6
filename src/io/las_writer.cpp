#include "io/las_writer.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <iterator>
#include <limits>

#include "core/atomic_file.hpp"
#include "core/parallel.hpp"
#include "io/las_format.hpp"

namespace sspc {

namespace io {

namespace {

void put_bytes(std::string& out, const void* p, std::size_t n) {
  out.append(static_cast<const char*>(p), n);
}
template <typename T>
void put(std::string& out, T v) {
  static_assert(std::endian::native == std::endian::little, "LAS is little-endian");
  put_bytes(out, &v, sizeof v);
}
// A fixed-size character field, NUL-padded (and cut when too long).
void put_fixed(std::string& out, const std::string& text, std::size_t n) {
  std::string field = text.substr(0, n);
  field.resize(n, '\0');
  out += field;
}
template <typename T>
void store(std::byte* p, T v) {
  std::memcpy(p, &v, sizeof v);
}

template <typename T>
T value_or(const std::vector<T>& values, std::size_t i, T fallback) {
  return values.empty() ? fallback : values[i];
}

// The format that keeps a waveform format's other fields.
int without_waveform(int format) {
  switch (format) {
    case 4: return 1;
    case 5: return 3;
    case 9: return 6;
    case 10: return 8;
    default: return format;
  }
}

// The finest power of ten at which the cloud's integers span at most 2^22 steps, the span a
// reader gets back from float32 local values exactly (las_reader.cpp). Its step, at most
// extent · 2^-22, is within a few float32 steps of the local values' own precision.
double default_scale(double extent) {
  if (!(extent > 0)) return 0.001;
  return std::pow(10.0, std::ceil(std::log10(std::ldexp(extent, -22))));
}

}  // namespace

StatusOr<LasEncoder> LasEncoder::make(const PointCloud& cloud, const LasWriteOptions& options) {
  LasEncoder e(cloud);
  e.choose_format(options);
  SSPC_RETURN_IF_ERROR(e.choose_grid(options));
  const LasPointAttributes& a = cloud.las;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const unsigned r = a.return_number.empty() ? 1u : a.return_number[i];
    if (r >= 1 && r <= 15) ++e.by_return_[r - 1];
  }
  const CloudMetadata& m = cloud.metadata;
  if (!m.crs_wkt.empty()) {
    LasRecord wkt{std::string(las::kUserProjection), las::kRecordWkt, "OGC WKT",
                  m.crs_wkt + std::string(1, '\0')};
    e.records_.push_back(std::move(wkt));
    e.wkt_ = true;
  }
  // GeoTIFF keys go out as they came. The specification asks formats 6-10 for WKT only;
  // turning keys into WKT needs a projection database, which sspc does not have.
  for (const LasRecord& r : m.crs_records) e.records_.push_back(r);
  if (e.extra_ != 0) {
    for (const LasRecord& r : m.extra_bytes_records) e.records_.push_back(r);
  }
  // A record longer than a VLR holds goes after the points as an EVLR, which needs LAS 1.4.
  const auto too_long = [](const LasRecord& r) { return r.data.size() > std::numeric_limits<std::uint16_t>::max(); };
  std::copy_if(e.records_.begin(), e.records_.end(), std::back_inserter(e.extended_), too_long);
  std::erase_if(e.records_, too_long);
  if (!e.extended_.empty()) e.minor_ = 4;
  return e;
}

void LasEncoder::choose_format(const LasWriteOptions& options) {
  const PointCloud& c = *cloud_;
  const LasPointAttributes& a = c.las;
  const bool rgb = !a.rgb.empty() || c.has_colours();
  const bool gps = !a.gps_time.empty();
  const bool nir = !a.nir.empty();
  const auto above = [](const std::vector<std::uint8_t>& v, unsigned limit) {
    return std::any_of(v.begin(), v.end(), [&](std::uint8_t x) { return x > limit; });
  };
  const bool extended = nir || above(a.classification, 31) || above(a.return_number, 7) ||
                        above(a.number_of_returns, 7) || above(a.classification_flags, 7) ||
                        above(a.scan_flags, 3);
  int format = 0;
  if (options.point_format) {
    format = *options.point_format;
  } else if (c.metadata.las) {
    format = without_waveform(c.metadata.las->point_format);
    const las::PointLayout l = las::point_layout(format);
    if (l.extended) {
      if (nir)
        format = 8;
      else if (rgb && l.rgb < 0)
        format = 7;
    } else if (extended) {
      format = nir ? 8 : rgb || l.rgb >= 0 ? 7 : 6;
    } else {
      if (rgb && l.rgb < 0) format = l.gps >= 0 ? 3 : 2;
      if (gps && las::point_layout(format).gps < 0) format = format == 2 ? 3 : 1;
    }
  } else if (extended) {
    format = nir ? 8 : rgb ? 7 : 6;
  } else {
    format = (gps ? 1 : 0) + (rgb ? 2 : 0);
    if (format == 2 && gps) format = 3;
  }
  format_ = format;
  const std::uint64_t n = c.size();
  minor_ =
      format >= 6 || !c.metadata.crs_wkt.empty() || n > std::numeric_limits<std::uint32_t>::max()
          ? 4
          : 2;
  if (c.metadata.las) minor_ = std::max<int>(minor_, c.metadata.las->version_minor);
  extra_ = a.extra_bytes.empty() ? 0 : a.extra_bytes_per_point;
  record_length_ = las::kMinRecordLength[static_cast<std::size_t>(format)] + extra_;
}

Status LasEncoder::choose_grid(const LasWriteOptions& options) {
  const PointCloud& c = *cloud_;
  const Box3f box = c.bounding_box();
  const double extent = box.isEmpty() ? 0.0 : (box.max() - box.min()).cast<double>().maxCoeff();
  if (options.scale) {
    scale_ = *options.scale;
  } else if (c.metadata.las) {
    scale_ = c.metadata.las->scale;
  } else {
    scale_ = Vec3d::Constant(default_scale(extent));
  }
  if (!scale_.allFinite() || (scale_.array() == 0).any()) {
    return invalid_argument("LAS scale must be finite and not zero");
  }
  // The source's offset when its integers still fit, else the origin (the world values near
  // the cloud, rounded to the scale's grid).
  const auto fits = [&](const Vec3d& offset) {
    if (box.isEmpty()) return true;
    for (int k = 0; k < 3; ++k) {
      for (const double local : {static_cast<double>(box.min()[k]), static_cast<double>(box.max()[k])}) {
        const double x = (c.origin[k] - offset[k]) / scale_[k] + local / scale_[k];
        if (!(std::abs(x) < 2147483647.0)) return false;
      }
    }
    return true;
  };
  const auto centred = [&] {
    const Vec3d centre = box.isEmpty() ? Vec3d(Vec3d::Zero()) : Vec3d(box.center().cast<double>());
    Vec3d offset;
    for (int k = 0; k < 3; ++k) offset[k] = std::round((c.origin[k] + centre[k]) / scale_[k]) * scale_[k];
    return offset;
  };
  offset_ = c.metadata.las && !options.scale ? c.metadata.las->offset : Vec3d::Zero();
  if (!fits(offset_)) offset_ = centred();
  if (!fits(offset_) && c.metadata.las && !options.scale) {
    // A decoded or edited cloud may span more than its source's grid holds (a source scale of
    // 1e-30 spans 2e-21 units): the writer's own scale then, rather than no file.
    scale_ = Vec3d::Constant(default_scale(extent));
    offset_ = centred();
  }
  if (!fits(offset_)) {
    char text[160];
    std::snprintf(text, sizeof text, "the cloud spans more than LAS's 32-bit integers hold at scale %g",
                  scale_.minCoeff());
    return invalid_argument(text);
  }
  anchor_ = (c.origin - offset_).cwiseQuotient(scale_);
  integers_.resize(c.size());
  world_min_ = Vec3d::Constant(std::numeric_limits<double>::infinity());
  world_max_ = -world_min_;
  for (std::size_t i = 0; i < c.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      const double x = std::round(anchor_[k] + static_cast<double>(c.positions[i][k]) / scale_[k]);
      integers_[i][static_cast<std::size_t>(k)] = static_cast<std::int32_t>(x);
      const double w = offset_[k] + scale_[k] * x;
      world_min_[k] = std::min(world_min_[k], w);
      world_max_[k] = std::max(world_max_[k], w);
    }
  }
  if (c.empty()) world_min_ = world_max_ = Vec3d::Zero();
  return Status();
}

std::string LasEncoder::header() const {
  const PointCloud& c = *cloud_;
  const std::optional<LasSource>& src = c.metadata.las;
  const std::size_t header_size = minor_ >= 4   ? las::kHeaderSize14
                                  : minor_ == 3 ? las::kHeaderSize13
                                                : las::kHeaderSize12;
  std::size_t vlr_bytes = 0;
  for (const LasRecord& r : records_) vlr_bytes += las::kVlrHeaderSize + r.data.size();
  std::uint16_t global = src ? src->global_encoding : std::uint16_t{0};
  global = static_cast<std::uint16_t>(global & las::kGlobalGpsStandard);
  if (wkt_ && minor_ >= 4) global |= las::kGlobalWkt;
  std::uint16_t day = src ? src->creation_day : 0, year = src ? src->creation_year : 0;
  if (!src) {
    const auto today = std::chrono::floor<std::chrono::days>(std::chrono::system_clock::now());
    const std::chrono::year_month_day ymd(today);
    const auto jan1 = std::chrono::sys_days(ymd.year() / std::chrono::January / 1);
    day = static_cast<std::uint16_t>((today - jan1).count() + 1);
    year = static_cast<std::uint16_t>(static_cast<int>(ymd.year()));
  }
  const std::uint64_t n = c.size();
  std::string h;
  h += las::kSignature;
  put<std::uint16_t>(h, src ? src->file_source_id : std::uint16_t{0});
  put<std::uint16_t>(h, global);
  h.append(16, '\0');  // project GUID
  put<std::uint8_t>(h, 1);
  put<std::uint8_t>(h, static_cast<std::uint8_t>(minor_));
  put_fixed(h, src ? src->system_identifier : std::string("OTHER"), 32);
  put_fixed(h, "sspc", 32);
  put<std::uint16_t>(h, day);
  put<std::uint16_t>(h, year);
  put<std::uint16_t>(h, static_cast<std::uint16_t>(header_size));
  put<std::uint32_t>(h, static_cast<std::uint32_t>(header_size + vlr_bytes));
  put<std::uint32_t>(h, static_cast<std::uint32_t>(records_.size()));
  put<std::uint8_t>(h, static_cast<std::uint8_t>(format_));
  put<std::uint16_t>(h, static_cast<std::uint16_t>(record_length_));
  // Formats 6-10 and counts beyond 32 bits leave the legacy counts 0 (§2.4).
  const bool legacy = format_ < 6 && n <= std::numeric_limits<std::uint32_t>::max();
  put<std::uint32_t>(h, legacy ? static_cast<std::uint32_t>(n) : 0u);
  for (std::size_t r = 0; r < 5; ++r) {
    put<std::uint32_t>(h, legacy ? static_cast<std::uint32_t>(by_return_[r]) : 0u);
  }
  for (int k = 0; k < 3; ++k) put<double>(h, scale_[k]);
  for (int k = 0; k < 3; ++k) put<double>(h, offset_[k]);
  for (int k = 0; k < 3; ++k) {
    put<double>(h, world_max_[k]);
    put<double>(h, world_min_[k]);
  }
  if (minor_ >= 3) put<std::uint64_t>(h, 0);  // no waveform data packets
  if (minor_ >= 4) {
    const std::uint64_t points_end = header_size + vlr_bytes + n * record_length_;
    put<std::uint64_t>(h, extended_.empty() ? 0 : points_end);
    put<std::uint32_t>(h, static_cast<std::uint32_t>(extended_.size()));
    put<std::uint64_t>(h, n);
    for (std::uint64_t count : by_return_) put<std::uint64_t>(h, count);
  }
  for (const LasRecord& r : records_) {
    put<std::uint16_t>(h, 0);
    put_fixed(h, r.user_id, 16);
    put<std::uint16_t>(h, r.record_id);
    put<std::uint16_t>(h, static_cast<std::uint16_t>(r.data.size()));
    put_fixed(h, r.description, 32);
    h += r.data;
  }
  return h;
}

std::string LasEncoder::trailer() const {
  std::string t;
  for (const LasRecord& r : extended_) {
    put<std::uint16_t>(t, 0);
    put_fixed(t, r.user_id, 16);
    put<std::uint16_t>(t, r.record_id);
    put<std::uint64_t>(t, r.data.size());
    put_fixed(t, r.description, 32);
    t += r.data;
  }
  return t;
}

void LasEncoder::append_record(std::size_t i, std::byte* r) const {
  const PointCloud& c = *cloud_;
  const LasPointAttributes& a = c.las;
  const las::PointLayout l = las::point_layout(format_);
  for (std::size_t k = 0; k < 3; ++k) store<std::int32_t>(r + 4 * k, integers_[i][k]);
  store<std::uint16_t>(r + 12, value_or<std::uint16_t>(a.intensity, i, 0));
  const unsigned ret = value_or<std::uint8_t>(a.return_number, i, 1);
  const unsigned returns = value_or<std::uint8_t>(a.number_of_returns, i, 1);
  const unsigned cls = value_or<std::uint8_t>(a.classification, i, 0);
  const unsigned cls_flags = value_or<std::uint8_t>(a.classification_flags, i, 0);
  const unsigned scan = value_or<std::uint8_t>(a.scan_flags, i, 0);
  // The stored integer's whole range (the specification asks for ±90° in both forms, but a file
  // outside it still passes through unchanged); NaN as 0.
  double angle = static_cast<double>(value_or<float>(a.scan_angle, i, 0.0f));
  if (!std::isfinite(angle)) angle = 0;
  if (!l.extended) {
    r[14] = std::byte(
        static_cast<std::uint8_t>((ret & 7u) | ((returns & 7u) << 3) | ((scan & 3u) << 6)));
    r[15] = std::byte(static_cast<std::uint8_t>((cls & 31u) | ((cls_flags & 7u) << 5)));
    store<std::int8_t>(r + 16,
                       static_cast<std::int8_t>(std::clamp(std::round(angle), -128.0, 127.0)));
    r[17] = std::byte(value_or<std::uint8_t>(a.user_data, i, 0));
    store<std::uint16_t>(r + 18, value_or<std::uint16_t>(a.point_source_id, i, 0));
  } else {
    r[14] = std::byte(static_cast<std::uint8_t>((ret & 15u) | ((returns & 15u) << 4)));
    r[15] = std::byte(static_cast<std::uint8_t>((cls_flags & 15u) | (((scan >> 2) & 3u) << 4) |
                                                ((scan & 3u) << 6)));
    r[16] = std::byte(static_cast<std::uint8_t>(cls));
    r[17] = std::byte(value_or<std::uint8_t>(a.user_data, i, 0));
    store<std::int16_t>(r + 18, static_cast<std::int16_t>(
                                    std::clamp(std::round(angle / 0.006), -32768.0, 32767.0)));
    store<std::uint16_t>(r + 20, value_or<std::uint16_t>(a.point_source_id, i, 0));
  }
  if (l.gps >= 0) store<double>(r + l.gps, value_or<double>(a.gps_time, i, 0.0));
  if (l.rgb >= 0) {
    std::array<std::uint16_t, 3> rgb{};
    if (!a.rgb.empty()) {
      rgb = a.rgb[i];
    } else if (c.has_colours()) {
      // 8 bits to 16 by repeating the byte: 255 becomes 65535 (§2.6, "normalised to 16 bits").
      const Rgb8 v = c.colours[i];
      rgb = {static_cast<std::uint16_t>(v.r * 257), static_cast<std::uint16_t>(v.g * 257),
             static_cast<std::uint16_t>(v.b * 257)};
    }
    for (std::size_t k = 0; k < 3; ++k) store<std::uint16_t>(r + l.rgb + 2 * k, rgb[k]);
  }
  if (l.nir >= 0) store<std::uint16_t>(r + l.nir, value_or<std::uint16_t>(a.nir, i, 0));
  if (extra_ != 0) {
    std::memcpy(r + (record_length_ - extra_), a.extra_bytes.data() + i * extra_, extra_);
  }
}

void LasEncoder::append_points(std::size_t begin, std::size_t end, std::string& out) const {
  const std::size_t base = out.size();
  out.resize(base + (end - begin) * record_length_);
  auto* dst = reinterpret_cast<std::byte*>(out.data() + base);
  std::memset(dst, 0, (end - begin) * record_length_);
  parallel_for_ranges(begin, end, 1 << 15, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) append_record(i, dst + (i - begin) * record_length_);
  });
}

}  // namespace io

StatusOr<std::string> encode_las(const PointCloud& cloud, const LasWriteOptions& options) {
  SSPC_RETURN_IF_ERROR(cloud.validate());
  SSPC_ASSIGN_OR_RETURN(const io::LasEncoder encoder, io::LasEncoder::make(cloud, options));
  std::string out = encoder.header();
  encoder.append_points(0, cloud.size(), out);
  out += encoder.trailer();
  return out;
}

Status write_las(const PointCloud& cloud, const std::filesystem::path& path,
                 const LasWriteOptions& options) {
  if (Status s = cloud.validate(); !s.ok()) return s.with_context("writing " + path.string());
  auto encoder = io::LasEncoder::make(cloud, options);
  if (!encoder.ok()) return encoder.status().with_context("writing " + path.string());
  AtomicFileWriter file;
  SSPC_RETURN_IF_ERROR(file.open(path));
  SSPC_RETURN_IF_ERROR(file.write(encoder->header()));
  constexpr std::size_t kChunk = std::size_t{1} << 19;
  std::string buffer;
  for (std::size_t begin = 0; begin < cloud.size(); begin += kChunk) {
    buffer.clear();
    encoder->append_points(begin, std::min(cloud.size(), begin + kChunk), buffer);
    SSPC_RETURN_IF_ERROR(file.write(buffer));
  }
  SSPC_RETURN_IF_ERROR(file.write(encoder->trailer()));
  return file.commit();
}

}  // namespace sspc
