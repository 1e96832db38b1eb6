#include "io/las_header.hpp"

#include <cmath>
#include <string>

#include "core/byte_reader.hpp"
#include "core/format_number.hpp"
#include "io/las_format.hpp"
#include "io/reader_common.hpp"

namespace sspc::io {

namespace {

// A fixed-size character field without its trailing NULs.
std::string fixed_string(const std::byte* p, std::size_t n) {
  std::string s(reinterpret_cast<const char*>(p), n);
  const std::size_t end = s.find('\0');
  if (end != std::string::npos) s.resize(end);
  return s;
}

template <typename T>
T at(std::span<const std::byte> data, std::size_t offset) {
  return load<T>(data.data() + offset, Endian::kLittle);
}

Status refuse_laz(std::string_view name, bool copc) {
  const std::string what = copc ? "COPC (cloud-optimised, LAZ-compressed LAS) is not supported"
                                : "LAZ (LASzip-compressed LAS) is not supported";
  return error_in(StatusCode::kUnsupported, name,
                  what +
                      "; decompress it to LAS first: pdal translate in.laz out.las, or "
                      "laszip -i in.laz -o out.las");
}

class HeaderParser {
 public:
  HeaderParser(std::span<const std::byte> data, std::string_view name) : data_(data), name_(name) {}

  StatusOr<LasHeader> parse() {
    SSPC_RETURN_IF_ERROR(parse_fixed());
    SSPC_RETURN_IF_ERROR(parse_vlrs());
    SSPC_RETURN_IF_ERROR(parse_evlrs());
    SSPC_RETURN_IF_ERROR(check_laz());
    SSPC_RETURN_IF_ERROR(check_points());
    return std::move(h_);
  }

 private:
  Status fail(std::size_t offset, const std::string& what) const {
    return error_at_offset(StatusCode::kParseError, name_, offset, what);
  }
  Status truncated(std::size_t offset, const std::string& what) const {
    return fail(data_.size(), "truncated: " + what + " needs bytes up to " +
                                  std::to_string(offset) + " but the file has " +
                                  std::to_string(data_.size()));
  }

  Status parse_fixed() {
    if (data_.size() < las::kSignature.size() || as_text(data_.first(4)) != las::kSignature) {
      return error_in(StatusCode::kParseError, name_, "not a LAS file: no 'LASF' signature");
    }
    if (data_.size() < las::kHeaderSize12) {
      return truncated(las::kHeaderSize12, "the public header block");
    }
    LasSource& s = h_.source;
    s.file_source_id = at<std::uint16_t>(data_, 4);
    s.global_encoding = at<std::uint16_t>(data_, 6);
    s.creation_day = at<std::uint16_t>(data_, 90);
    s.creation_year = at<std::uint16_t>(data_, 92);
    s.version_major = at<std::uint8_t>(data_, las::kOffVersionMajor);
    s.version_minor = at<std::uint8_t>(data_, las::kOffVersionMajor + 1);
    if (s.version_major != 1 || s.version_minor > 4) {
      return error_at_offset(StatusCode::kUnsupported, name_, las::kOffVersionMajor,
                             "LAS version " + std::to_string(s.version_major) + "." +
                                 std::to_string(s.version_minor) +
                                 " (this sspc reads LAS 1.0 to 1.4)");
    }
    s.system_identifier = fixed_string(data_.data() + 26, 32);
    s.generating_software = fixed_string(data_.data() + 58, 32);
    h_.header_size = at<std::uint16_t>(data_, las::kOffHeaderSize);
    const std::size_t needed = s.version_minor >= 4   ? las::kHeaderSize14
                               : s.version_minor == 3 ? las::kHeaderSize13
                                                      : las::kHeaderSize12;
    if (h_.header_size < needed) {
      return fail(las::kOffHeaderSize,
                  "header size " + std::to_string(h_.header_size) + " is less than LAS 1." +
                      std::to_string(s.version_minor) + "'s " + std::to_string(needed));
    }
    if (data_.size() < h_.header_size) return truncated(h_.header_size, "the public header block");
    h_.point_data_offset = at<std::uint32_t>(data_, las::kOffPointDataOffset);
    vlr_count_ = at<std::uint32_t>(data_, las::kOffVlrCount);
    format_byte_ = at<std::uint8_t>(data_, las::kOffPointFormat);
    h_.record_length = at<std::uint16_t>(data_, las::kOffRecordLength);
    h_.point_count = at<std::uint32_t>(data_, las::kOffLegacyCount);
    for (int k = 0; k < 3; ++k) {
      s.scale[k] = at<double>(data_, las::kOffScale + 8 * static_cast<std::size_t>(k));
      s.offset[k] = at<double>(data_, las::kOffOffset + 8 * static_cast<std::size_t>(k));
      if (!std::isfinite(s.scale[k]) || s.scale[k] == 0) {
        return fail(las::kOffScale + 8 * static_cast<std::size_t>(k),
                    "scale factor is zero or not finite");
      }
      // Real files use 0.0001 to 1. Local float32 values are multiples of the scale, and below
      // 1e-30 they would fall among float's subnormals, above 1e30 past its range after 2^22
      // steps: neither could give the stored integers back.
      if (!(std::abs(s.scale[k]) >= 1e-30 && std::abs(s.scale[k]) <= 1e30)) {
        return error_at_offset(StatusCode::kUnsupported, name_,
                               las::kOffScale + 8 * static_cast<std::size_t>(k),
                               "scale factor " + format_number(s.scale[k]) +
                                   " is outside 1e-30 to 1e30 in magnitude");
      }
      if (!std::isfinite(s.offset[k])) {
        return fail(las::kOffOffset + 8 * static_cast<std::size_t>(k), "offset is not finite");
      }
    }
    if (s.version_minor >= 4) {
      evlr_start_ = at<std::uint64_t>(data_, las::kOffEvlrStart);
      evlr_count_ = at<std::uint32_t>(data_, las::kOffEvlrCount);
      const auto count64 = at<std::uint64_t>(data_, las::kOffCount64);
      // A 1.4 writer fills the legacy count only for formats 0-5 and fewer than 2^32 points,
      // and then with the same value; the 64-bit count is the one that holds in every case.
      if (count64 != 0 || (format_byte_ & 0x3f) >= 6) h_.point_count = count64;
    }
    return Status();
  }

  Status parse_vlrs() {
    std::uint64_t at_byte = h_.header_size;
    for (std::uint32_t i = 0; i < vlr_count_; ++i) {
      if (at_byte + las::kVlrHeaderSize > h_.point_data_offset) {
        return fail(static_cast<std::size_t>(at_byte),
                    "variable-length record " + std::to_string(i) + " of " +
                        std::to_string(vlr_count_) + " starts past the point data offset " +
                        std::to_string(h_.point_data_offset));
      }
      if (at_byte + las::kVlrHeaderSize > data_.size()) {
        return truncated(static_cast<std::size_t>(at_byte + las::kVlrHeaderSize),
                         "variable-length record " + std::to_string(i));
      }
      const auto length = at<std::uint16_t>(data_, static_cast<std::size_t>(at_byte) + 20);
      const std::uint64_t end = at_byte + las::kVlrHeaderSize + length;
      if (end > h_.point_data_offset) {
        return fail(static_cast<std::size_t>(at_byte) + 20,
                    "variable-length record " + std::to_string(i) + " of " +
                        std::to_string(length) + " bytes runs past the point data offset " +
                        std::to_string(h_.point_data_offset));
      }
      if (end > data_.size()) {
        return truncated(static_cast<std::size_t>(end),
                         "variable-length record " + std::to_string(i));
      }
      add_record(static_cast<std::size_t>(at_byte), 20, las::kVlrHeaderSize, length);
      at_byte = end;
    }
    if (h_.point_data_offset < at_byte) {
      return fail(
          las::kOffPointDataOffset,
          "point data offset " + std::to_string(h_.point_data_offset) + " lies inside the header");
    }
    return Status();
  }

  Status parse_evlrs() {
    if (evlr_count_ == 0) return Status();
    if (evlr_start_ < h_.point_data_offset) {
      return fail(las::kOffEvlrStart, "extended variable-length records start at " +
                                          std::to_string(evlr_start_) + ", before the point data");
    }
    std::uint64_t at_byte = evlr_start_;
    for (std::uint32_t i = 0; i < evlr_count_; ++i) {
      if (at_byte > data_.size() || data_.size() - at_byte < las::kEvlrHeaderSize) {
        return truncated(static_cast<std::size_t>(
                             std::min<std::uint64_t>(at_byte + las::kEvlrHeaderSize, SIZE_MAX)),
                         "extended variable-length record " + std::to_string(i));
      }
      const auto length = at<std::uint64_t>(data_, static_cast<std::size_t>(at_byte) + 20);
      const std::uint64_t room = data_.size() - at_byte - las::kEvlrHeaderSize;
      if (length > room) {
        return fail(static_cast<std::size_t>(at_byte) + 20,
                    "extended variable-length record " + std::to_string(i) + " of " +
                        std::to_string(length) + " bytes runs past the end of the file");
      }
      add_record(static_cast<std::size_t>(at_byte), 28, las::kEvlrHeaderSize,
                 static_cast<std::size_t>(length));
      at_byte += las::kEvlrHeaderSize + length;
    }
    return Status();
  }

  // A record whose header starts at `offset`, description at offset + `description_at`.
  void add_record(std::size_t offset, std::size_t description_at, std::size_t header_size,
                  std::size_t length) {
    LasRecord r;
    r.user_id = fixed_string(data_.data() + offset + 2, 16);
    r.record_id = at<std::uint16_t>(data_, offset + 18);
    r.description = fixed_string(data_.data() + offset + description_at, 32);
    r.data.assign(reinterpret_cast<const char*>(data_.data() + offset + header_size), length);
    h_.vlrs.push_back(std::move(r));
  }

  Status check_laz() const {
    bool laszip = (format_byte_ & 0xc0) != 0;
    bool copc = false;
    for (const LasRecord& r : h_.vlrs) {
      if (r.user_id == las::kUserLaszip && r.record_id == las::kRecordLaszip) laszip = true;
      if (r.user_id == las::kUserCopc) copc = true;
    }
    if (copc) return refuse_laz(name_, true);
    if (laszip) return refuse_laz(name_, false);
    return Status();
  }

  Status check_points() {
    const int format = format_byte_;
    if (format > las::kMaxPointFormat) {
      return error_at_offset(
          StatusCode::kUnsupported, name_, las::kOffPointFormat,
          "point data record format " + std::to_string(format) + " (LAS defines 0 to 10)");
    }
    h_.source.point_format = static_cast<std::uint8_t>(format);
    const std::size_t minimum = las::kMinRecordLength[static_cast<std::size_t>(format)];
    if (h_.record_length < minimum) {
      return fail(las::kOffRecordLength, "point record length " + std::to_string(h_.record_length) +
                                             " is less than point format " +
                                             std::to_string(format) + "'s " +
                                             std::to_string(minimum));
    }
    // The point records end before the EVLRs, or the waveform data, when there are any.
    std::uint64_t limit = data_.size();
    if (evlr_count_ != 0) limit = std::min<std::uint64_t>(limit, evlr_start_);
    if (h_.source.version_minor >= 3) {
      // Internal waveform data packets (LAS 1.3's formats 4 and 5) follow the points too.
      const auto waveform = at<std::uint64_t>(data_, las::kOffWaveformStart);
      if (waveform > h_.point_data_offset) limit = std::min<std::uint64_t>(limit, waveform);
    }
    const std::uint64_t room = limit >= h_.point_data_offset ? limit - h_.point_data_offset : 0;
    if (h_.point_count > room / h_.record_length) {
      return fail(static_cast<std::size_t>(std::min<std::uint64_t>(limit, data_.size())),
                  "truncated: the header promises " + std::to_string(h_.point_count) +
                      " points of " + std::to_string(h_.record_length) + " bytes from byte " +
                      std::to_string(h_.point_data_offset) + " but only " +
                      std::to_string(room / h_.record_length) + " fit before byte " +
                      std::to_string(limit));
    }
    // More whole records than the header counts: the count is wrong, and reading it would drop
    // points silently (the PLY reader refuses the same lie).
    if (room / h_.record_length > h_.point_count) {
      return fail(las::kOffLegacyCount, "the header counts " + std::to_string(h_.point_count) +
                                            " points, but the point data holds " +
                                            std::to_string(room / h_.record_length) + " records of " +
                                            std::to_string(h_.record_length) + " bytes before byte " +
                                            std::to_string(limit));
    }
    return Status();
  }

  std::span<const std::byte> data_;
  std::string_view name_;
  LasHeader h_;
  std::uint32_t vlr_count_ = 0;
  std::uint8_t format_byte_ = 0;
  std::uint64_t evlr_start_ = 0;
  std::uint32_t evlr_count_ = 0;
};

}  // namespace

StatusOr<LasHeader> parse_las_header(std::span<const std::byte> data, std::string_view name) {
  return HeaderParser(data, name).parse();
}

}  // namespace sspc::io
