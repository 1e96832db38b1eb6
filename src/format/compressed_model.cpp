// sspc::CompressedModel: random-access decoding of an .sspc file (docs/FORMAT.md, "Decoding:
// regions").
//
// Blocks come from one of two sources: a shared LRU cache for random queries (decode_patch,
// decode_box, patch, codeword: what a renderer calls from many threads), or all blocks decoded
// up front for decode_all. Both feed the same per-patch routine, decode_one(), which is why the
// three decodes agree bit for bit.
#include "sspc/compressed_model.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include "core/check.hpp"
#include "core/mapped_file.hpp"
#include "core/parallel.hpp"
#include "format/block_cache.hpp"
#include "format/attribute_coder.hpp"
#include "format/block_index.hpp"
#include "format/container_reader.hpp"
#include "format/quantise.hpp"
#include "format/region_decoder.hpp"

namespace sspc {

using codec::DecodedCodewords;
using codec::DecodedPatches;

namespace {

// Relative slack for the spatial searches: far above float rounding (~6e-8), far below any
// distance that matters, so the searches return a superset of what the exact rules select.
constexpr float kSearchSlack = 1e-5f;

// The most points decode_chunks reserves room for in one block's part before decoding it (the
// part grows past it if it must): a block of 32 patches of 4096 points, resampled 4 × 4, is 2M.
constexpr std::size_t kMaxReservedPoints = std::size_t{1} << 22;

class BlockSource {
 public:
  virtual ~BlockSource() = default;
  virtual Status patches(std::size_t b, std::shared_ptr<const DecodedPatches>& out) = 0;
  virtual Status codewords(std::size_t b, std::shared_ptr<const DecodedCodewords>& out) = 0;
};

// The status of a read from the mapped file: if the file shrank under the mapping, the read saw
// zeros where the file was cut (core/mapped_file.hpp), and that, not the checksum or the count
// the zeros broke, is what the caller is told. A model built from bytes in memory has no
// mapping, and an empty MappedFile is always intact.
Status after_read(const MappedFile& mapped, Status read) {
  SSPC_RETURN_IF_ERROR(mapped.check_intact());
  return read;
}

class CachedSource final : public BlockSource {
 public:
  CachedSource(const codec::ContainerReader& reader, const MappedFile& mapped,
               codec::BlockCache<DecodedPatches>& patches,
               codec::BlockCache<DecodedCodewords>& codewords)
      : reader_(reader), mapped_(mapped), patch_cache_(patches), codeword_cache_(codewords) {}
  Status patches(std::size_t b, std::shared_ptr<const DecodedPatches>& out) override {
    out = patch_cache_.find(b);
    if (out) return Status();
    auto block = std::make_shared<DecodedPatches>();
    SSPC_RETURN_IF_ERROR(after_read(mapped_, reader_.read_patches(b, *block)));
    release(codec::SectionKind::kPatchBlocks, b);
    patch_cache_.insert(b, block, block->memory_bytes());
    out = std::move(block);
    return Status();
  }
  Status codewords(std::size_t b, std::shared_ptr<const DecodedCodewords>& out) override {
    out = codeword_cache_.find(b);
    if (out) return Status();
    auto block = std::make_shared<DecodedCodewords>();
    SSPC_RETURN_IF_ERROR(after_read(mapped_, reader_.read_codewords(b, *block)));
    release(codec::SectionKind::kCodebookBlocks, b);
    codeword_cache_.insert(b, block, block->memory_bytes());
    out = std::move(block);
    return Status();
  }

 private:
  // A decoded block's stored bytes go back to the kernel: the cache holds what they decode to,
  // and the file's pages would otherwise stay resident as they were read, the whole file in the
  // end (autzen's level-0 model, 21 MB, 2 bytes a point of the 8.45 its render grew by under a
  // 64 MiB budget). Decoded again, a block's pages are read again from the page cache.
  void release(codec::SectionKind kind, std::size_t b) const {
    const auto [begin, end] = reader_.block_bytes(kind, b);
    mapped_.release(begin, end);
  }

  const codec::ContainerReader& reader_;
  const MappedFile& mapped_;
  codec::BlockCache<DecodedPatches>& patch_cache_;
  codec::BlockCache<DecodedCodewords>& codeword_cache_;
};

}  // namespace

struct CompressedModel::Impl {
  MappedFile mapped;
  std::string owned;
  codec::ContainerReader reader;
  codec::BlockIndex index;
  float coordinate_scale = 0;  // largest |coordinate| of any block box: scales the search slack
  float position_step = 0;     // the code words' grid step, which resampling spreads points over
  // The cache budget split: patch blocks get an eighth (a patch block is small, autzen level 5:
  // 64 patches, 7.4 KB, and a query needs its neighbours' blocks as well as its own).
  static constexpr std::uint64_t patch_share(std::uint64_t bytes) { return bytes / 8; }
  mutable codec::BlockCache<DecodedPatches> patch_cache{patch_share(CompressedModel::kDefaultCacheBudget)};
  mutable codec::BlockCache<DecodedCodewords> codeword_cache{
      CompressedModel::kDefaultCacheBudget - patch_share(CompressedModel::kDefaultCacheBudget)};

  Status init(std::span<const std::byte> bytes, std::string name) {
    SSPC_ASSIGN_OR_RETURN(reader, codec::ContainerReader::open(bytes, std::move(name)));
    std::vector<Box3f> boxes;
    boxes.reserve(reader.patch_blocks().size());
    for (const codec::BlockEntry& e : reader.patch_blocks()) {
      boxes.push_back(e.box);
      coordinate_scale = std::max(
          {coordinate_scale, e.box.min().cwiseAbs().maxCoeff(), e.box.max().cwiseAbs().maxCoeff()});
    }
    index = codec::BlockIndex(boxes);
    position_step = codec::position_step(reader.header().patch_radius, reader.header().position_bits);
    return Status();
  }

  CachedSource cached() const { return CachedSource(reader, mapped, patch_cache, codeword_cache); }
  std::uint32_t patches_per_block() const { return reader.header().patches_per_block; }
  std::uint32_t codewords_per_block() const { return reader.header().codewords_per_block; }

  Status decode_one(BlockSource& src, std::size_t k, const DecodeOptions& options, const Box3f* clip,
                    std::vector<codec::NeighbourInstance>& neighbours, PointCloud& out) const;
};

namespace {

// Blocks decoded up front for a whole decode (all of them, or one chunk's: decode_chunks), and
// the model's cache for any other: a patch's neighbours may lie in a block of another chunk.
// Entries are filled before the parallel decode reads them and not changed while it runs.
class PreloadedSource final : public BlockSource {
 public:
  explicit PreloadedSource(CachedSource fallback) : fallback_(std::move(fallback)) {}
  std::vector<std::shared_ptr<const DecodedPatches>> patch_blocks;
  std::vector<std::shared_ptr<const DecodedCodewords>> codeword_blocks;

  Status patches(std::size_t b, std::shared_ptr<const DecodedPatches>& out) override {
    out = b < patch_blocks.size() ? patch_blocks[b] : nullptr;
    return out ? Status() : fallback_.patches(b, out);
  }
  Status codewords(std::size_t b, std::shared_ptr<const DecodedCodewords>& out) override {
    out = b < codeword_blocks.size() ? codeword_blocks[b] : nullptr;
    return out ? Status() : fallback_.codewords(b, out);
  }

 private:
  CachedSource fallback_;
};

// `src`'s points inside `box` (inclusive), with their attributes, appended to `dst`.
void append_inside(PointCloud& dst, const PointCloud& src, const Box3f& box) {
  auto keep = [&](const auto& from, auto& to) {
    if (from.empty()) return;
    for (std::size_t i = 0; i < src.positions.size(); ++i) {
      if (box.contains(src.positions[i])) to.push_back(from[i]);
    }
  };
  keep(src.positions, dst.positions);
  keep(src.normals, dst.normals);
  keep(src.colours, dst.colours);
  keep(src.las.intensity, dst.las.intensity);
  keep(src.las.classification, dst.las.classification);
  keep(src.las.return_number, dst.las.return_number);
  keep(src.las.number_of_returns, dst.las.number_of_returns);
}

}  // namespace

Status CompressedModel::Impl::decode_one(BlockSource& src, std::size_t k,
                                         const DecodeOptions& options, const Box3f* clip,
                                         std::vector<codec::NeighbourInstance>& neighbours,
                                         PointCloud& out) const {
  std::shared_ptr<const DecodedPatches> own;
  SSPC_RETURN_IF_ERROR(src.patches(k / patches_per_block(), own));
  SSPC_DCHECK(k >= own->first && k - own->first < own->count());
  const std::size_t local = k - own->first;
  const std::uint32_t c = own->codeword[local];
  const Eigen::Matrix3f& rotation = own->rotation[local];
  const Vec3f centre = own->centre[local];

  std::shared_ptr<const DecodedCodewords> words;
  SSPC_RETURN_IF_ERROR(src.codewords(c / codewords_per_block(), words));
  SSPC_DCHECK(c >= words->first && c - words->first < words->count());
  const std::size_t w = c - words->first;
  const std::uint32_t begin = words->offsets[w], end = words->offsets[w + 1];
  SSPC_DCHECK(begin <= end && end <= words->points.size());
  codec::CodewordView view;
  view.points = words->points.data() + begin;
  view.norm2 = words->norm2.data() + begin;
  view.normals = words->normals.empty() ? nullptr : words->normals.data() + begin;
  view.colours = words->colours.empty() ? nullptr : words->colours.data() + begin;
  view.size = end - begin;

  const bool overlap = options.overlap;
  const int resample = overlap                 ? 0
                       : options.resample < 0 ? reader.header().resample
                                              : std::min(options.resample, codec::kMaxResample);
  neighbours.clear();
  if (!overlap) {
    const float threshold2 = codec::neighbour_threshold2(words->radius[w]);
    const float reach =
        std::sqrt(threshold2) * 1.01f + kSearchSlack * (coordinate_scale + words->radius[w]);
    thread_local std::vector<std::size_t> blocks;
    blocks.clear();
    index.for_each_near(centre, reach * reach, [&](std::size_t b) { blocks.push_back(b); });
    for (std::size_t b : blocks) {
      std::shared_ptr<const DecodedPatches> near;
      SSPC_RETURN_IF_ERROR(src.patches(b, near));
      for (std::uint32_t i = 0; i < near->count(); ++i) {
        const std::uint32_t j = near->first + i;
        if (j == k) continue;
        if (codec::centre_distance2(near->centre[i], centre) <= threshold2) {
          neighbours.push_back({j, near->centre[i]});
        }
      }
    }
  }
  if ((own->attribute_streams.empty() || overlap) && resample == 0) {
    codec::emit_patch(static_cast<std::uint32_t>(k), rotation, centre, view, neighbours, overlap,
                      clip, out);
    return Status();
  }
  // Attributes are coded for the patch's whole region in decode order (FORMAT.md,
  // "Attributes"): decode them for all of it, then clip.
  thread_local PointCloud part;
  thread_local codec::AttributeReferences refs;
  thread_local std::vector<std::uint32_t> parents;
  part.positions.clear();
  part.normals.clear();
  part.colours.clear();
  part.las.clear();
  codec::emit_patch(static_cast<std::uint32_t>(k), rotation, centre, view, neighbours, false,
                    nullptr, part, resample > 0 ? &parents : nullptr);
  // The code word's surface: the block's, built as it was decoded where the header asks for
  // resampling, else one for this call (a decode that asks for another m than the header's).
  std::optional<codec::CodewordFit> own_surface;
  const auto emit_resampled = [&] {
    const codec::CodewordFit& surface =
        words->surfaces.empty() ? own_surface.emplace(std::span<const Vec3f>(view.points, view.size))
                                : words->surfaces[w];
    codec::emit_resampled(rotation, centre, surface, resample, position_step, part, parents, clip, out);
  };
  if (own->attribute_streams.empty()) {
    emit_resampled();
    return Status();
  }
  refs.find(part.positions);
  const codec::AttributeParams& params = reader.attributes();
  for (std::size_t bit = 0; bit < codec::kChannelCount; ++bit) {
    const auto channel = static_cast<std::uint8_t>(1u << bit);
    if ((params.channels & channel) == 0) continue;
    Status s = codec::decode_attribute_stream(channel, params, refs,
                                              own->attribute_streams[local][bit], part);
    if (!s.ok()) {
      return Status(s.code(), reader.name() + ": patch " + std::to_string(k) + ": " + s.message());
    }
  }
  if (resample > 0) {
    emit_resampled();
    return Status();
  }
  if (clip != nullptr) {
    append_inside(out, part, *clip);
  } else {
    out.append(part);
  }
  return Status();
}

CompressedModel::CompressedModel(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
CompressedModel::CompressedModel(CompressedModel&&) noexcept = default;
CompressedModel& CompressedModel::operator=(CompressedModel&&) noexcept = default;
CompressedModel::~CompressedModel() = default;

StatusOr<CompressedModel> CompressedModel::open(const std::filesystem::path& path) {
  auto impl = std::make_unique<Impl>();
  SSPC_ASSIGN_OR_RETURN(impl->mapped, MappedFile::open(path));
  SSPC_RETURN_IF_ERROR(after_read(impl->mapped, impl->init(impl->mapped.bytes(), path.string())));
  return CompressedModel(std::move(impl));
}

StatusOr<CompressedModel> CompressedModel::from_bytes(std::string bytes) {
  auto impl = std::make_unique<Impl>();
  impl->owned = std::move(bytes);
  const auto span = std::as_bytes(std::span<const char>(impl->owned.data(), impl->owned.size()));
  SSPC_RETURN_IF_ERROR(impl->init(span, "<memory>"));
  return CompressedModel(std::move(impl));
}

std::size_t CompressedModel::patch_count() const {
  return impl_->reader.header().patch_count;
}
std::size_t CompressedModel::codeword_count() const {
  return impl_->reader.header().codeword_count;
}

StatusOr<PatchRecord> CompressedModel::patch(std::size_t k) const {
  if (k >= patch_count()) {
    return invalid_argument("patch " + std::to_string(k) + " out of range (the model has " +
                            std::to_string(patch_count()) + ")");
  }
  CachedSource src = impl_->cached();
  std::shared_ptr<const DecodedPatches> block;
  SSPC_RETURN_IF_ERROR(src.patches(k / impl_->patches_per_block(), block));
  SSPC_DCHECK(k >= block->first && k - block->first < block->count());
  const std::size_t i = k - block->first;
  PatchRecord r;
  r.codeword = block->codeword[i];
  r.rotation = block->rotation[i];
  r.translation = block->centre[i];
  return r;
}

StatusOr<CodewordData> CompressedModel::codeword(std::size_t c) const {
  if (c >= codeword_count()) {
    return invalid_argument("code word " + std::to_string(c) + " out of range (the model has " +
                            std::to_string(codeword_count()) + ")");
  }
  CachedSource src = impl_->cached();
  std::shared_ptr<const DecodedCodewords> block;
  SSPC_RETURN_IF_ERROR(src.codewords(c / impl_->codewords_per_block(), block));
  SSPC_DCHECK(c >= block->first && c - block->first < block->count());
  const std::size_t w = c - block->first;
  const auto begin = static_cast<std::ptrdiff_t>(block->offsets[w]);
  const auto end = static_cast<std::ptrdiff_t>(block->offsets[w + 1]);
  CodewordData out;
  out.radius = block->radius[w];
  out.points.positions.assign(block->points.begin() + begin, block->points.begin() + end);
  if (!block->normals.empty()) {
    out.points.normals.assign(block->normals.begin() + begin, block->normals.begin() + end);
  }
  if (!block->colours.empty()) {
    out.points.colours.assign(block->colours.begin() + begin, block->colours.begin() + end);
  }
  return out;
}

// A decoded cloud in the world of the file. The metadata stays with metadata(): a renderer
// decodes patches by the thousand and needs no copy of a CRS with each.
PointCloud CompressedModel::placed(PointCloud cloud) const {
  cloud.origin = impl_->reader.metadata().origin;
  return cloud;
}

Vec3d CompressedModel::origin() const { return impl_->reader.metadata().origin; }

const CloudMetadata& CompressedModel::metadata() const { return impl_->reader.metadata().cloud; }

StatusOr<PointCloud> CompressedModel::decode_patch(std::size_t k,
                                                   const DecodeOptions& options) const {
  if (k >= patch_count()) {
    return invalid_argument("patch " + std::to_string(k) + " out of range (the model has " +
                            std::to_string(patch_count()) + ")");
  }
  CachedSource src = impl_->cached();
  PointCloud out;
  thread_local std::vector<codec::NeighbourInstance> neighbours;
  SSPC_RETURN_IF_ERROR(impl_->decode_one(src, k, options, nullptr, neighbours, out));
  if (options.patch_of != nullptr) options.patch_of->assign(out.size(), static_cast<std::uint32_t>(k));
  return placed(std::move(out));
}

StatusOr<PointCloud> CompressedModel::decode_box(const Box3f& box,
                                                 const DecodeOptions& options) const {
  if (!box.min().allFinite() || !box.max().allFinite()) {
    return invalid_argument("decode_box: the box is not finite");
  }
  PointCloud out;
  if (options.patch_of != nullptr) options.patch_of->clear();
  if (box.isEmpty()) return placed(std::move(out));
  const codec::ContainerHeader& h = impl_->reader.header();
  // A patch's points lie within its code word's radius (≤ codeword_radius) of its centre.
  const float scale = std::max(
      {impl_->coordinate_scale, box.min().cwiseAbs().maxCoeff(), box.max().cwiseAbs().maxCoeff()});
  const float reach = h.codeword_radius * 1.01f + kSearchSlack * (scale + h.codeword_radius);
  const float reach2 = reach * reach;
  std::vector<std::size_t> blocks;
  impl_->index.for_each_meeting(box, reach2, [&](std::size_t b) { blocks.push_back(b); });

  progress_begin(options.progress, "decoding box", blocks.size(), "blocks");
  CachedSource src = impl_->cached();
  std::vector<codec::NeighbourInstance> neighbours;
  for (std::size_t b : blocks) {
    std::shared_ptr<const DecodedPatches> block;
    SSPC_RETURN_IF_ERROR(src.patches(b, block));
    for (std::uint32_t i = 0; i < block->count(); ++i) {
      if (box.squaredExteriorDistance(block->centre[i]) > reach2) continue;
      SSPC_RETURN_IF_ERROR(
          impl_->decode_one(src, block->first + i, options, &box, neighbours, out));
      if (options.patch_of != nullptr) options.patch_of->resize(out.size(), block->first + i);
    }
    progress_advance(options.progress, 1);
  }
  progress_end(options.progress);
  return placed(std::move(out));
}

StatusOr<PointCloud> CompressedModel::decode_all(const DecodeOptions& options) const {
  PointCloud out;
  std::vector<std::uint32_t> patch_of, chunk_patch_of;
  DecodeOptions one = options;
  if (options.patch_of != nullptr) one.patch_of = &chunk_patch_of;
  // One chunk: every patch block (decode_chunks reads the largest size as "no limit").
  bool first = true;
  SSPC_RETURN_IF_ERROR(decode_chunks(std::numeric_limits<std::size_t>::max(), [&](PointCloud&& chunk) {
    SSPC_DCHECK(first);
    first = false;
    out = std::move(chunk);
    patch_of = std::move(chunk_patch_of);
    return Status();
  }, one));
  if (options.patch_of != nullptr) *options.patch_of = std::move(patch_of);
  return out;
}

Status CompressedModel::decode_chunks(std::size_t chunk_points, const std::function<Status(PointCloud&&)>& sink,
                                      const DecodeOptions& options) const {
  if (chunk_points == 0) return invalid_argument("decode_chunks: chunk_points must be positive");
  const codec::ContainerReader& reader = impl_->reader;
  const std::size_t p_blocks = reader.patch_blocks().size();
  const std::size_t c_blocks = reader.codebook_blocks().size();
  // Patch blocks a chunk: its points over the source's points a patch, a block's patches.
  const double per_block = static_cast<double>(impl_->patches_per_block()) *
                           static_cast<double>(std::max<std::uint64_t>(1, reader.header().source_points)) /
                           static_cast<double>(std::max<std::size_t>(1, patch_count()));
  // The header's source point count is what the encoder read, which a hostile file may state
  // as anything: it sizes the chunks, never what they hold; "no limit" is one chunk whatever it
  // says (decode_all relies on that).
  const std::size_t blocks_per_chunk =
      chunk_points == std::numeric_limits<std::size_t>::max() ||
              static_cast<double>(chunk_points) >= per_block * static_cast<double>(p_blocks)
          ? std::max<std::size_t>(1, p_blocks)
          : std::max<std::size_t>(1, static_cast<std::size_t>(static_cast<double>(chunk_points) / per_block));
  const bool colours = info().has_colours;
  PreloadedSource src(impl_->cached());
  src.patch_blocks.resize(p_blocks);
  src.codeword_blocks.resize(c_blocks);
  std::vector<std::size_t> held_codewords;  // the previous chunk's code-word blocks

  progress_begin(options.progress, "decoding", patch_count(), "patches");
  for (std::size_t first = 0; first < p_blocks; first += blocks_per_chunk) {
    const std::size_t last = std::min(p_blocks, first + blocks_per_chunk);
    // The chunk's patch blocks, then the code-word blocks its patches use, decoded in parallel;
    // the previous chunk's code-word blocks it does not use are released.
    std::vector<Status> status(last - first);
    parallel_for(first, last, 1, [&](std::size_t b) {
      if (src.patch_blocks[b]) return;
      auto block = std::make_shared<DecodedPatches>();
      status[b - first] = reader.read_patches(b, *block);
      src.patch_blocks[b] = std::move(block);
    });
    SSPC_RETURN_IF_ERROR(impl_->mapped.check_intact());
    for (const Status& s : status) SSPC_RETURN_IF_ERROR(s);
    std::vector<std::size_t> needed;
    for (std::size_t b = first; b < last; ++b) {
      for (const std::uint32_t c : src.patch_blocks[b]->codeword) needed.push_back(c / impl_->codewords_per_block());
    }
    std::sort(needed.begin(), needed.end());
    needed.erase(std::unique(needed.begin(), needed.end()), needed.end());
    for (const std::size_t c : held_codewords) {
      if (!std::binary_search(needed.begin(), needed.end(), c)) src.codeword_blocks[c].reset();
    }
    status.assign(needed.size(), Status());
    parallel_for(0, needed.size(), 1, [&](std::size_t i) {
      const std::size_t c = needed[i];
      if (c >= c_blocks || src.codeword_blocks[c]) return;  // out of range: decode_one's read reports it
      auto block = std::make_shared<DecodedCodewords>();
      status[i] = reader.read_codewords(c, *block);
      src.codeword_blocks[c] = std::move(block);
    });
    SSPC_RETURN_IF_ERROR(impl_->mapped.check_intact());
    for (const Status& s : status) SSPC_RETURN_IF_ERROR(s);
    held_codewords = std::move(needed);

    std::vector<PointCloud> parts(last - first);
    std::vector<std::vector<std::uint32_t>> part_patches(options.patch_of != nullptr ? last - first : 0);
    status.assign(last - first, Status());
    parallel_for(first, last, 1, [&](std::size_t b) {
      PreloadedSource& shared = src;  // read-only from here on (misses go to the thread-safe cache)
      std::vector<codec::NeighbourInstance> neighbours;
      const DecodedPatches& block = *shared.patch_blocks[b];
      PointCloud& part = parts[b - first];
      // Room for every point of the block's code words (trimmed code words keep almost all of
      // theirs; resampled ones decode m × m a point): grown patch by patch instead, the part
      // was reallocated and its pages faulted in again about a dozen times a block.
      std::size_t bound = 0;
      for (const std::uint32_t c : block.codeword) {
        const auto& words = shared.codeword_blocks[c / impl_->codewords_per_block()];
        if (words && c >= words->first && c - words->first < words->count()) {
          bound += words->offsets[c - words->first + 1] - words->offsets[c - words->first];
        }
      }
      const auto m = static_cast<std::size_t>(std::max(1, reader.header().resample));
      part.reserve(std::min<std::size_t>(bound * m * m, kMaxReservedPoints), reader.header().has_normals(), colours);
      for (std::uint32_t i = 0; i < block.count(); ++i) {
        Status s = impl_->decode_one(shared, block.first + i, options, nullptr, neighbours, part);
        if (!s.ok()) {
          status[b - first] = s;
          return;
        }
        if (!part_patches.empty()) part_patches[b - first].resize(part.size(), block.first + i);
      }
      progress_advance(options.progress, block.count());
    });
    for (const Status& s : status) SSPC_RETURN_IF_ERROR(s);
    // The chunk before this one may hold the neighbours of this one's first patches; older
    // patch blocks are released.
    for (std::size_t b = first >= blocks_per_chunk ? first - blocks_per_chunk : 0; b < first; ++b) {
      src.patch_blocks[b].reset();
    }

    std::size_t total = 0;
    for (const PointCloud& p : parts) total += p.size();
    PointCloud chunk = PointCloud::concatenate(std::move(parts));
    if (options.patch_of != nullptr) {
      options.patch_of->clear();
      options.patch_of->reserve(total);
      for (const auto& p : part_patches) options.patch_of->insert(options.patch_of->end(), p.begin(), p.end());
    }
    SSPC_RETURN_IF_ERROR(sink(placed(std::move(chunk))));
  }
  progress_end(options.progress);
  if (p_blocks == 0) {  // a model without patches: one empty chunk, with the origin
    if (options.patch_of != nullptr) options.patch_of->clear();
    return sink(placed(PointCloud()));
  }
  return Status();
}

Status CompressedModel::verify() const {
  const codec::ContainerReader& reader = impl_->reader;
  const std::size_t p_blocks = reader.patch_blocks().size();
  const std::size_t c_blocks = reader.codebook_blocks().size();
  std::vector<Status> status(p_blocks + c_blocks);
  parallel_for(0, p_blocks + c_blocks, 1, [&](std::size_t i) {
    if (i < p_blocks) {
      DecodedPatches block;
      status[i] = reader.read_patches(i, block);
    } else {
      DecodedCodewords block;
      status[i] = reader.read_codewords(i - p_blocks, block);
    }
  });
  // Blocks first: their errors say which block and where; the section CRCs then catch what
  // no block covers. A truncation explains either.
  SSPC_RETURN_IF_ERROR(impl_->mapped.check_intact());
  for (const Status& s : status) SSPC_RETURN_IF_ERROR(s);
  SSPC_RETURN_IF_ERROR(
      after_read(impl_->mapped, reader.check_section_crc(codec::SectionKind::kCodebookBlocks)));
  SSPC_RETURN_IF_ERROR(
      after_read(impl_->mapped, reader.check_section_crc(codec::SectionKind::kPatchBlocks)));
  // Attribute streams are decoded against the geometry (FORMAT.md, "Attributes"): only a whole
  // decode shows that every one is well formed.
  if (reader.attributes().channels != 0) {
    auto all = decode_all();
    if (!all.ok()) return all.status();
  }
  return Status();
}

void CompressedModel::set_cache_budget(std::uint64_t bytes) const {
  impl_->patch_cache.set_budget(Impl::patch_share(bytes));
  impl_->codeword_cache.set_budget(bytes - Impl::patch_share(bytes));
}

std::uint64_t CompressedModel::cache_budget() const {
  return impl_->patch_cache.budget() + impl_->codeword_cache.budget();
}

std::uint64_t CompressedModel::cache_bytes() const {
  return impl_->patch_cache.bytes() + impl_->codeword_cache.bytes();
}

std::uint64_t CompressedModel::cache_peak_bytes() const {
  return impl_->patch_cache.peak_bytes() + impl_->codeword_cache.peak_bytes();
}

void CompressedModel::reset_cache_peak() const {
  impl_->patch_cache.reset_peak();
  impl_->codeword_cache.reset_peak();
}

ModelInfo CompressedModel::info() const {
  const codec::ContainerReader& reader = impl_->reader;
  const codec::ContainerHeader& h = reader.header();
  ModelInfo m;
  m.version = h.version;
  m.has_normals = h.has_normals();
  const codec::AttributeParams& a = reader.attributes();
  m.attributes = a.channels;
  m.has_colours = h.has_colours() || (a.channels & codec::kChannelColour) != 0;
  m.colour_step = (a.channels & codec::kChannelColour) ? a.colour_step : 0;
  m.intensity_step = (a.channels & codec::kChannelIntensity) ? a.intensity_step : 0;
  m.attribute_bytes = reader.attribute_part_bytes();
  m.patch_radius = h.patch_radius;
  m.coverage_radius = h.coverage_radius;
  m.spacing = h.spacing;
  m.codeword_radius = h.codeword_radius;
  m.bounds = Box3f(h.bounds_min, h.bounds_max);
  m.source_points = h.source_points;
  m.position_bits = h.position_bits;
  m.normal_bits = h.normal_bits;
  m.rotation_bits = h.rotation_bits;
  m.translation_step = h.translation_step;
  m.resample = h.resample;
  m.patches = h.patch_count;
  m.codewords = h.codeword_count;
  m.codeword_points = h.codeword_point_count;
  m.patches_per_block = h.patches_per_block;
  m.codewords_per_block = h.codewords_per_block;
  m.file_bytes = reader.file_size();
  m.header_bytes = codec::kHeaderSize;
  for (std::size_t i = 0; i < codec::kSectionCount; ++i) {
    const codec::SectionEntry& s = h.sections[i];
    SectionInfo& out = m.sections[i];
    out.name = codec::section_name(s.kind);
    out.offset = s.offset;
    out.bytes = s.size;
    out.raw_bytes = s.size;
  }
  auto fill_blocks = [](SectionInfo& s, const std::vector<codec::BlockEntry>& blocks) {
    s.blocks = blocks.size();
    s.raw_bytes = 0;
    for (const codec::BlockEntry& e : blocks) s.raw_bytes += e.raw_size;
  };
  fill_blocks(m.sections[0], reader.codebook_blocks());
  fill_blocks(m.sections[2], reader.patch_blocks());
  m.sections[1].blocks = reader.codebook_blocks().size();
  m.sections[3].blocks = reader.patch_blocks().size();
  m.codebook_ratio = h.codeword_count == 0 ? 0.0
                                           : static_cast<double>(h.patch_count) /
                                                 static_cast<double>(h.codeword_count);
  m.bits_per_point = h.source_points == 0 ? 0.0
                                          : static_cast<double>(m.file_bytes) * 8.0 /
                                                static_cast<double>(h.source_points);
  return m;
}

}  // namespace sspc
