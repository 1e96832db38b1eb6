// The .sspc container: round trip within the quantisation error, deterministic bytes, and a
// reader that refuses every malformed file (truncations at every length, flipped bytes, trailing
// bytes, bad magic, unknown versions, absurd counts) with an error instead of a crash.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cstring>
#include <limits>
#include <string>

#include <unistd.h>

#include "container_test_models.hpp"
#include "encoder/container_writer.hpp"
#include "format/checksum.hpp"
#include "format/container_format.hpp"
#include "format/container_reader.hpp"
#include "format/quantise.hpp"
#include "geometry/rigid_transform.hpp"
#include "sspc/compressed_model.hpp"
#include "test_util.hpp"

namespace sspc::codec {
namespace {

test::ModelShape small_shape() {
  test::ModelShape s;
  s.side = 12;
  s.patch_radius = 3.0f;
  s.centre_step = 3.0f;
  s.codewords = 3;
  s.full_rotations = true;
  return s;
}

QuantOptions small_blocks() {
  QuantOptions o;
  o.patches_per_block = 4;
  o.codewords_per_block = 2;
  return o;
}

std::string encode_or_die(const EncodedModel& m, const QuantOptions& o = {}) {
  auto bytes = encode_container(m, o);
  EXPECT_TRUE(bytes.ok()) << bytes.status().to_string();
  return bytes.ok() ? *bytes : std::string();
}

bool same_cloud(const PointCloud& a, const PointCloud& b) {
  return a.positions == b.positions && a.normals == b.normals && a.colours == b.colours;
}

void store_u32(std::string& s, std::size_t at, std::uint32_t v) {
  for (int i = 0; i < 4; ++i)
    s[at + static_cast<std::size_t>(i)] = static_cast<char>((v >> (8 * i)) & 0xFF);
}
void fix_header_crc(std::string& s) {
  const auto span = std::as_bytes(std::span<const char>(s.data(), kHeaderCrcOffset));
  store_u32(s, kHeaderCrcOffset, crc32_of(span));
}

TEST(ContainerTest, RoundTripWithinQuantisationError) {
  const EncodedModel m = test::make_plane_model(small_shape());
  const QuantOptions o = small_blocks();
  auto model = CompressedModel::from_bytes(encode_or_die(m, o));
  ASSERT_TRUE(model.ok()) << model.status().to_string();
  ASSERT_EQ(model->patch_count(), m.patches.size());
  ASSERT_EQ(model->codeword_count(), m.codebook.size());

  const float step = position_step(m.patch_radius, o.position_bits);
  for (std::size_t c = 0; c < m.codebook.size(); ++c) {
    auto w = model->codeword(c);
    ASSERT_TRUE(w.ok()) << w.status().to_string();
    const Codeword& src = m.codebook[c];
    ASSERT_EQ(w->points.size(), src.points.size());
    // The columns store a code word's points in their own order: pair each decoded point with
    // its source point, each used once. Within half a step on x and y; on z, version 5's writer
    // may code a lowest height one step nearer its prediction (choose_codeword_heights), never
    // further than a step from where it lies.
    std::vector<bool> used(src.points.size(), false);
    for (std::size_t i = 0; i < src.points.size(); ++i) {
      std::size_t j = src.points.size();
      float best = std::numeric_limits<float>::infinity();
      for (std::size_t s = 0; s < src.points.size(); ++s) {
        const float d = (w->points.positions[i] - src.points[s]).squaredNorm();
        if (!used[s] && d < best) {
          best = d;
          j = s;
        }
      }
      ASSERT_LT(j, src.points.size());
      used[j] = true;
      const Vec3f off = (w->points.positions[i] - src.points[j]).cwiseAbs();
      EXPECT_LE(std::max(off.x(), off.y()), step * 0.5001f);
      EXPECT_LE(off.z(), step * 1.0001f);
      EXPECT_GT(w->points.normals[i].dot(src.normals[j]), std::cos(0.2f * 3.14159f / 180));
      EXPECT_EQ(w->points.colours[i], src.colours[j]);
      EXPECT_LE(w->points.positions[i].norm(), w->radius);
    }
  }
  const float t_step = m.spacing / 64;
  for (std::size_t k = 0; k < m.patches.size(); ++k) {
    auto p = model->patch(k);
    ASSERT_TRUE(p.ok()) << p.status().to_string();
    EXPECT_EQ(p->codeword, m.patches[k].codeword);
    EXPECT_TRUE(is_rotation(p->rotation, 1e-5f));
    EXPECT_GT(p->rotation.determinant(), 0.0f);
    EXPECT_LE((p->rotation - m.patches[k].world_from_codeword.rotation).cwiseAbs().maxCoeff(),
              1e-3f);
    EXPECT_LE((p->translation - m.patches[k].world_from_codeword.translation).cwiseAbs().maxCoeff(),
              t_step * 0.5f + 1e-5f);
  }
  EXPECT_FALSE(model->patch(m.patches.size()).ok());
  EXPECT_FALSE(model->codeword(m.codebook.size()).ok());

  const ModelInfo info = model->info();
  EXPECT_EQ(info.version, kFormatVersion);
  EXPECT_EQ(info.patches, m.patches.size());
  EXPECT_NEAR(info.codebook_ratio,
              static_cast<double>(m.patches.size()) / static_cast<double>(m.codebook.size()), 1e-9);
  EXPECT_TRUE(model->verify().ok());
}

TEST(ContainerTest, WithoutNormalsOrColours) {
  test::ModelShape s = small_shape();
  s.normals = false;
  s.colours = false;
  const EncodedModel m = test::make_plane_model(s);
  auto model = CompressedModel::from_bytes(encode_or_die(m, small_blocks()));
  ASSERT_TRUE(model.ok()) << model.status().to_string();
  auto all = model->decode_all();
  ASSERT_TRUE(all.ok());
  EXPECT_FALSE(all->has_normals());
  EXPECT_FALSE(all->has_colours());
  EXPECT_TRUE(all->validate().ok());
}

TEST(ContainerTest, DeterministicBytesWhateverTheThreadCount) {
  test::ModelShape s = small_shape();
  s.side = 40;
  const EncodedModel m = test::make_plane_model(s);
  const std::string many = encode_or_die(m, small_blocks());
  std::string one;
  {
    tbb::global_control single(tbb::global_control::max_allowed_parallelism, 1);
    one = encode_or_die(m, small_blocks());
  }
  EXPECT_EQ(many, one);
  EXPECT_EQ(many, encode_or_die(m, small_blocks()));
}

TEST(ContainerTest, WriteIsAtomicAndReadable) {
  test::TempDir dir;
  const EncodedModel m = test::make_plane_model(small_shape());
  const auto path = dir.path() / "m.sspc";
  auto stats = write_container(m, small_blocks(), path);
  ASSERT_TRUE(stats.ok()) << stats.status().to_string();
  EXPECT_EQ(stats->file_bytes, std::filesystem::file_size(path));
  EXPECT_EQ(stats->header_bytes + stats->codebook_bytes + stats->codebook_seek_bytes +
                stats->patch_bytes + stats->patch_seek_bytes,
            stats->file_bytes);
  EXPECT_EQ(test::count_files(dir.path()), 1u);  // no temporary left behind
  auto model = CompressedModel::open(path);
  ASSERT_TRUE(model.ok()) << model.status().to_string();
  EXPECT_TRUE(model->verify().ok());
  EXPECT_EQ(model->info().file_bytes, stats->file_bytes);
}

// A model keeps its file mapped for random access; when the file shrinks under it, every decode
// that touches the lost part says so, instead of the process dying of SIGBUS or the decoder
// blaming a checksum.
TEST(ContainerTest, AFileThatShrinksWhileOpenGivesAClearError) {
  test::TempDir dir;
  test::ModelShape shape = small_shape();
  shape.side = 96;
  const EncodedModel m = test::make_plane_model(shape);
  const auto path = dir.path() / "shrinking.sspc";
  auto stats = write_container(m, small_blocks(), path);
  ASSERT_TRUE(stats.ok()) << stats.status().to_string();
  const std::uint64_t size = stats->file_bytes;
  ASSERT_GT(size, 4u * static_cast<std::uint64_t>(sysconf(_SC_PAGESIZE)));  // faults, not zeros
  auto model = CompressedModel::open(path);
  ASSERT_TRUE(model.ok()) << model.status().to_string();
  ASSERT_EQ(truncate(path.c_str(), static_cast<off_t>(kHeaderSize)), 0);

  const std::string expected = path.string() + ": the file shrank while it was read (was " +
                               std::to_string(size) + " bytes)";
  const StatusOr<PointCloud> all = model->decode_all();
  ASSERT_FALSE(all.ok());
  EXPECT_EQ(all.status().code(), StatusCode::kIoError);
  EXPECT_EQ(all.status().message(), expected);
  const StatusOr<PointCloud> last = model->decode_patch(model->patch_count() - 1);
  ASSERT_FALSE(last.ok());
  EXPECT_EQ(last.status().message(), expected);
  const StatusOr<CodewordData> word = model->codeword(model->codeword_count() - 1);
  ASSERT_FALSE(word.ok());
  EXPECT_EQ(word.status().message(), expected);
  EXPECT_EQ(model->verify().message(), expected);
}

TEST(ContainerTest, InvalidModelsAreRefused) {
  EncodedModel m = test::make_plane_model(small_shape());
  m.patches[3].codeword = 99;
  EXPECT_EQ(encode_container(m, {}).status().code(), StatusCode::kInvalidArgument);
  m = test::make_plane_model(small_shape());
  m.codebook[1].normals.pop_back();
  EXPECT_EQ(encode_container(m, {}).status().code(), StatusCode::kInvalidArgument);
  m = test::make_plane_model(small_shape());
  QuantOptions o;
  o.position_bits = 17;
  EXPECT_EQ(encode_container(m, o).status().code(), StatusCode::kInvalidArgument);
  o = {};
  o.translation_step = 1e-9f;  // grid values beyond 2^24
  EXPECT_EQ(encode_container(m, o).status().code(), StatusCode::kInvalidArgument);
}

TEST(ContainerTest, EmptyModelRoundTrips) {
  EncodedModel m;
  m.patch_radius = 1;
  auto model = CompressedModel::from_bytes(encode_or_die(m));
  ASSERT_TRUE(model.ok()) << model.status().to_string();
  EXPECT_EQ(model->patch_count(), 0u);
  auto all = model->decode_all();
  ASSERT_TRUE(all.ok());
  EXPECT_TRUE(all->empty());
  EXPECT_TRUE(model->verify().ok());
}

TEST(ContainerTest, EveryTruncationIsRefused) {
  const std::string bytes = encode_or_die(test::make_plane_model(small_shape()), small_blocks());
  ASSERT_GT(bytes.size(), kHeaderSize);
  for (std::size_t n = 0; n < bytes.size(); ++n) {
    auto model = CompressedModel::from_bytes(bytes.substr(0, n));
    ASSERT_FALSE(model.ok()) << "a file truncated to " << n << " bytes was accepted";
    // Every message names the file (from_bytes calls it "<memory>"), also past the header,
    // where the name was once read after being moved away: ": byte 10000: ...".
    EXPECT_EQ(model.status().message().rfind("<memory>: ", 0), 0u) << model.status().message();
    if (n >= 8) {
      EXPECT_EQ(model.status().code(), StatusCode::kCorrupt) << n;
    }
  }
}

TEST(ContainerTest, TrailingBytesAreRefused) {
  const std::string bytes = encode_or_die(test::make_plane_model(small_shape()), small_blocks());
  for (const std::string& tail : {std::string(1, '\0'), std::string("garbage")}) {
    auto model = CompressedModel::from_bytes(bytes + tail);
    ASSERT_FALSE(model.ok());
    EXPECT_NE(model.status().message().find("trailing"), std::string::npos)
        << model.status().message();
  }
}

TEST(ContainerTest, BadMagicAndUnknownVersionAreRefused) {
  const std::string bytes = encode_or_die(test::make_plane_model(small_shape()), small_blocks());
  std::string bad = bytes;
  bad[0] = 'P';
  auto model = CompressedModel::from_bytes(bad);
  ASSERT_FALSE(model.ok());
  EXPECT_NE(model.status().message().find("magic"), std::string::npos);
  EXPECT_FALSE(CompressedModel::from_bytes("ply\nformat ascii 1.0\n").ok());

  for (const int version : {0, kFormatVersion + 1}) {
    std::string other = bytes;
    other[8] = static_cast<char>(version);
    fix_header_crc(other);
    model = CompressedModel::from_bytes(other);
    ASSERT_FALSE(model.ok());
    EXPECT_EQ(model.status().code(), StatusCode::kUnsupported);
    EXPECT_NE(model.status().message().find("version " + std::to_string(version)), std::string::npos);
  }
}

TEST(ContainerTest, AbsurdCountsAreRefusedBeforeAllocating) {
  // A header promising 2^32 − 1 code words and patches in blocks of one: the seek tables that
  // would need (~300 GB) cannot be in a small file, so the reader must refuse it from the sizes
  // alone.
  std::string bytes = encode_or_die(test::make_plane_model(small_shape()), small_blocks());
  store_u32(bytes, 72, 0xFFFFFFFFu);
  store_u32(bytes, 76, 0xFFFFFFFFu);
  store_u32(bytes, 88, 1);
  store_u32(bytes, 92, 1);
  fix_header_crc(bytes);
  auto model = CompressedModel::from_bytes(bytes);
  ASSERT_FALSE(model.ok());
  EXPECT_EQ(model.status().code(), StatusCode::kCorrupt);

  // And a 100-byte file that starts like one.
  std::string tiny = bytes.substr(0, 100);
  EXPECT_FALSE(CompressedModel::from_bytes(tiny).ok());
}

// Flips every byte of a small file, one at a time: the reader must refuse the file (at open, on
// decode or on verify) or decode it exactly as before. Never a crash, never silent garbage.
TEST(ContainerTest, EveryFlippedByteIsCaughtOrHarmless) {
  test::ModelShape s = small_shape();
  s.side = 8;
  const std::string bytes = encode_or_die(test::make_plane_model(s), small_blocks());
  auto original = CompressedModel::from_bytes(bytes);
  ASSERT_TRUE(original.ok());
  auto expected = original->decode_all();
  ASSERT_TRUE(expected.ok());
  const ModelInfo info = original->info();
  int refused = 0;
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    std::string flipped = bytes;
    flipped[i] = static_cast<char>(flipped[i] ^ 0x20);
    auto model = CompressedModel::from_bytes(flipped);
    if (!model.ok()) {
      ++refused;
      continue;
    }
    const Status verified = model->verify();
    auto decoded = model->decode_all();
    if (!verified.ok()) {
      ++refused;
      // Flips in a block section name it.
      for (std::size_t sct : {std::size_t{0}, std::size_t{2}}) {
        const SectionInfo& sec = info.sections[sct];
        if (i >= sec.offset && i < sec.offset + sec.bytes) {
          EXPECT_NE(verified.message().find(sec.name), std::string::npos) << verified.message();
        }
      }
      continue;
    }
    ASSERT_TRUE(decoded.ok()) << "byte " << i << ": verify passed but decode failed: "
                              << decoded.status().to_string();
    EXPECT_TRUE(same_cloud(*decoded, *expected)) << "byte " << i << " changed the decode silently";
  }
  EXPECT_EQ(refused, static_cast<int>(bytes.size()));  // CRCs cover every byte
}

// block_bytes names exactly each block's stored bytes (what a mapped model hands back to the
// kernel once the block is decoded): the ranges lie in the file, in order, without overlap, and
// a byte flipped at either end of one breaks that block's read and no other's.
TEST(ContainerTest, BlockBytesAreEachBlocksStoredBytes) {
  const std::string bytes = encode_or_die(test::make_plane_model(small_shape()), small_blocks());
  const auto view = std::as_bytes(std::span<const char>(bytes.data(), bytes.size()));
  auto reader = ContainerReader::open(view, "<memory>");
  ASSERT_TRUE(reader.ok()) << reader.status().to_string();
  for (SectionKind kind : {SectionKind::kCodebookBlocks, SectionKind::kPatchBlocks}) {
    const std::size_t blocks = kind == SectionKind::kCodebookBlocks ? reader->codebook_blocks().size()
                                                                     : reader->patch_blocks().size();
    ASSERT_GE(blocks, 2u);
    auto read = [kind](const ContainerReader& r, std::size_t b) {
      if (kind == SectionKind::kCodebookBlocks) {
        DecodedCodewords out;
        return r.read_codewords(b, out);
      }
      DecodedPatches out;
      return r.read_patches(b, out);
    };
    std::size_t previous_end = 0;
    for (std::size_t b = 0; b < blocks; ++b) {
      const auto [begin, end] = reader->block_bytes(kind, b);
      ASSERT_LT(begin, end);
      ASSERT_LE(end, bytes.size());
      EXPECT_GE(begin, previous_end);
      previous_end = end;
      for (std::size_t at : {begin, end - 1}) {
        std::string flipped = bytes;
        flipped[at] = static_cast<char>(flipped[at] ^ 0x01);
        auto r = ContainerReader::open(std::as_bytes(std::span<const char>(flipped.data(), flipped.size())), "<memory>");
        ASSERT_TRUE(r.ok());
        for (std::size_t other = 0; other < blocks; ++other) {
          EXPECT_EQ(read(*r, other).ok(), other != b) << section_name(kind) << " block " << b << ", byte " << at;
        }
      }
    }
    EXPECT_EQ(reader->block_bytes(kind, blocks), (std::pair<std::size_t, std::size_t>{0, 0}));
  }
}

// A block whose bytes are corrupted but whose CRC was recomputed (a hostile file) must still
// decode safely: an error or well-formed points.
TEST(ContainerTest, HostileBlocksWithValidCrcsDoNotCrash) {
  test::ModelShape s = small_shape();
  s.side = 8;
  const EncodedModel m = test::make_plane_model(s);
  QuantOptions o = small_blocks();
  o.zstd_level = 1;
  const std::string bytes = encode_or_die(m, o);
  auto original = CompressedModel::from_bytes(bytes);
  ASSERT_TRUE(original.ok());
  const ModelInfo info = original->info();
  test::TestRng rng(11);
  for (int trial = 0; trial < 400; ++trial) {
    std::string hostile = bytes;
    const SectionInfo& sec = info.sections[trial % 2 == 0 ? 0 : 2];
    const std::size_t at = sec.offset + rng.below(static_cast<std::uint32_t>(sec.bytes));
    hostile[at] = static_cast<char>(rng.below(256));
    // Recompute every block CRC of both block sections and the section CRCs.
    auto fix = [&](std::size_t data, std::size_t seek, std::size_t entry_size) {
      const SectionInfo& d = info.sections[data];
      const SectionInfo& t = info.sections[seek];
      for (std::size_t e = t.offset; e < t.offset + t.bytes; e += entry_size) {
        std::uint64_t off = 0;
        std::memcpy(&off, hostile.data() + e, 8);
        std::uint32_t stored = 0;
        std::memcpy(&stored, hostile.data() + e + 8, 4);
        const auto span =
            std::as_bytes(std::span<const char>(hostile.data() + d.offset + off, stored));
        store_u32(hostile, e + 16, crc32_of(span));
      }
      const auto whole = std::as_bytes(std::span<const char>(hostile.data() + d.offset, d.bytes));
      store_u32(hostile, kSectionTableOffset + data * kSectionEntrySize + 4, crc32_of(whole));
      const auto table = std::as_bytes(std::span<const char>(hostile.data() + t.offset, t.bytes));
      store_u32(hostile, kSectionTableOffset + seek * kSectionEntrySize + 4, crc32_of(table));
    };
    fix(0, 1, kCodebookSeekEntrySize);
    fix(2, 3, kPatchSeekEntrySize);
    fix_header_crc(hostile);
    auto model = CompressedModel::from_bytes(hostile);
    ASSERT_TRUE(model.ok()) << model.status().to_string();
    auto all = model->decode_all();
    if (all.ok()) {
      EXPECT_TRUE(all->validate().ok());
      for (std::size_t k = 0; k < model->patch_count(); ++k) {
        auto p = model->decode_patch(k);
        if (p.ok()) {
          EXPECT_TRUE(p->validate().ok());
        }
      }
    } else {
      EXPECT_EQ(all.status().code(), StatusCode::kCorrupt);
    }
  }
}

}  // namespace
}  // namespace sspc::codec
