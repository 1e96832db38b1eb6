#include "format/metadata_section.hpp"

#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "core/byte_reader.hpp"
#include "core/varint.hpp"
#include "format/checksum.hpp"
#include "sspc/neighbours.hpp"

namespace sspc::codec {

namespace {

template <typename T>
void put(std::string& out, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof v);
  if constexpr (std::endian::native != std::endian::little) std::reverse(b, b + sizeof b);
  out.append(b, sizeof b);
}

void put_vec3d(std::string& out, const Vec3d& v) {
  for (int k = 0; k < 3; ++k) put<double>(out, v[k]);
}

std::string format_vec3(const Vec3d& v) {
  char text[96];
  std::snprintf(text, sizeof text, "(%.6g, %.6g, %.6g)", v.x(), v.y(), v.z());
  return text;
}

void put_text(std::string& out, const std::string& text) {
  append_varint(out, text.size());
  out += text;
}

// Reads the fields in FORMAT.md's order; every failure names the byte.
class PayloadReader {
 public:
  PayloadReader(std::span<const std::byte> payload, std::uint64_t file_offset,
                const std::string& name)
      : r_(payload, static_cast<std::size_t>(file_offset)), name_(name) {}

  StatusOr<ModelMetadata> read() {
    ModelMetadata m;
    SSPC_RETURN_IF_ERROR(read_vec3(m.origin, false, "origin"));
    // A world coordinate is origin + a float32 position: past kMaxCoordinate a box query's world
    // to local conversion leaves float's range (an origin of 1e308 verified, and then every box
    // decode failed).
    if ((m.origin.array().abs() > kMaxCoordinate).any()) {
      return fail(r_.offset() - 24, "origin " + format_vec3(m.origin) + " beyond +-1e18");
    }
    SSPC_ASSIGN_OR_RETURN(const auto has_las, read<std::uint8_t>());
    if (has_las > 1) return fail(r_.offset() - 1, "has_las is " + std::to_string(has_las));
    if (has_las == 1) {
      LasSource las;
      SSPC_ASSIGN_OR_RETURN(las.version_minor, read<std::uint8_t>());
      if (las.version_minor > 4) return fail(r_.offset() - 1, "LAS minor version above 4");
      SSPC_ASSIGN_OR_RETURN(las.point_format, read<std::uint8_t>());
      if (las.point_format > 10) return fail(r_.offset() - 1, "LAS point format above 10");
      SSPC_RETURN_IF_ERROR(read_vec3(las.scale, true, "LAS scale"));
      SSPC_RETURN_IF_ERROR(read_vec3(las.offset, false, "LAS offset"));
      SSPC_ASSIGN_OR_RETURN(las.global_encoding, read<std::uint16_t>());
      SSPC_ASSIGN_OR_RETURN(las.file_source_id, read<std::uint16_t>());
      las.system_identifier = "OTHER";
      m.cloud.las = las;
    }
    SSPC_ASSIGN_OR_RETURN(const std::uint64_t comments, read_count("comment count"));
    for (std::uint64_t i = 0; i < comments; ++i) {
      SSPC_ASSIGN_OR_RETURN(std::string c, read_text("comment"));
      m.cloud.comments.push_back(std::move(c));
    }
    SSPC_ASSIGN_OR_RETURN(m.cloud.crs_wkt, read_text("CRS WKT"));
    SSPC_ASSIGN_OR_RETURN(const std::uint64_t records, read_count("CRS record count"));
    for (std::uint64_t i = 0; i < records; ++i) {
      LasRecord rec;
      SSPC_ASSIGN_OR_RETURN(const auto user, r_.read_bytes(16));
      rec.user_id.assign(reinterpret_cast<const char*>(user.data()), user.size());
      rec.user_id.resize(std::min(rec.user_id.size(), rec.user_id.find('\0')));
      SSPC_ASSIGN_OR_RETURN(rec.record_id, read<std::uint16_t>());
      SSPC_ASSIGN_OR_RETURN(rec.data, read_text("CRS record"));
      m.cloud.crs_records.push_back(std::move(rec));
    }
    if (!r_.at_end()) {
      return fail(r_.offset(),
                  std::to_string(r_.remaining()) + " bytes after the last metadata field");
    }
    return m;
  }

 private:
  Status fail(std::size_t offset, const std::string& what) const {
    return corrupt(name_ + ": byte " + std::to_string(offset) + ": metadata: " + what);
  }
  Status in_context(const Status& s) const { return corrupt(name_ + ": metadata: " + s.message()); }
  template <typename T>
  StatusOr<T> read() {
    auto v = r_.read<T>();
    if (!v.ok()) return in_context(v.status());
    return v;
  }
  Status read_vec3(Vec3d& out, bool nonzero, const char* what) {
    const std::size_t at = r_.offset();
    for (int k = 0; k < 3; ++k) {
      SSPC_ASSIGN_OR_RETURN(out[k], read<double>());
    }
    if (!out.allFinite() || (nonzero && (out.array() == 0).any())) {
      return fail(at, std::string(what) + (nonzero ? " is zero or not finite" : " is not finite"));
    }
    return Status();
  }
  // A count of items that take at least one byte each.
  StatusOr<std::uint64_t> read_count(const char* what) {
    const std::size_t at = r_.offset();
    std::uint64_t n = 0;
    if (Status s = r_.read_varint(n); !s.ok()) return in_context(s);
    if (n > r_.remaining()) {
      return fail(at, std::string(what) + " " + std::to_string(n) + " exceeds the " +
                          std::to_string(r_.remaining()) + " bytes left");
    }
    return n;
  }
  StatusOr<std::string> read_text(const char* what) {
    SSPC_ASSIGN_OR_RETURN(const std::uint64_t n, read_count(what));
    SSPC_ASSIGN_OR_RETURN(const auto bytes, r_.read_bytes(static_cast<std::size_t>(n)));
    return std::string(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  }

  ByteReader r_;
  const std::string& name_;
};

}  // namespace

bool ModelMetadata::present() const {
  return origin != Vec3d::Zero() || !cloud.comments.empty() || cloud.has_crs() ||
         cloud.las.has_value();
}

std::string encode_metadata(const ModelMetadata& m) {
  std::string p;
  put_vec3d(p, m.origin);
  const std::optional<LasSource>& las = m.cloud.las;
  put<std::uint8_t>(p, las ? 1 : 0);
  if (las) {
    put<std::uint8_t>(p, las->version_minor);
    put<std::uint8_t>(p, las->point_format);
    put_vec3d(p, las->scale);
    put_vec3d(p, las->offset);
    put<std::uint16_t>(p, las->global_encoding);
    put<std::uint16_t>(p, las->file_source_id);
  }
  append_varint(p, m.cloud.comments.size());
  for (const std::string& c : m.cloud.comments) put_text(p, c);
  put_text(p, m.cloud.crs_wkt);
  append_varint(p, m.cloud.crs_records.size());
  for (const LasRecord& r : m.cloud.crs_records) {
    std::string user = r.user_id.substr(0, 16);
    user.resize(16, '\0');
    p += user;
    put<std::uint16_t>(p, r.record_id);
    put_text(p, r.data);
  }
  std::string out;
  put<std::uint32_t>(out, static_cast<std::uint32_t>(p.size()));
  put<std::uint32_t>(out, crc32_of(std::as_bytes(std::span<const char>(p.data(), p.size()))));
  return out + p;
}

StatusOr<ModelMetadata> decode_metadata(std::span<const std::byte> bytes, std::uint64_t file_offset,
                                        const std::string& name) {
  const auto fail = [&](std::uint64_t at, const std::string& what) {
    return corrupt(name + ": byte " + std::to_string(at) + ": metadata: " + what);
  };
  if (bytes.size() < 8) {
    return fail(file_offset + bytes.size(),
                "truncated: " + std::to_string(bytes.size()) + " of its 8 header bytes");
  }
  const auto size = load<std::uint32_t>(bytes.data(), Endian::kLittle);
  const auto crc = load<std::uint32_t>(bytes.data() + 4, Endian::kLittle);
  if (size != bytes.size() - 8) {
    return fail(file_offset, "payload size " + std::to_string(size) + " but " +
                                 std::to_string(bytes.size() - 8) + " bytes follow");
  }
  const std::span<const std::byte> payload = bytes.subspan(8);
  if (crc32_of(payload) != crc) return fail(file_offset + 4, "CRC32 mismatch");
  return PayloadReader(payload, file_offset + 8, name).read();
}

}  // namespace sspc::codec
