#include "io/ply_writer.hpp"

#include <bit>
#include <charconv>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "core/atomic_file.hpp"
#include "core/byte_reader.hpp"
#include "core/parallel.hpp"

namespace sspc {

namespace io {

namespace {

// Stores `v` at `p` in byte order `endian`.
inline void store_float(std::byte* p, float v, Endian endian) {
  std::uint32_t bits = std::bit_cast<std::uint32_t>(v);
  if (endian != kNativeEndian) bits = __builtin_bswap32(bits);
  std::memcpy(p, &bits, sizeof bits);
}

inline void store_double(std::byte* p, double v, Endian endian) {
  std::uint64_t bits = std::bit_cast<std::uint64_t>(v);
  if (endian != kNativeEndian) bits = __builtin_bswap64(bits);
  std::memcpy(p, &bits, sizeof bits);
}

inline void append_double(std::string& out, double v) {
  char buf[32];
  const auto res = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, res.ptr);
}

// Shortest representation that reads back to the same float (std::to_chars' guarantee).
inline void append_float(std::string& out, float v) {
  char buf[32];
  const auto res = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, res.ptr);
}

inline void append_uint(std::string& out, unsigned v) {
  char buf[8];
  const auto res = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, res.ptr);
}

// A comment is one header line: line breaks inside it would end the header early.
std::string one_line(const std::string& text) {
  std::string out = text;
  for (char& c : out) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  return out;
}

}  // namespace

PlyEncoder::PlyEncoder(const PointCloud& cloud, const PlyWriteOptions& options)
    : cloud_(cloud), options_(options) {
  normals_ = options.write_normals && cloud.has_normals() && cloud.normals.size() == cloud.size();
  colours_ = options.write_colours && cloud.has_colours() && cloud.colours.size() == cloud.size();
  doubles_ = cloud.origin != Vec3d::Zero();
  stride_ = (doubles_ ? 24u : 12u) + (normals_ ? 12u : 0u) + (colours_ ? 3u : 0u);
}

std::string PlyEncoder::header(std::size_t count) const {
  std::string h = "ply\nformat ";
  switch (options_.encoding) {
    case PlyEncoding::kBinaryLittleEndian: h += "binary_little_endian"; break;
    case PlyEncoding::kBinaryBigEndian: h += "binary_big_endian"; break;
    case PlyEncoding::kAscii: h += "ascii"; break;
  }
  h += " 1.0\n";
  for (const std::string& c : cloud_.metadata.comments) h += "comment " + one_line(c) + "\n";
  for (const std::string& c : options_.comments) h += "comment " + one_line(c) + "\n";
  if (!cloud_.metadata.crs_wkt.empty()) {
    h += "comment " + std::string(kPlyCrsComment) + one_line(cloud_.metadata.crs_wkt) + "\n";
  }
  h += "element vertex " + std::to_string(count) + "\n";
  if (doubles_) {
    h += "property double x\nproperty double y\nproperty double z\n";
  } else {
    h += "property float x\nproperty float y\nproperty float z\n";
  }
  if (normals_) h += "property float nx\nproperty float ny\nproperty float nz\n";
  if (colours_) h += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  h += "end_header\n";
  return h;
}

void PlyEncoder::append_body(std::size_t begin, std::size_t end, std::string& out) const {
  if (options_.encoding == PlyEncoding::kAscii) {
    append_ascii(begin, end, out);
  } else {
    append_binary(begin, end, out);
  }
}

void PlyEncoder::append_binary(std::size_t begin, std::size_t end, std::string& out) const {
  const Endian endian =
      options_.encoding == PlyEncoding::kBinaryBigEndian ? Endian::kBig : Endian::kLittle;
  const std::size_t base = out.size();
  out.resize(base + (end - begin) * stride_);
  auto* dst = reinterpret_cast<std::byte*>(out.data() + base);
  parallel_for_ranges(begin, end, 1 << 15, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) {
      std::byte* rec = dst + (i - begin) * stride_;
      if (doubles_) {
        const Vec3d w = cloud_.world(i);
        for (int k = 0; k < 3; ++k) store_double(rec + 8 * static_cast<std::size_t>(k), w[k], endian);
        rec += 24;
      } else {
        for (int k = 0; k < 3; ++k)
          store_float(rec + 4 * static_cast<std::size_t>(k), cloud_.positions[i][k], endian);
        rec += 12;
      }
      if (normals_) {
        for (int k = 0; k < 3; ++k)
          store_float(rec + 4 * static_cast<std::size_t>(k), cloud_.normals[i][k], endian);
        rec += 12;
      }
      if (colours_) {
        const Rgb8 c = cloud_.colours[i];
        rec[0] = std::byte{c.r};
        rec[1] = std::byte{c.g};
        rec[2] = std::byte{c.b};
      }
    }
  });
}

void PlyEncoder::append_ascii(std::size_t begin, std::size_t end, std::string& out) const {
  for (std::size_t i = begin; i < end; ++i) {
    if (doubles_) {
      const Vec3d w = cloud_.world(i);
      for (int k = 0; k < 3; ++k) {
        if (k > 0) out += ' ';
        append_double(out, w[k]);
      }
    } else {
      for (int k = 0; k < 3; ++k) {
        if (k > 0) out += ' ';
        append_float(out, cloud_.positions[i][k]);
      }
    }
    if (normals_) {
      for (int k = 0; k < 3; ++k) {
        out += ' ';
        append_float(out, cloud_.normals[i][k]);
      }
    }
    if (colours_) {
      const Rgb8 c = cloud_.colours[i];
      for (unsigned v : {unsigned{c.r}, unsigned{c.g}, unsigned{c.b}}) {
        out += ' ';
        append_uint(out, v);
      }
    }
    out += '\n';
  }
}

}  // namespace io

std::string encode_ply(const PointCloud& cloud, const PlyWriteOptions& options) {
  const io::PlyEncoder encoder(cloud, options);
  std::string out = encoder.header();
  encoder.append_body(0, cloud.size(), out);
  return out;
}

Status write_ply(const PointCloud& cloud, const std::filesystem::path& path,
                 const PlyWriteOptions& options) {
  if (Status s = cloud.validate(); !s.ok()) {
    return s.with_context("writing " + path.string());
  }
  const io::PlyEncoder encoder(cloud, options);
  AtomicFileWriter file;
  SSPC_RETURN_IF_ERROR(file.open(path));
  SSPC_RETURN_IF_ERROR(file.write(encoder.header()));
  // Chunks of about 16 MB bound the memory a large cloud needs on top of itself.
  constexpr std::size_t kChunk = std::size_t{1} << 19;
  std::string buffer;
  for (std::size_t begin = 0; begin < cloud.size(); begin += kChunk) {
    buffer.clear();
    encoder.append_body(begin, std::min(cloud.size(), begin + kChunk), buffer);
    SSPC_RETURN_IF_ERROR(file.write(buffer));
  }
  return file.commit();
}

struct PlyStreamWriter::Impl {
  std::filesystem::path path;
  PlyWriteOptions options;
  std::size_t memory_bytes = 0;
  bool started = false;
  PointCloud layout;  // the header's: the first chunk's metadata and origin, and one point of the fields
  bool fields_known = false;
  std::uint64_t count = 0;
  // The body's chunks as encoded, each its own string: one growing string re-copied itself as it
  // doubled (memmove and memset were 15% of autzen's streamed decode).
  std::vector<std::string> body;
  std::size_t body_bytes = 0;
  AtomicFileWriter spill;  // the body beyond memory_bytes, never committed
  bool spilling = false;

  Status fail(const std::string& what) const { return invalid_argument("writing " + path.string() + ": " + what); }
};

PlyStreamWriter::PlyStreamWriter(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
PlyStreamWriter::PlyStreamWriter(PlyStreamWriter&&) noexcept = default;
PlyStreamWriter& PlyStreamWriter::operator=(PlyStreamWriter&&) noexcept = default;
PlyStreamWriter::~PlyStreamWriter() = default;  // the spill's writer removes its file

StatusOr<PlyStreamWriter> PlyStreamWriter::open(const std::filesystem::path& path, const PlyWriteOptions& options,
                                                std::size_t memory_bytes) {
  auto impl = std::make_unique<Impl>();
  impl->path = path;
  impl->options = options;
  impl->memory_bytes = memory_bytes;
  return PlyStreamWriter(std::move(impl));
}

std::uint64_t PlyStreamWriter::points() const { return impl_->count; }

Status PlyStreamWriter::write(const PointCloud& chunk) {
  Impl& m = *impl_;
  if (Status s = chunk.validate(); !s.ok()) return s.with_context("writing " + m.path.string());
  if (!m.started) {
    m.started = true;
    m.layout.metadata = chunk.metadata;
    m.layout.origin = chunk.origin;
  } else if (chunk.origin != m.layout.origin) {
    return m.fail("a chunk with another origin than the first");
  }
  if (chunk.size() == 0) return Status();
  const io::PlyEncoder encoder(chunk, m.options);
  if (!m.fields_known) {
    m.fields_known = true;
    m.layout.positions.assign(1, Vec3f::Zero());
    if (encoder.writes_normals()) m.layout.normals.assign(1, Vec3f::UnitZ());
    if (encoder.writes_colours()) m.layout.colours.assign(1, Rgb8{});
  } else if (encoder.writes_normals() != m.layout.has_normals() || encoder.writes_colours() != m.layout.has_colours()) {
    return m.fail("a chunk with other fields (normals, colours) than the first");
  }
  encoder.append_body(0, chunk.size(), m.body.emplace_back());
  m.body_bytes += m.body.back().size();
  m.count += chunk.size();
  if (m.body_bytes >= m.memory_bytes) {
    if (!m.spilling) {
      m.spilling = true;
      std::string name = m.path.filename().string();
      name.insert(0, 1, '.');  // a hidden file (GCC 12 misreads "." + name as an overflow)
      name += ".body";
      SSPC_RETURN_IF_ERROR(m.spill.open(m.path.parent_path() / name));
    }
    for (const std::string& part : m.body) SSPC_RETURN_IF_ERROR(m.spill.write(part));
    m.body.clear();
    m.body_bytes = 0;
  }
  return Status();
}

Status PlyStreamWriter::finish() {
  Impl& m = *impl_;
  if (!m.started) return m.fail("no chunk was written");
  AtomicFileWriter file;
  SSPC_RETURN_IF_ERROR(file.open(m.path));
  SSPC_RETURN_IF_ERROR(file.write(io::PlyEncoder(m.layout, m.options).header(m.count)));
  if (m.spilling) {
    for (const std::string& part : m.body) SSPC_RETURN_IF_ERROR(m.spill.write(part));
    SSPC_RETURN_IF_ERROR(m.spill.flush());
    std::FILE* in = std::fopen(m.spill.temporary_path().c_str(), "rb");
    if (in == nullptr) return io_error("writing " + m.path.string() + ": cannot read back its body: " + std::strerror(errno));
    std::string block(std::size_t{16} << 20, '\0');
    Status copied;
    for (;;) {
      const std::size_t n = std::fread(block.data(), 1, block.size(), in);
      if (n > 0) copied = file.write(block.data(), n);
      if (!copied.ok() || n < block.size()) break;
    }
    if (copied.ok() && std::ferror(in) != 0) copied = io_error("writing " + m.path.string() + ": reading back its body failed");
    std::fclose(in);
    m.spill.abandon();
    SSPC_RETURN_IF_ERROR(copied);
  } else {
    for (const std::string& part : m.body) SSPC_RETURN_IF_ERROR(file.write(part));
  }
  m.body.clear();
  return file.commit();
}

Status write_point_cloud(const PointCloud& cloud, const std::filesystem::path& path,
                         const PlyWriteOptions& ply) {
  const PointCloudFormat format = format_from_extension(path);
  if (format == PointCloudFormat::kPly) return write_ply(cloud, path, ply);
  if (format == PointCloudFormat::kLas && path.extension() != ".laz" &&
      path.extension() != ".LAZ") {
    return write_las(cloud, path);
  }
  return unsupported(path.string() + ": sspc writes .ply and .las; name the output " +
                     path.stem().string() + ".ply or " + path.stem().string() + ".las");
}

}  // namespace sspc
