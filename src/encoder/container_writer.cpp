// The .sspc writer (docs/FORMAT.md). Each block is encoded, decoded again (so that what the
// header and seek tables promise, the code-word radius and the block boxes, is computed exactly
// as a reader will compute it) and compressed on its own, in parallel.
#include "encoder/container_writer.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>
#include <memory>
#include <utility>
#include <vector>

#include <fcntl.h>
#include <zstd.h>

#include "core/atomic_file.hpp"
#include "core/parallel.hpp"
#include "core/varint.hpp"
#include "encoder/codeword_trim.hpp"
#include "encoder/resample_choice.hpp"
#include "format/block_codec.hpp"
#include "format/checksum.hpp"
#include "format/container_format.hpp"
#include "format/quantise.hpp"
#include "sspc/compressed_model.hpp"
#include "sspc/neighbours.hpp"

namespace sspc::codec {
namespace {

void put_u8(std::string& out, std::uint8_t v) {
  out.push_back(static_cast<char>(v));
}
void put_u16(std::string& out, std::uint16_t v) {
  for (int i = 0; i < 2; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
}
void put_u32(std::string& out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
}
void put_u64(std::string& out, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
}
void put_f32(std::string& out, float v) {
  put_u32(out, std::bit_cast<std::uint32_t>(v));
}
void put_vec3(std::string& out, const Vec3f& v) {
  for (int a = 0; a < 3; ++a) put_f32(out, v[a]);
}

std::span<const std::byte> as_bytes(const std::string& s) {
  return std::as_bytes(std::span<const char>(s.data(), s.size()));
}

struct BuiltBlock {
  std::string stored;
  BlockEntry entry;
  Status status;
  float radius = 0;  // code-book blocks: the largest code-word radius
};

// zstd without the frame fields the seek table already carries (size, checksum, dictionary),
// or the raw payload when zstd does not shrink it or would shrink it more than a reader accepts
// (kMaxBlockExpansion).
struct ZstdCctxDeleter {
  void operator()(ZSTD_CCtx* ctx) const { ZSTD_freeCCtx(ctx); }
};

Status compress_block(const std::string& raw, int level, BuiltBlock& block) {
  if (raw.size() > kMaxRawBlockSize) {
    return invalid_argument("a block's payload of " + std::to_string(raw.size()) +
                            " bytes exceeds the format's 64 MiB; use fewer items per block");
  }
  std::string compressed(ZSTD_compressBound(raw.size()), '\0');
  const std::unique_ptr<ZSTD_CCtx, ZstdCctxDeleter> ctx(ZSTD_createCCtx());
  if (ctx == nullptr) return resource_exhausted("zstd: cannot create a compression context");
  // A frame without these fields is what the seek table expects; a zstd that refuses to leave
  // them out would write blocks a reader rejects, so a refusal is an error, not a default.
  const std::pair<ZSTD_cParameter, int> parameters[] = {{ZSTD_c_compressionLevel, level},
                                                        {ZSTD_c_contentSizeFlag, 0},
                                                        {ZSTD_c_checksumFlag, 0},
                                                        {ZSTD_c_dictIDFlag, 0}};
  for (const auto& [parameter, value] : parameters) {
    const std::size_t rc = ZSTD_CCtx_setParameter(ctx.get(), parameter, value);
    if (ZSTD_isError(rc)) return internal_error(std::string("zstd: ") + ZSTD_getErrorName(rc));
  }
  const std::size_t n =
      ZSTD_compress2(ctx.get(), compressed.data(), compressed.size(), raw.data(), raw.size());
  if (ZSTD_isError(n)) return internal_error(std::string("zstd: ") + ZSTD_getErrorName(n));
  if (n < raw.size() && raw.size() <= n * kMaxBlockExpansion) {
    compressed.resize(n);
    block.stored = std::move(compressed);
  } else {
    block.stored = raw;
  }
  block.entry.raw_size = static_cast<std::uint32_t>(raw.size());
  block.entry.stored_size = static_cast<std::uint32_t>(block.stored.size());
  block.entry.crc32 = crc32_of(as_bytes(block.stored));
  return Status();
}

Status validate(const EncodedModel& model, const QuantOptions& o) {
  auto bits_ok = [](int b, int lo, int hi) { return b >= lo && b <= hi; };
  if (!bits_ok(o.position_bits, kMinPositionBits, kMaxPositionBits) ||
      !bits_ok(o.normal_bits, kMinNormalBits, kMaxNormalBits) ||
      !bits_ok(o.rotation_bits, kMinRotationBits, kMaxRotationBits)) {
    return invalid_argument(
        "quantisation bits out of range (positions 4–16, normals 4–16, "
        "rotations 4–20)");
  }
  if (o.format_version < 2 || o.format_version > kFormatVersion) {
    return invalid_argument("the writer writes format versions 2 to " + std::to_string(kFormatVersion) + ", not " + std::to_string(o.format_version));
  }
  if (o.resample < -1 || o.resample > kMaxResample || (o.resample > 0 && o.format_version < 4)) {
    return invalid_argument("resample must be 0 to 4 (-1: chosen by the writer), and needs format version 4 or later");
  }
  if (o.patches_per_block == 0 || o.codewords_per_block == 0) {
    return invalid_argument("patches_per_block and codewords_per_block must be at least 1");
  }
  if (const AttributeParams& a = o.attributes; a.channels != 0) {
    if ((a.channels & ~kKnownChannels) != 0) return invalid_argument("unknown attribute channels");
    if (o.format_version < 3 || model.has_colours) {
      return invalid_argument("per-patch attributes need format version 3 or later and no code-word colours");
    }
    if (a.colour_step < 1 || a.colour_step > kMaxColourStep || a.intensity_step < 1 ||
        a.intensity_step > kMaxIntensityStep) {
      return invalid_argument("colour step must be 1–64 and intensity step 1–4096");
    }
  }
  if (o.zstd_level < ZSTD_minCLevel() || o.zstd_level > ZSTD_maxCLevel()) {
    return invalid_argument("zstd_level out of range");
  }
  if (!(o.position_step >= 0) || !std::isfinite(o.position_step)) {
    return invalid_argument("position_step must be finite and non-negative");
  }
  if (!(o.translation_step >= 0) || !std::isfinite(o.translation_step)) {
    return invalid_argument("translation_step must be finite and non-negative");
  }
  if (!(model.patch_radius > 0) || !std::isfinite(model.patch_radius)) {
    return invalid_argument("patch_radius must be finite and positive");
  }
  if (!(model.coverage_radius >= 0) || !std::isfinite(model.coverage_radius) ||
      !(model.spacing >= 0) || !std::isfinite(model.spacing)) {
    return invalid_argument("coverage_radius and spacing must be finite and non-negative");
  }
  if (model.codebook.size() > std::numeric_limits<std::uint32_t>::max() ||
      model.patches.size() > std::numeric_limits<std::uint32_t>::max()) {
    return invalid_argument("more than 2^32 − 1 code words or patches");
  }
  if (!model.patches.empty() && model.bounds.isEmpty()) {
    return invalid_argument("the model has patches but empty bounds");
  }
  if (!model.bounds.isEmpty() &&
      (!model.bounds.min().allFinite() || !model.bounds.max().allFinite())) {
    return invalid_argument("the model's bounds are not finite");
  }
  if (const Vec3d& origin = model.metadata.origin;
      !origin.allFinite() || (origin.array().abs() > kMaxCoordinate).any()) {
    return invalid_argument("the model's origin is not finite or beyond +-1e18 (a reader refuses it)");
  }
  for (std::size_t c = 0; c < model.codebook.size(); ++c) {
    const Codeword& w = model.codebook[c];
    const std::string where = "code word " + std::to_string(c);
    if (model.has_normals && w.normals.size() != w.points.size()) {
      return invalid_argument(where + " has " + std::to_string(w.normals.size()) + " normals for " +
                              std::to_string(w.points.size()) + " points");
    }
    if (model.has_colours && w.colours.size() != w.points.size()) {
      return invalid_argument(where + " has " + std::to_string(w.colours.size()) + " colours for " +
                              std::to_string(w.points.size()) + " points");
    }
    if (w.points.size() > std::numeric_limits<std::uint32_t>::max() / 16) {
      return invalid_argument(where + " has too many points");
    }
  }
  for (std::size_t k = 0; k < model.patches.size(); ++k) {
    const PatchInstance& p = model.patches[k];
    if (p.codeword >= model.codebook.size()) {
      return invalid_argument("patch " + std::to_string(k) + " refers to code word " +
                              std::to_string(p.codeword) + " of " +
                              std::to_string(model.codebook.size()));
    }
    if (!p.world_from_codeword.rotation.allFinite() ||
        !p.world_from_codeword.translation.allFinite()) {
      return invalid_argument("patch " + std::to_string(k) + " has a non-finite transform");
    }
  }
  return Status();
}

std::string encode_header(const ContainerHeader& h) {
  std::string out;
  out.reserve(kHeaderSize);
  for (std::uint8_t b : kMagic) put_u8(out, b);
  put_u16(out, h.version);
  put_u16(out, h.flags);
  put_u32(out, static_cast<std::uint32_t>(kHeaderSize));
  put_f32(out, h.patch_radius);
  put_f32(out, h.coverage_radius);
  put_f32(out, h.spacing);
  put_f32(out, h.codeword_radius);
  put_u64(out, h.source_points);
  put_vec3(out, h.bounds_min);
  put_vec3(out, h.bounds_max);
  put_f32(out, h.translation_step);
  put_u8(out, static_cast<std::uint8_t>(h.position_bits));
  put_u8(out, static_cast<std::uint8_t>(h.normal_bits));
  put_u8(out, static_cast<std::uint8_t>(h.rotation_bits));
  put_u8(out, static_cast<std::uint8_t>(h.resample));
  put_u32(out, h.codeword_count);
  put_u32(out, h.patch_count);
  put_u64(out, h.codeword_point_count);
  put_u32(out, h.codewords_per_block);
  put_u32(out, h.patches_per_block);
  for (const SectionEntry& s : h.sections) {
    put_u32(out, static_cast<std::uint32_t>(s.kind));
    put_u32(out, s.crc32);
    put_u64(out, s.offset);
    put_u64(out, s.size);
  }
  put_u32(out, crc32_of(as_bytes(out)));
  return out;
}

// Where the container's bytes go: a string, or a temporary file that finish() renames over the
// target. Both can be read back as a model before the end (the attributes are coded on what the
// geometry decodes to).
class Sink {
 public:
  virtual ~Sink() = default;
  virtual Status append(std::string_view bytes) = 0;
  virtual Status write_at(std::uint64_t offset, std::string_view bytes) = 0;
  virtual std::uint64_t size() const = 0;
  virtual StatusOr<CompressedModel> open_model() = 0;  // the bytes written so far
  virtual Status commit() = 0;
  virtual std::string take() { return {}; }
};

class StringSink final : public Sink {
 public:
  Status append(std::string_view bytes) override {
    out_ += bytes;
    return Status();
  }
  Status write_at(std::uint64_t offset, std::string_view bytes) override {
    out_.replace(static_cast<std::size_t>(offset), bytes.size(), bytes);
    return Status();
  }
  std::uint64_t size() const override { return out_.size(); }
  StatusOr<CompressedModel> open_model() override { return CompressedModel::from_bytes(out_); }
  Status commit() override { return Status(); }
  std::string take() override { return std::move(out_); }

 private:
  std::string out_;
};

class FileSink final : public Sink {
 public:
  Status open(const std::filesystem::path& path) { return file_.open(path); }
  Status append(std::string_view bytes) override {
    size_ += bytes.size();
    return file_.write(bytes);
  }
  Status write_at(std::uint64_t offset, std::string_view bytes) override { return file_.write_at(offset, bytes); }
  std::uint64_t size() const override { return size_; }
  StatusOr<CompressedModel> open_model() override {
    SSPC_RETURN_IF_ERROR(file_.flush());
    return CompressedModel::open(file_.temporary_path());
  }
  Status commit() override { return file_.commit(); }

 private:
  AtomicFileWriter file_;
  std::uint64_t size_ = 0;
};

std::string encode_seek_entry(const BlockEntry& e, bool patch_block) {
  std::string out;
  put_u64(out, e.offset);
  put_u32(out, e.stored_size);
  put_u32(out, e.raw_size);
  put_u32(out, e.crc32);
  put_u32(out, e.first);
  put_u32(out, e.count);
  put_u32(out, patch_block ? 0 : e.point_count);
  if (patch_block) {
    put_vec3(out, e.box.min());
    put_vec3(out, e.box.max());
  }
  return out;
}

std::uint32_t crc32_update(std::uint32_t crc, std::string_view bytes) {
  return crc32_continue(crc, std::as_bytes(std::span<const char>(bytes.data(), bytes.size())));
}

// One section as it is appended: its place, size and running CRC.
struct SectionWriter {
  std::uint64_t offset = 0;
  std::uint64_t size = 0;
  std::uint32_t crc = 0;
  Status append(Sink& sink, std::string_view bytes) {
    crc = crc32_update(crc, bytes);
    size += bytes.size();
    return sink.append(bytes);
  }
};

// Code books set aside until every tile's patches are known: one record per tile in a file of a
// hidden folder beside the output (removed with it), native byte order, read back once.
class CodebookSpill {
 public:
  Status open(const std::filesystem::path& output) {
    std::filesystem::path dir = output.parent_path();
    SSPC_RETURN_IF_ERROR(dir_.open(dir.empty() ? std::filesystem::path(".") : dir));
    path_ = dir_.stage("codebooks");
    file_ = std::fopen(path_.c_str(), "w+b");
    if (file_ == nullptr) return io_error(path_.string() + ": cannot create: " + std::strerror(errno));
    return Status();
  }
  ~CodebookSpill() {
    if (file_ != nullptr) std::fclose(file_);
  }
  // Written straight through the stream's buffer: building the record in one string first cost
  // 0.38 s of a tile's 0.46 s on autzen's 1M-point tiles (a fresh 47 MB, its pages faulted in).
  Status put(const std::vector<Codeword>& codebook) {
    const std::uint64_t start = end_;
    auto write = [this](const void* data, std::size_t n) {
      if (n > 0 && std::fwrite(data, 1, n, file_) != n) return false;
      end_ += n;
      return true;
    };
    bool ok = std::fseek(file_, 0, SEEK_END) == 0;
    std::string head;
    put_u64(head, codebook.size());
    ok = ok && write(head.data(), head.size());
    for (std::size_t i = 0; i < codebook.size() && ok; ++i) {
      const Codeword& w = codebook[i];
      head.clear();
      put_u64(head, w.points.size());
      put_u8(head, static_cast<std::uint8_t>((w.normals.empty() ? 0 : 1) | (w.colours.empty() ? 0 : 2)));
      ok = write(head.data(), head.size()) && write(w.points.data(), w.points.size() * sizeof(Vec3f)) &&
           write(w.normals.data(), w.normals.size() * sizeof(Vec3f)) &&
           write(w.colours.data(), w.colours.size() * sizeof(Rgb8));
    }
    if (!ok) return io_error(path_.string() + ": write failed: " + std::strerror(errno));
    records_.emplace_back(start, end_ - start);
    return Status();
  }
  StatusOr<std::vector<Codeword>> get(std::size_t t) {
    const auto [offset, size] = records_.at(t);
    std::string in(size, '\0');
    if (std::fseek(file_, static_cast<long>(offset), SEEK_SET) != 0 || std::fread(in.data(), 1, size, file_) != size) {
      return io_error(path_.string() + ": cannot read back what was written");
    }
    // Each record is read once: its disk space is given back now, so that only the code books of
    // tiles not yet written take disk. Untrimmed code words hold whole spheres: 1B points had
    // spilled 13.5 GB 23 minutes into their encode, on the way past the disk's free 35 GB. Where
    // the file system cannot punch holes, the file stays whole.
#ifdef FALLOC_FL_PUNCH_HOLE
    (void)::fallocate(::fileno(file_), FALLOC_FL_PUNCH_HOLE | FALLOC_FL_KEEP_SIZE, static_cast<off_t>(offset),
                      static_cast<off_t>(size));
#endif
    const char* at = in.data();
    auto take = [&at](void* to, std::size_t n) {
      if (n > 0) std::memcpy(to, at, n);
      at += n;
    };
    std::uint64_t count = 0;
    take(&count, 8);
    std::vector<Codeword> codebook(count);
    for (Codeword& w : codebook) {
      std::uint64_t n = 0;
      std::uint8_t flags = 0;
      take(&n, 8);
      take(&flags, 1);
      w.points.resize(n);
      take(w.points.data(), n * sizeof(Vec3f));
      if (flags & 1) {
        w.normals.resize(n);
        take(w.normals.data(), n * sizeof(Vec3f));
      }
      if (flags & 2) {
        w.colours.resize(n);
        take(w.colours.data(), n * sizeof(Rgb8));
      }
    }
    return codebook;
  }

 private:
  StagingDirectory dir_;
  std::filesystem::path path_;
  std::FILE* file_ = nullptr;
  std::uint64_t end_ = 0;
  std::vector<std::pair<std::uint64_t, std::size_t>> records_;
};

}  // namespace

struct ContainerStreamWriter::Impl {
  QuantOptions options;
  ContainerHeader h;
  ModelMetadata metadata;
  std::unique_ptr<Sink> sink;
  ContainerStats stats;
  SectionWriter codebook_section;
  std::string codebook_seek;  // section 2, built as blocks are written
  std::vector<Codeword> pending;  // code words not yet in a block
  std::uint64_t codewords = 0;    // added so far
  std::uint64_t blocked = 0;      // written in blocks so far
  std::vector<PatchInstance> patches;  // expressed in the decoded frames, global code-word indices
  std::vector<std::size_t> tile_first_patch{0};
  std::vector<std::uint64_t> tile_first_codeword{0};
  // The tiles' code books (expressed and merged) until finish() trims them: in memory, or in a
  // file beside the output.
  std::vector<std::vector<Codeword>> held;
  std::unique_ptr<CodebookSpill> spill;
  std::vector<Box3f> expected;  // expect_tiles(): the boxes that hold each tile's patch centres
  std::vector<Box3f> written_reach;  // reach_of() of the tiles written before finish()
  std::size_t written_tiles = 0;  // tiles whose code books are trimmed and in blocks or pending
  bool finished = false;
  bool bounds_empty = false;  // the model's: then no tile may have patches

  std::size_t tiles() const { return tile_first_patch.size() - 1; }
  Box3f reach_of(std::size_t t) const;
  Status write_tile_codebook(std::size_t t);
  Status write_ready_tiles();
  Status write_codebook_blocks(bool last);
  StatusOr<std::string> attribute_part(CompressedModel& geometry, const TileSource& source);
  StatusOr<int> measured_resample(const CompressedModel& geometry, const TileSource& source, int rule, int max_m);
};

ContainerStreamWriter::ContainerStreamWriter(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
ContainerStreamWriter::ContainerStreamWriter(ContainerStreamWriter&&) noexcept = default;
ContainerStreamWriter& ContainerStreamWriter::operator=(ContainerStreamWriter&&) noexcept = default;
ContainerStreamWriter::~ContainerStreamWriter() = default;

namespace {

// The header's model-wide fields from `model` (its code book and patches are not looked at) and
// the options, as every tile shares them.
ContainerHeader shared_header(const EncodedModel& model, const QuantOptions& options) {
  ContainerHeader h;
  h.version = static_cast<std::uint16_t>(options.format_version);
  const bool duplicates_flag = options.keep_duplicates && h.version >= 3;
  h.flags = static_cast<std::uint16_t>((model.has_normals ? kFlagNormals : 0) |
                                       (model.has_colours ? kFlagColours : 0) |
                                       (model.metadata.present() ? kFlagMetadata : 0) |
                                       (duplicates_flag ? kFlagDuplicates : 0) |
                                       (options.attributes.channels != 0 ? kFlagAttributes : 0));
  h.patch_radius = model.patch_radius;
  h.coverage_radius = model.coverage_radius;
  h.spacing = model.spacing;
  h.source_points = model.source_points;
  if (!model.bounds.isEmpty()) {
    h.bounds_min = model.bounds.min();
    h.bounds_max = model.bounds.max();
  }
  h.translation_step = options.translation_step > 0 ? options.translation_step
                       : model.spacing > 0          ? model.spacing / 64.0f
                                                    : model.patch_radius / 256.0f;
  h.position_bits = options.position_bits;
  if (options.position_step > 0) {
    h.position_bits = position_bits_for_step(static_cast<double>(model.patch_radius),
                                             static_cast<double>(options.position_step));
    h.patch_radius = std::max(model.patch_radius,
                              options.position_step * static_cast<float>(1u << (h.position_bits - 1)));
  }
  h.normal_bits = options.normal_bits;
  h.rotation_bits = options.rotation_bits;
  h.codewords_per_block = options.codewords_per_block;
  h.patches_per_block = options.patches_per_block;
  return h;
}

}  // namespace

StatusOr<ContainerStreamWriter> ContainerStreamWriter::open(const EncodedModel& model, const QuantOptions& options,
                                                            const std::filesystem::path* path, bool spill) {
  EncodedModel shared;  // the model-wide fields alone
  shared.patch_radius = model.patch_radius;
  shared.coverage_radius = model.coverage_radius;
  shared.spacing = model.spacing;
  shared.bounds = model.bounds;
  shared.has_colours = model.has_colours;
  SSPC_RETURN_IF_ERROR(validate(shared, options));
  auto impl = std::make_unique<Impl>();
  impl->options = options;
  impl->h = shared_header(model, options);
  impl->metadata = model.metadata;
  impl->bounds_empty = model.bounds.isEmpty();
  if (path != nullptr) {
    auto file = std::make_unique<FileSink>();
    SSPC_RETURN_IF_ERROR(file->open(*path));
    impl->sink = std::move(file);
    if (spill) {
      impl->spill = std::make_unique<CodebookSpill>();
      SSPC_RETURN_IF_ERROR(impl->spill->open(*path));
    }
  } else {
    impl->sink = std::make_unique<StringSink>();
  }
  // The header is written last, when its counts, radius and section table are known.
  SSPC_RETURN_IF_ERROR(impl->sink->append(std::string(kHeaderSize, '\0')));
  impl->codebook_section.offset = kHeaderSize;
  return ContainerStreamWriter(std::move(impl));
}

StatusOr<ContainerStreamWriter> ContainerStreamWriter::to_file(const EncodedModel& model, const QuantOptions& options,
                                                               const std::filesystem::path& path, bool spill) {
  return open(model, options, &path, spill);
}

StatusOr<ContainerStreamWriter> ContainerStreamWriter::to_memory(const EncodedModel& model,
                                                                 const QuantOptions& options) {
  return open(model, options, nullptr, false);
}

Status ContainerStreamWriter::add_tile(EncodedModel tile) {
  Impl& m = *impl_;
  if (m.finished) return internal_error("ContainerStreamWriter::add_tile after finish");
  const ContainerHeader& h = m.h;
  tile.patch_radius = h.patch_radius;
  tile.coverage_radius = h.coverage_radius;
  tile.spacing = h.spacing;
  tile.has_normals = h.has_normals();
  tile.has_colours = h.has_colours();
  tile.bounds = m.bounds_empty ? Box3f() : Box3f(h.bounds_min, h.bounds_max);
  SSPC_RETURN_IF_ERROR(validate(tile, m.options));
  if (m.codewords + tile.codebook.size() > std::numeric_limits<std::uint32_t>::max() ||
      m.patches.size() + tile.patches.size() > std::numeric_limits<std::uint32_t>::max()) {
    return invalid_argument("more than 2^32 − 1 code words or patches");
  }
  // The code words moved into the frames a reader decodes and merged; trimmed at finish(), when
  // the patches of every tile that may neighbour this one's are known.
  express_in_decoded_frames(tile, h);
  if (!m.options.keep_duplicates) merge_duplicate_cells(tile, h);
  parallel_for(0, tile.codebook.size(), 16, [&](std::size_t c) { choose_codeword_heights(tile.codebook[c], h); });
  // A tile written early was trimmed without this one's patches: none may lie within its reach
  // (else expect_tiles() was given a wrong box and the trim would differ from finish()'s).
  for (std::size_t t = 0; t < m.written_reach.size(); ++t) {
    for (const PatchInstance& p : tile.patches) {
      if (m.written_reach[t].contains(p.region_centre())) {
        return internal_error("tile " + std::to_string(m.tiles()) + " has a patch within reach of tile " +
                              std::to_string(t) + ", written before it: the expected tile boxes are wrong");
      }
    }
  }
  const auto offset = static_cast<std::uint32_t>(m.codewords);
  for (PatchInstance p : tile.patches) {
    p.codeword += offset;
    m.patches.push_back(p);
  }
  m.tile_first_patch.push_back(m.patches.size());
  m.codewords += tile.codebook.size();
  m.tile_first_codeword.push_back(m.codewords);
  if (m.spill) {
    SSPC_RETURN_IF_ERROR(m.spill->put(tile.codebook));
  } else {
    m.held.push_back(std::move(tile.codebook));
  }
  return m.write_ready_tiles();
}

void ContainerStreamWriter::expect_tiles(std::vector<Box3f> boxes) { impl_->expected = std::move(boxes); }

// Where the patches that may claim tile t's code-word points lie: a neighbour of a patch lies
// within 2ρ ≤ 2·patch_radius (FORMAT.md, "Decoding: regions") of its decoded centre, which is
// within a translation step of the stored one. Empty for a tile without patches.
Box3f ContainerStreamWriter::Impl::reach_of(std::size_t t) const {
  Box3f box;
  for (std::size_t k = tile_first_patch[t]; k < tile_first_patch[t + 1]; ++k) box.extend(patches[k].region_centre());
  if (box.isEmpty()) return box;
  const float reach = 2.01f * h.patch_radius + 2 * h.translation_step;
  return Box3f(box.min() - Vec3f::Constant(reach), box.max() + Vec3f::Constant(reach));
}

// With the tiles' boxes known, every tile whose reach no tile still to come can enter is trimmed
// and written now, in order, so that finish() is left the last few: on a Dask client this work
// overlaps the workers' (autzen in 16 tiles: 8.1 s of finish() moved into the tiles' time). The
// bytes are finish()'s: a tile still to come has its patch centres in its box, moved by at most
// a translation step by express_in_decoded_frames.
Status ContainerStreamWriter::Impl::write_ready_tiles() {
  if (expected.size() < tiles()) return Status();
  const Vec3f slack = Vec3f::Constant(2 * h.translation_step);
  while (written_tiles < tiles()) {
    const Box3f reach = reach_of(written_tiles);
    for (std::size_t j = tiles(); j < expected.size(); ++j) {
      const Box3f& b = expected[j];
      if (!reach.isEmpty() && !b.isEmpty() && Box3f(b.min() - slack, b.max() + slack).intersects(reach)) {
        return Status();
      }
    }
    written_reach.push_back(reach);
    SSPC_RETURN_IF_ERROR(write_tile_codebook(written_tiles++));
  }
  return Status();
}

// Tile t's code book trimmed (against its own patches and every other tile's within reach:
// exactly the whole model's trim) and its whole blocks written.
Status ContainerStreamWriter::Impl::write_tile_codebook(std::size_t t) {
  std::vector<Codeword> codebook;
  if (spill) {
    SSPC_ASSIGN_OR_RETURN(codebook, spill->get(t));
  } else {
    codebook = std::move(held[t]);
  }
  if (options.trim_unclaimed) {
    EncodedModel tile;
    tile.codebook = std::move(codebook);
    const std::size_t first = tile_first_patch[t], last = tile_first_patch[t + 1];
    const auto offset = static_cast<std::uint32_t>(tile_first_codeword[t]);
    for (std::size_t k = first; k < last; ++k) {
      PatchInstance p = patches[k];
      p.codeword -= offset;
      tile.patches.push_back(p);
    }
    const Box3f grown = reach_of(t);
    std::vector<IndexedPatch> others;
    if (!grown.isEmpty()) {
      for (std::size_t k = 0; k < patches.size(); ++k) {
        if ((k < first || k >= last) && grown.contains(patches[k].region_centre())) {
          others.push_back({static_cast<std::uint32_t>(k), patches[k]});
        }
      }
    }
    TrimStats trim;
    tile = trim_unclaimed_points(tile, h, &trim, others, static_cast<std::uint32_t>(first));
    stats.untrimmed_codeword_points += trim.points_before;
    codebook = std::move(tile.codebook);
  }
  for (Codeword& w : codebook) pending.push_back(std::move(w));
  return write_codebook_blocks(false);
}

// Writes the pending code words' whole blocks (and, when `last`, the partial one), each encoded,
// decoded again for the radius a reader computes, and compressed, in parallel.
Status ContainerStreamWriter::Impl::write_codebook_blocks(bool last) {
  const std::size_t per = h.codewords_per_block;
  const std::size_t blocks = last ? static_cast<std::size_t>(block_count(pending.size(), h.codewords_per_block))
                                  : pending.size() / per;
  if (blocks == 0) return Status();
  const std::uint64_t first_index = blocked;
  std::vector<BuiltBlock> built(blocks);
  parallel_for(0, blocks, 1, [&](std::size_t b) {
    BuiltBlock& block = built[b];
    const std::size_t first = b * per;
    const std::size_t count = std::min(per, pending.size() - first);
    const std::span<const Codeword> words(pending.data() + first, count);
    const std::string raw = encode_codeword_block(words, h);
    block.entry.first = static_cast<std::uint32_t>(first_index + first);
    block.entry.count = static_cast<std::uint32_t>(count);
    std::size_t points = 0;
    for (const Codeword& w : words) points += w.points.size();
    if (points > std::numeric_limits<std::uint32_t>::max()) {
      block.status = invalid_argument("a code-book block holds more than 2^32 − 1 points");
      return;
    }
    block.entry.point_count = static_cast<std::uint32_t>(points);
    DecodedCodewords decoded;
    block.status = decode_codeword_block(as_bytes(raw), block.entry, h, decoded);
    if (!block.status.ok()) return;
    for (float r : decoded.radius) block.radius = std::max(block.radius, r);
    block.status = compress_block(raw, options.zstd_level, block);
  });
  for (BuiltBlock& b : built) {
    SSPC_RETURN_IF_ERROR(b.status);
    h.codeword_radius = std::max(h.codeword_radius, b.radius);
    h.codeword_point_count += b.entry.point_count;
    stats.codebook_raw_bytes += b.entry.raw_size;
    b.entry.offset = codebook_section.size;
    codebook_seek += encode_seek_entry(b.entry, false);
    SSPC_RETURN_IF_ERROR(codebook_section.append(*sink, b.stored));
    ++stats.codebook_blocks;
    blocked += b.entry.count;
  }
  pending.erase(pending.begin(), pending.begin() + static_cast<std::ptrdiff_t>(std::min(pending.size(), blocks * per)));
  return Status();
}

// The attributes part (FORMAT.md, "Attributes"): the geometry decoded tile by tile as a reader
// decodes it, each decoded point given the values of its nearest point of the tile's source, and
// coded patch by patch; blocks are coded (in parallel) as soon as every patch of theirs is.
StatusOr<std::string> ContainerStreamWriter::Impl::attribute_part(CompressedModel& geometry,
                                                                  const TileSource& source) {
  AttributeParams params = options.attributes;
  params.unary_lengths = options.format_version >= 7;
  const std::size_t per = h.patches_per_block;
  const auto blocks = static_cast<std::size_t>(block_count(h.patch_count, h.patches_per_block));
  std::vector<std::string> block_bytes(blocks);
  std::vector<std::array<std::uint64_t, kChannelCount>> block_channel_bytes(blocks);
  // Each patch's points and values from its tile's decode until its block is coded: a tile's
  // patches and a block's at a time, not the model's (a PointCloud is some 500 bytes empty).
  std::map<std::size_t, PointCloud> values;
  std::size_t coded_blocks = 0;
  const PointCloud empty;  // a patch that decodes to no point
  const float reach = h.codeword_radius + h.translation_step;
  const std::size_t tiles = tile_first_patch.size() - 1;
  for (std::size_t t = 0; t < tiles; ++t) {
    const std::size_t first = tile_first_patch[t], last = tile_first_patch[t + 1];
    if (first < last) {
      std::shared_ptr<const PointCloud> src;
      SSPC_RETURN_IF_ERROR(source(t, src));
      if (src == nullptr || (channels_present(*src) & params.channels) != params.channels) {
        return invalid_argument("attributes asked for that the source does not have");
      }
      Box3f box;
      for (std::size_t k = first; k < last; ++k) box.extend(patches[k].region_centre());
      box = Box3f(box.min() - Vec3f::Constant(reach), box.max() + Vec3f::Constant(reach));
      std::vector<std::uint32_t> patch_of;
      DecodeOptions decode;
      decode.patch_of = &patch_of;
      SSPC_ASSIGN_OR_RETURN(PointCloud decoded, geometry.decode_box(box, decode));
      const KdTree3 tree(src->positions);
      std::vector<std::uint32_t> nearest(decoded.size(), std::numeric_limits<std::uint32_t>::max());
      parallel_for(0, decoded.size(), 4096, [&](std::size_t i) {
        if (patch_of[i] < first || patch_of[i] >= last) return;
        float d2 = 0;
        nearest[i] = static_cast<std::uint32_t>(tree.nearest(decoded.positions[i], &d2));
      });
      for (std::size_t i = 0; i < decoded.size(); ++i) {
        const std::uint32_t s = nearest[i];
        if (s == std::numeric_limits<std::uint32_t>::max()) continue;
        PointCloud& v = values[patch_of[i]];
        v.positions.push_back(decoded.positions[i]);
        if (params.channels & kChannelColour) v.colours.push_back(src->colours[s]);
        if (params.channels & kChannelIntensity) v.las.intensity.push_back(src->las.intensity[s]);
        if (params.channels & kChannelClassification) v.las.classification.push_back(src->las.classification[s]);
        if (params.channels & kChannelReturns) {
          v.las.return_number.push_back(src->las.return_number[s]);
          v.las.number_of_returns.push_back(src->las.number_of_returns[s]);
        }
      }
    }
    const std::size_t ready = t + 1 == tiles ? blocks : last / per;
    parallel_for(coded_blocks, ready, 1, [&](std::size_t b) {
      const std::size_t begin = b * per;
      const std::size_t end = std::min<std::size_t>(begin + per, h.patch_count);
      std::string sizes, streams;
      AttributeReferences refs;
      for (std::size_t k = begin; k < end; ++k) {
        const auto it = values.find(k);
        const PointCloud& v = it != values.end() ? it->second : empty;
        refs.find(v.positions);
        for (std::size_t bit = 0; bit < kChannelCount; ++bit) {
          const auto channel = static_cast<std::uint8_t>(1u << bit);
          if ((params.channels & channel) == 0) continue;
          const std::string stream = encode_attribute_stream(channel, params, refs, v);
          append_varint(sizes, stream.size());
          streams += stream;
          block_channel_bytes[b][bit] += stream.size();
        }
      }
      block_bytes[b] = sizes + streams;
    });
    // Coded: dropped (serially, after the parallel loop that read them).
    values.erase(values.begin(), values.lower_bound(std::max(coded_blocks, ready) * per));
    coded_blocks = std::max(coded_blocks, ready);
  }

  std::string table;
  put_u8(table, params.channels);
  put_u8(table, static_cast<std::uint8_t>((params.channels & kChannelColour) ? params.colour_step : 0));
  put_u16(table, static_cast<std::uint16_t>((params.channels & kChannelIntensity) ? params.intensity_step : 0));
  table.append(12, '\0');
  std::uint64_t offset = 0;
  for (const std::string& block : block_bytes) {
    put_u64(table, offset);
    put_u32(table, static_cast<std::uint32_t>(block.size()));
    put_u32(table, crc32_of(as_bytes(block)));
    offset += block.size();
  }
  const std::uint64_t payload = table.size() + offset;
  if (payload > std::numeric_limits<std::uint32_t>::max()) {
    return resource_exhausted("the attributes part exceeds 4 GiB");
  }
  std::string out;
  out.reserve(8 + payload);
  put_u32(out, static_cast<std::uint32_t>(payload));
  put_u32(out, crc32_of(as_bytes(table)));
  out += table;
  for (const std::string& block : block_bytes) out += block;
  stats.attribute_bytes = out.size();
  for (const auto& c : block_channel_bytes) {
    for (std::size_t bit = 0; bit < kChannelCount; ++bit) stats.channel_bytes[bit] += c[bit];
  }
  return out;
}

// Samples kResampleSamples patch centres from up to four tiles (their sources read once each)
// and measures the candidates 0..max_m there; `rule` stands where a tile has no source.
StatusOr<int> ContainerStreamWriter::Impl::measured_resample(const CompressedModel& geometry,
                                                              const TileSource& source, int rule, int max_m) {
  std::vector<std::size_t> with_patches;
  for (std::size_t t = 0; t + 1 < tile_first_patch.size(); ++t) {
    if (tile_first_patch[t] < tile_first_patch[t + 1]) with_patches.push_back(t);
  }
  const std::size_t tiles = std::min<std::size_t>(with_patches.size(), 4);
  if (tiles == 0) return rule;
  // A sphere of some 800 source points, or the region a centre covers where that is smaller.
  const float radius = h.spacing > 0 ? std::min(h.coverage_radius, 16 * h.spacing) : h.coverage_radius;
  if (!(radius > 0)) return rule;
  ResampleMeter meter(geometry, radius, max_m);
  for (std::size_t i = 0; i < tiles; ++i) {
    const std::size_t t = with_patches[(2 * i + 1) * with_patches.size() / (2 * tiles)];
    std::shared_ptr<const PointCloud> cloud;
    SSPC_RETURN_IF_ERROR(source(t, cloud));
    if (cloud == nullptr) return rule;
    const std::size_t first = tile_first_patch[t], n = tile_first_patch[t + 1] - first;
    const std::size_t count = std::min(n, kResampleSamples / tiles);
    std::vector<Vec3f> centres;
    for (std::size_t j = 0; j < count; ++j) centres.push_back(patches[first + (2 * j + 1) * n / (2 * count)].region_centre());
    SSPC_RETURN_IF_ERROR(meter.add(*cloud, centres));
  }
  return meter.chosen();
}

StatusOr<ContainerStats> ContainerStreamWriter::finish(const TileSource& attribute_source) {
  Impl& m = *impl_;
  if (m.finished) return internal_error("ContainerStreamWriter::finish twice");
  m.finished = true;
  ContainerHeader& h = m.h;
  while (m.written_tiles < m.tiles()) SSPC_RETURN_IF_ERROR(m.write_tile_codebook(m.written_tiles++));
  m.spill.reset();
  SSPC_RETURN_IF_ERROR(m.write_codebook_blocks(true));
  h.codeword_count = static_cast<std::uint32_t>(m.codewords);
  h.patch_count = static_cast<std::uint32_t>(m.patches.size());

  // Patch blocks.
  const auto p_blocks = static_cast<std::size_t>(block_count(h.patch_count, h.patches_per_block));
  std::vector<BuiltBlock> patches(p_blocks);
  parallel_for(0, p_blocks, 1, [&](std::size_t b) {
    BuiltBlock& block = patches[b];
    const std::size_t first = b * h.patches_per_block;
    const std::size_t count = std::min<std::size_t>(h.patches_per_block, h.patch_count - first);
    auto raw = encode_patch_block({m.patches.data() + first, count}, h);
    if (!raw.ok()) {
      block.status = raw.status();
      return;
    }
    block.entry.first = static_cast<std::uint32_t>(first);
    block.entry.count = static_cast<std::uint32_t>(count);
    DecodedPatches decoded;
    block.status = decode_patch_block(as_bytes(*raw), block.entry, h, false, decoded);
    if (!block.status.ok()) return;
    Box3f centres;
    for (const Vec3f& c : decoded.centre) centres.extend(c);
    const Vec3f r = Vec3f::Constant(h.patch_radius);
    block.entry.box = Box3f(centres.min() - r, centres.max() + r);
    block.status = compress_block(*raw, m.options.zstd_level, block);
  });
  for (const BuiltBlock& b : patches) SSPC_RETURN_IF_ERROR(b.status);
  // The resample byte: as asked; else by the count rule, then, where the source is at hand
  // and the grid is coarser than the spacing, by measurement (resample_choice.hpp) once the
  // geometry can be decoded.
  bool measure = false;
  int max_m = 0;
  if (m.options.format_version < 4) {
    h.resample = 0;
  } else if (m.options.resample >= 0) {
    h.resample = m.options.resample;
  } else {
    const double decoded = static_cast<double>(h.codeword_point_count) * static_cast<double>(h.patch_count) /
                           static_cast<double>(std::max<std::uint32_t>(1, h.codeword_count));
    const double step = static_cast<double>(position_step(h.patch_radius, h.position_bits));
    const double step_in_spacings = step / static_cast<double>(h.spacing);
    h.resample = resample_for(h.source_points, decoded, step_in_spacings);
    measure = static_cast<bool>(attribute_source) && step_in_spacings > kMeasuredResampleStep;
    max_m = std::max(h.resample, 1);
  }

  // Sections 2–4 follow the code-book blocks.
  SectionWriter sections[kSectionCount];
  sections[0] = m.codebook_section;
  sections[1].offset = sections[0].offset + sections[0].size;
  SSPC_RETURN_IF_ERROR(sections[1].append(*m.sink, m.codebook_seek));
  sections[2].offset = sections[1].offset + sections[1].size;
  std::string patch_seek;
  for (BuiltBlock& b : patches) {
    b.entry.offset = sections[2].size;
    m.stats.patch_raw_bytes += b.entry.raw_size;
    patch_seek += encode_seek_entry(b.entry, true);
    SSPC_RETURN_IF_ERROR(sections[2].append(*m.sink, b.stored));
  }
  patches.clear();
  sections[3].offset = sections[2].offset + sections[2].size;
  SSPC_RETURN_IF_ERROR(sections[3].append(*m.sink, patch_seek));
  for (std::size_t i = 0; i < kSectionCount; ++i) {
    SectionEntry& s = h.sections[i];
    s.kind = static_cast<SectionKind>(i + 1);
    s.offset = sections[i].offset;
    s.size = sections[i].size;
    s.crc32 = sections[i].crc;
  }

  const bool attributes = m.options.attributes.channels != 0;
  if (attributes || measure) {
    // The geometry alone is a file a reader decodes: the attributes are coded on what it
    // decodes, and the resampling measured on it.
    ContainerHeader geometry = h;
    geometry.flags = static_cast<std::uint16_t>(h.flags & ~(kFlagMetadata | kFlagAttributes));
    geometry.resample = 0;  // attributes are coded on the stored points; new points inherit them
    SSPC_RETURN_IF_ERROR(m.sink->write_at(0, encode_header(geometry)));
    if (attributes && !attribute_source) return invalid_argument("attributes asked for without a source");
    std::string part;
    {
      SSPC_ASSIGN_OR_RETURN(CompressedModel model, m.sink->open_model());
      if (measure) {
        SSPC_ASSIGN_OR_RETURN(h.resample, m.measured_resample(model, attribute_source, h.resample, max_m));
      }
      if (attributes) {
        SSPC_ASSIGN_OR_RETURN(part, m.attribute_part(model, attribute_source));
      }
    }
    SSPC_RETURN_IF_ERROR(m.sink->append(part));
  }
  if (h.has_metadata()) SSPC_RETURN_IF_ERROR(m.sink->append(encode_metadata(m.metadata)));
  SSPC_RETURN_IF_ERROR(m.sink->write_at(0, encode_header(h)));
  ContainerStats& stats = m.stats;
  stats.file_bytes = m.sink->size();
  stats.codeword_points = h.codeword_point_count;
  stats.resample = h.resample;
  stats.header_bytes = kHeaderSize;
  stats.codebook_bytes = sections[0].size;
  stats.codebook_seek_bytes = sections[1].size;
  stats.patch_bytes = sections[2].size;
  stats.patch_seek_bytes = sections[3].size;
  stats.patch_blocks = static_cast<std::uint32_t>(p_blocks);
  SSPC_RETURN_IF_ERROR(m.sink->commit());
  return stats;
}

std::string ContainerStreamWriter::take_bytes() { return impl_->sink->take(); }

namespace {

// encode_container's and write_container's check beyond what the writer validates (the options
// when it opens, the model when it is added as the one tile): the one source of attributes is
// given and has them.
Status check_attribute_source(const QuantOptions& o) {
  if (o.attributes.channels != 0 &&
      (o.attribute_source == nullptr || (channels_present(*o.attribute_source) & o.attributes.channels) != o.attributes.channels)) {
    return invalid_argument("attributes asked for that the source does not have");
  }
  return Status();
}

}  // namespace

int resample_for(std::uint64_t source_points, double decoded_points, double step_in_spacings) {
  const double ratio = static_cast<double>(source_points) / std::max(decoded_points, 1.0);
  if (!(ratio >= 1.5) || !(step_in_spacings > 1)) return 0;
  return std::min(kMaxResample, static_cast<int>(std::ceil(std::sqrt(ratio))));
}

StatusOr<std::string> encode_container(const EncodedModel& model, const QuantOptions& options, ContainerStats* stats) {
  SSPC_RETURN_IF_ERROR(check_attribute_source(options));
  SSPC_ASSIGN_OR_RETURN(ContainerStreamWriter writer, ContainerStreamWriter::to_memory(model, options));
  SSPC_RETURN_IF_ERROR(writer.add_tile(model));
  const std::shared_ptr<const PointCloud> source(options.attribute_source, [](const PointCloud*) {});
  SSPC_ASSIGN_OR_RETURN(const ContainerStats written,
                        writer.finish([&](std::size_t, std::shared_ptr<const PointCloud>& out) {
                          out = source;
                          return Status();
                        }));
  if (stats != nullptr) *stats = written;
  return writer.take_bytes();
}

StatusOr<ContainerStats> write_container(EncodedModel model, const QuantOptions& options,
                                         const std::filesystem::path& path) {
  SSPC_RETURN_IF_ERROR(check_attribute_source(options));
  SSPC_ASSIGN_OR_RETURN(ContainerStreamWriter writer, ContainerStreamWriter::to_file(model, options, path));
  SSPC_RETURN_IF_ERROR(writer.add_tile(std::move(model)));
  const std::shared_ptr<const PointCloud> source(options.attribute_source, [](const PointCloud*) {});
  return writer.finish([&](std::size_t, std::shared_ptr<const PointCloud>& out) {
    out = source;
    return Status();
  });
}

}  // namespace sspc::codec
