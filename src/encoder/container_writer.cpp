// The .sspc writer (docs/FORMAT.md). Each block is encoded, decoded again (so that what the
// header and seek tables promise, the code-word radius and the block boxes, is computed exactly
// as a reader will compute it) and compressed on its own, in parallel.
#include "encoder/container_writer.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <utility>
#include <vector>

#include <zstd.h>

#include "core/atomic_file.hpp"
#include "core/parallel.hpp"
#include "core/varint.hpp"
#include "encoder/codeword_trim.hpp"
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
    return invalid_argument("the writer writes format versions 2 and 3, not " + std::to_string(o.format_version));
  }
  if (o.patches_per_block == 0 || o.codewords_per_block == 0) {
    return invalid_argument("patches_per_block and codewords_per_block must be at least 1");
  }
  if (const AttributeParams& a = o.attributes; a.channels != 0) {
    if ((a.channels & ~kKnownChannels) != 0 || o.attribute_source == nullptr ||
        (channels_present(*o.attribute_source) & a.channels) != a.channels) {
      return invalid_argument("attributes asked for that the source does not have");
    }
    if (o.format_version < 3 || model.has_colours) {
      return invalid_argument("per-patch attributes need format version 3 and no code-word colours");
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
  put_u8(out, 0);
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

// The attributes part (FORMAT.md, "Attributes") for the model whose geometry `geometry` holds:
// decodes it as a reader will, gives each decoded point the values of its nearest source point,
// and codes them patch by patch.
StatusOr<std::string> encode_attribute_part(std::string geometry, const ContainerHeader& h,
                                            const QuantOptions& options, ContainerStats* stats) {
  const AttributeParams& params = options.attributes;
  const PointCloud& source = *options.attribute_source;
  SSPC_ASSIGN_OR_RETURN(const CompressedModel model, CompressedModel::from_bytes(std::move(geometry)));
  std::vector<std::uint32_t> patch_of;
  DecodeOptions decode;
  decode.patch_of = &patch_of;
  SSPC_ASSIGN_OR_RETURN(PointCloud decoded, model.decode_all(decode));
  // Each patch's points are contiguous and in patch order.
  std::vector<std::size_t> begin(h.patch_count + 1, decoded.size());
  for (std::size_t i = decoded.size(); i-- > 0;) begin[patch_of[i]] = i;
  for (std::size_t k = h.patch_count; k-- > 0;) begin[k] = std::min(begin[k], begin[k + 1]);

  const KdTree3 tree(source.positions);
  std::vector<std::uint32_t> nearest(decoded.size());
  parallel_for(0, decoded.size(), 4096, [&](std::size_t i) {
    float d2 = 0;
    nearest[i] = static_cast<std::uint32_t>(tree.nearest(decoded.positions[i], &d2));
  });

  const auto blocks = static_cast<std::size_t>(block_count(h.patch_count, h.patches_per_block));
  std::vector<std::string> block_bytes(blocks);
  std::vector<std::array<std::uint64_t, kChannelCount>> block_channel_bytes(blocks);
  parallel_for(0, blocks, 1, [&](std::size_t b) {
    const std::size_t first = b * h.patches_per_block;
    const std::size_t last = std::min<std::size_t>(first + h.patches_per_block, h.patch_count);
    std::string sizes, streams;
    PointCloud values;
    AttributeReferences refs;
    for (std::size_t k = first; k < last; ++k) {
      values = PointCloud();
      values.positions.assign(decoded.positions.begin() + static_cast<std::ptrdiff_t>(begin[k]),
                              decoded.positions.begin() + static_cast<std::ptrdiff_t>(begin[k + 1]));
      for (std::size_t i = begin[k]; i < begin[k + 1]; ++i) {
        const std::uint32_t s = nearest[i];
        if (params.channels & kChannelColour) values.colours.push_back(source.colours[s]);
        if (params.channels & kChannelIntensity) values.las.intensity.push_back(source.las.intensity[s]);
        if (params.channels & kChannelClassification) {
          values.las.classification.push_back(source.las.classification[s]);
        }
        if (params.channels & kChannelReturns) {
          values.las.return_number.push_back(source.las.return_number[s]);
          values.las.number_of_returns.push_back(source.las.number_of_returns[s]);
        }
      }
      refs.find(values.positions);
      for (std::size_t bit = 0; bit < kChannelCount; ++bit) {
        const auto channel = static_cast<std::uint8_t>(1u << bit);
        if ((params.channels & channel) == 0) continue;
        const std::string stream = encode_attribute_stream(channel, params, refs, values);
        append_varint(sizes, stream.size());
        streams += stream;
        block_channel_bytes[b][bit] += stream.size();
      }
    }
    block_bytes[b] = sizes + streams;
  });

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
  if (stats != nullptr) {
    stats->attribute_bytes = out.size();
    for (const auto& c : block_channel_bytes) {
      for (std::size_t bit = 0; bit < kChannelCount; ++bit) stats->channel_bytes[bit] += c[bit];
    }
  }
  return out;
}

}  // namespace

StatusOr<std::string> encode_container(const EncodedModel& source, const QuantOptions& options,
                                       ContainerStats* stats) {
  SSPC_RETURN_IF_ERROR(validate(source, options));

  ContainerHeader h;
  h.version = static_cast<std::uint16_t>(options.format_version);
  const bool metadata = source.metadata.present();
  const bool duplicates_flag = options.keep_duplicates && h.version >= 3;
  h.flags = static_cast<std::uint16_t>((source.has_normals ? kFlagNormals : 0) |
                                       (source.has_colours ? kFlagColours : 0) |
                                       (metadata ? kFlagMetadata : 0) |
                                       (duplicates_flag ? kFlagDuplicates : 0) |
                                       (options.attributes.channels != 0 ? kFlagAttributes : 0));
  h.patch_radius = source.patch_radius;
  h.coverage_radius = source.coverage_radius;
  h.spacing = source.spacing;
  h.source_points = source.source_points;
  if (!source.bounds.isEmpty()) {
    h.bounds_min = source.bounds.min();
    h.bounds_max = source.bounds.max();
  }
  h.translation_step = options.translation_step > 0 ? options.translation_step
                       : source.spacing > 0          ? source.spacing / 64.0f
                                                    : source.patch_radius / 256.0f;
  h.position_bits = options.position_bits;
  if (options.position_step > 0) {
    h.position_bits = position_bits_for_step(source.patch_radius, options.position_step);
    h.patch_radius = std::max(source.patch_radius,
                              options.position_step * static_cast<float>(1u << (h.position_bits - 1)));
  }
  h.normal_bits = options.normal_bits;
  h.rotation_bits = options.rotation_bits;
  h.codeword_count = static_cast<std::uint32_t>(source.codebook.size());
  h.patch_count = static_cast<std::uint32_t>(source.patches.size());
  h.codewords_per_block = options.codewords_per_block;
  h.patches_per_block = options.patches_per_block;
  // One working copy of the code book, moved into the decoded frames and merged in place.
  EncodedModel working = source;
  express_in_decoded_frames(working, h);
  if (!options.keep_duplicates) merge_duplicate_cells(working, h);
  EncodedModel trimmed;
  if (options.trim_unclaimed) {
    TrimStats trim;
    trimmed = trim_unclaimed_points(working, h, &trim);
    if (stats != nullptr) stats->untrimmed_codeword_points = trim.points_before;
  }
  const EncodedModel& model = options.trim_unclaimed ? trimmed : working;
  for (const Codeword& w : model.codebook) h.codeword_point_count += w.points.size();

  // Code-book blocks.
  const auto cw_blocks =
      static_cast<std::size_t>(block_count(h.codeword_count, h.codewords_per_block));
  std::vector<BuiltBlock> codebook(cw_blocks);
  parallel_for(0, cw_blocks, 1, [&](std::size_t b) {
    BuiltBlock& block = codebook[b];
    const std::size_t first = b * h.codewords_per_block;
    const std::size_t count =
        std::min<std::size_t>(h.codewords_per_block, h.codeword_count - first);
    const std::span<const Codeword> words(model.codebook.data() + first, count);
    const std::string raw = encode_codeword_block(words, h);
    block.entry.first = static_cast<std::uint32_t>(first);
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
  for (const BuiltBlock& b : codebook) {
    SSPC_RETURN_IF_ERROR(b.status);
    h.codeword_radius = std::max(h.codeword_radius, b.radius);
  }

  // Patch blocks.
  const auto p_blocks = static_cast<std::size_t>(block_count(h.patch_count, h.patches_per_block));
  std::vector<BuiltBlock> patches(p_blocks);
  parallel_for(0, p_blocks, 1, [&](std::size_t b) {
    BuiltBlock& block = patches[b];
    const std::size_t first = b * h.patches_per_block;
    const std::size_t count = std::min<std::size_t>(h.patches_per_block, h.patch_count - first);
    auto raw = encode_patch_block({model.patches.data() + first, count}, h);
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
    block.status = compress_block(*raw, options.zstd_level, block);
  });
  for (const BuiltBlock& b : patches) SSPC_RETURN_IF_ERROR(b.status);

  // Sections.
  std::string section[kSectionCount];
  std::uint64_t raw_totals[2] = {0, 0};
  // One seek-table writer for both kinds (docs/FORMAT.md, "Blocks and seek tables"): a code-book
  // entry carries its point count, a patch entry 0 there and its blocks' bounding box.
  const auto append_blocks = [](const std::vector<BuiltBlock>& blocks, bool patch_blocks, std::string& data,
                                std::string& table, std::uint64_t& raw_total) {
    for (const BuiltBlock& b : blocks) {
      BlockEntry e = b.entry;
      e.offset = data.size();
      data += b.stored;
      raw_total += e.raw_size;
      put_u64(table, e.offset);
      put_u32(table, e.stored_size);
      put_u32(table, e.raw_size);
      put_u32(table, e.crc32);
      put_u32(table, e.first);
      put_u32(table, e.count);
      put_u32(table, patch_blocks ? 0 : e.point_count);
      if (patch_blocks) {
        put_vec3(table, e.box.min());
        put_vec3(table, e.box.max());
      }
    }
  };
  append_blocks(codebook, false, section[0], section[1], raw_totals[0]);
  append_blocks(patches, true, section[2], section[3], raw_totals[1]);
  std::uint64_t offset = kHeaderSize;
  for (std::size_t i = 0; i < kSectionCount; ++i) {
    SectionEntry& s = h.sections[i];
    s.kind = static_cast<SectionKind>(i + 1);
    s.offset = offset;
    s.size = section[i].size();
    s.crc32 = crc32_of(as_bytes(section[i]));
    offset += s.size;
  }
  std::string attribute_part;
  if (options.attributes.channels != 0) {
    // The geometry alone, as a file a reader can decode: the attributes are coded on what it
    // decodes.
    ContainerHeader geometry = h;
    geometry.flags = static_cast<std::uint16_t>(h.flags & ~(kFlagMetadata | kFlagAttributes));
    std::string bytes = encode_header(geometry);
    for (const std::string& s : section) bytes += s;
    SSPC_ASSIGN_OR_RETURN(attribute_part, encode_attribute_part(std::move(bytes), h, options, stats));
  }
  std::string out = encode_header(h);
  const std::string metadata_part = metadata ? encode_metadata(source.metadata) : std::string();
  out.reserve(offset + attribute_part.size() + metadata_part.size());
  for (const std::string& s : section) out += s;
  out += attribute_part;
  out += metadata_part;

  if (stats != nullptr) {
    stats->file_bytes = out.size();
    stats->codeword_points = h.codeword_point_count;
    stats->header_bytes = kHeaderSize;
    stats->codebook_bytes = section[0].size();
    stats->codebook_seek_bytes = section[1].size();
    stats->patch_bytes = section[2].size();
    stats->patch_seek_bytes = section[3].size();
    stats->codebook_raw_bytes = raw_totals[0];
    stats->patch_raw_bytes = raw_totals[1];
    stats->codebook_blocks = static_cast<std::uint32_t>(cw_blocks);
    stats->patch_blocks = static_cast<std::uint32_t>(p_blocks);
  }
  return out;
}

StatusOr<ContainerStats> write_container(const EncodedModel& model, const QuantOptions& options,
                                         const std::filesystem::path& path) {
  ContainerStats stats;
  SSPC_ASSIGN_OR_RETURN(std::string bytes, encode_container(model, options, &stats));
  SSPC_RETURN_IF_ERROR(write_file_atomically(path, as_bytes(bytes)));
  return stats;
}

}  // namespace sspc::codec
