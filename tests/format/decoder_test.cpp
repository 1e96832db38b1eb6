// Region decoding (docs/FORMAT.md, "Decoding: regions"): one patch, one box and the whole
// model agree exactly; the regions are Voronoi cells; overlap mode keeps every instance whole;
// concurrent queries give the same answers.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <thread>
#include <vector>

#include "container_test_models.hpp"
#include "encoder/container_writer.hpp"
#include "format/block_cache.hpp"
#include "sspc/compressed_model.hpp"

namespace sspc::codec {
namespace {

struct Fixture {
  EncodedModel model;
  CompressedModel compressed;
  PointCloud all;
  std::vector<std::size_t> offsets;  // patch k's first point in `all`
};

Fixture make_fixture(const test::ModelShape& shape, const QuantOptions& options) {
  EncodedModel m = test::make_plane_model(shape);
  auto bytes = encode_container(m, options);
  EXPECT_TRUE(bytes.ok()) << bytes.status().to_string();
  auto c = CompressedModel::from_bytes(std::move(bytes).value());
  EXPECT_TRUE(c.ok()) << c.status().to_string();
  auto all = c->decode_all();
  EXPECT_TRUE(all.ok()) << all.status().to_string();
  Fixture f{std::move(m), std::move(c).value(), std::move(all).value(), {}};
  std::size_t at = 0;
  for (std::size_t k = 0; k < f.compressed.patch_count(); ++k) {
    f.offsets.push_back(at);
    auto p = f.compressed.decode_patch(k);
    EXPECT_TRUE(p.ok());
    at += p->size();
  }
  f.offsets.push_back(at);
  return f;
}

test::ModelShape default_shape() {
  test::ModelShape s;
  s.side = 40;
  s.patch_radius = 4.0f;
  s.centre_step = 3.0f;
  s.codewords = 6;
  return s;
}

QuantOptions eight_patch_blocks() {
  QuantOptions o;
  o.patches_per_block = 8;
  o.codewords_per_block = 2;
  return o;
}

PointCloud slice(const PointCloud& c, std::size_t begin, std::size_t end) {
  PointCloud out;
  const auto b = static_cast<std::ptrdiff_t>(begin), e = static_cast<std::ptrdiff_t>(end);
  out.positions.assign(c.positions.begin() + b, c.positions.begin() + e);
  if (c.has_normals()) out.normals.assign(c.normals.begin() + b, c.normals.begin() + e);
  if (c.has_colours()) out.colours.assign(c.colours.begin() + b, c.colours.begin() + e);
  return out;
}

void expect_same(const PointCloud& a, const PointCloud& b, const std::string& what) {
  ASSERT_EQ(a.size(), b.size()) << what;
  EXPECT_TRUE(a.positions == b.positions) << what;
  EXPECT_TRUE(a.normals == b.normals) << what;
  EXPECT_TRUE(a.colours == b.colours) << what;
}

TEST(DecoderTest, DecodePatchIsItsPartOfDecodeAll) {
  for (bool full : {false, true}) {
    test::ModelShape s = default_shape();
    s.full_rotations = full;
    Fixture f = make_fixture(s, eight_patch_blocks());
    ASSERT_EQ(f.offsets.back(), f.all.size());
    for (std::size_t k = 0; k < f.compressed.patch_count(); ++k) {
      auto p = f.compressed.decode_patch(k);
      ASSERT_TRUE(p.ok());
      expect_same(*p, slice(f.all, f.offsets[k], f.offsets[k + 1]), "patch " + std::to_string(k));
    }
    EXPECT_FALSE(f.compressed.decode_patch(f.compressed.patch_count()).ok());
  }
}

TEST(DecoderTest, DecodeBoxIsDecodeAllFilteredByTheBox) {
  Fixture f = make_fixture(default_shape(), eight_patch_blocks());
  test::TestRng rng(21);
  std::vector<Box3f> boxes = {Box3f(Vec3f(-100, -100, -100), Vec3f(100, 100, 100)),
                              Box3f(Vec3f(50, 50, 50), Vec3f(60, 60, 60)),
                              Box3f(Vec3f(10, 10, -1), Vec3f(10, 20, 1))};  // a flat box
  // A box whose faces pass exactly through decoded points: inclusive bounds matter.
  boxes.emplace_back(f.all.positions[100], f.all.positions[100] + Vec3f(5, 5, 1));
  for (int i = 0; i < 30; ++i) {
    const Vec3f a(rng.range(-5, 45), rng.range(-5, 45), rng.range(-1, 1));
    const Vec3f size(rng.range(0, 15), rng.range(0, 15), rng.range(0, 2));
    boxes.emplace_back(a, a + size);
  }
  for (const Box3f& box : boxes) {
    PointCloud expected;
    for (std::size_t i = 0; i < f.all.size(); ++i) {
      if (!box.contains(f.all.positions[i])) continue;
      expected.positions.push_back(f.all.positions[i]);
      expected.normals.push_back(f.all.normals[i]);
      expected.colours.push_back(f.all.colours[i]);
    }
    auto got = f.compressed.decode_box(box);
    ASSERT_TRUE(got.ok()) << got.status().to_string();
    expect_same(*got, expected, "box");
  }
  // The box on its face point: that point is in.
  auto edge = f.compressed.decode_box(boxes[3]);
  ASSERT_TRUE(edge.ok());
  EXPECT_NE(std::find(edge->positions.begin(), edge->positions.end(), f.all.positions[100]),
            edge->positions.end());
}

// DecodeOptions::patch_of names each point's patch: the patch decode's runs in decode_all, and
// the same patches for a box's points as the whole decode gives them.
TEST(DecoderTest, PatchOfNamesEachPointsPatch) {
  Fixture f = make_fixture(default_shape(), eight_patch_blocks());
  std::vector<std::uint32_t> all_of;
  DecodeOptions options;
  options.patch_of = &all_of;
  auto all = f.compressed.decode_all(options);
  ASSERT_TRUE(all.ok());
  ASSERT_EQ(all_of.size(), all->size());
  for (std::size_t k = 0; k < f.compressed.patch_count(); ++k) {
    for (std::size_t i = f.offsets[k]; i < f.offsets[k + 1]; ++i) ASSERT_EQ(all_of[i], k) << i;
  }
  std::vector<std::uint32_t> one;
  options.patch_of = &one;
  auto patch = f.compressed.decode_patch(3, options);
  ASSERT_TRUE(patch.ok());
  EXPECT_EQ(one, std::vector<std::uint32_t>(patch->size(), 3u));
  const Box3f box(Vec3f(5, 5, -1), Vec3f(20, 15, 1));
  std::vector<std::uint32_t> box_of;
  options.patch_of = &box_of;
  auto inside = f.compressed.decode_box(box, options);
  ASSERT_TRUE(inside.ok());
  std::vector<std::uint32_t> expected;
  for (std::size_t i = 0; i < f.all.size(); ++i) {
    if (box.contains(f.all.positions[i])) expected.push_back(all_of[i]);
  }
  ASSERT_GT(expected.size(), 20u);
  EXPECT_EQ(box_of, expected);
}

// decode_chunks: whole patch blocks a chunk, in order; joined, decode_all's cloud and patches,
// whatever the chunk size (one block, a few, more than the model); the sink's error stops it.
TEST(DecoderTest, ChunksJoinedAreDecodeAll) {
  Fixture f = make_fixture(default_shape(), eight_patch_blocks());
  std::vector<std::uint32_t> all_of;
  DecodeOptions whole;
  whole.patch_of = &all_of;
  ASSERT_TRUE(f.compressed.decode_all(whole).ok());
  const std::size_t blocks = (f.compressed.patch_count() + 7) / 8;
  ASSERT_GT(blocks, 4u);
  for (const std::size_t chunk_points : {std::size_t{1}, f.all.size() / 5, f.all.size() * 2}) {
    PointCloud joined;
    std::vector<std::uint32_t> joined_of, of;
    DecodeOptions options;
    options.patch_of = &of;
    std::size_t chunks = 0;
    const Status s = f.compressed.decode_chunks(chunk_points, [&](PointCloud&& chunk) {
      ++chunks;
      EXPECT_EQ(of.size(), chunk.size());
      // Whole patches: a chunk starts where a patch starts.
      EXPECT_EQ(of.empty() ? 0 : f.offsets[of.front()], joined.size());
      joined_of.insert(joined_of.end(), of.begin(), of.end());
      joined.append(chunk);
      return Status();
    }, options);
    ASSERT_TRUE(s.ok()) << s.to_string();
    expect_same(joined, f.all, "chunks of " + std::to_string(chunk_points));
    EXPECT_EQ(joined_of, all_of);
    if (chunk_points == 1) {
      EXPECT_EQ(chunks, blocks);  // one patch block a chunk
    }
    if (chunk_points > f.all.size()) {
      EXPECT_EQ(chunks, 1u);
    }
    if (chunk_points == f.all.size() / 5) {
      EXPECT_GE(chunks, 3u);
      EXPECT_LE(chunks, 8u);
    }
  }
  std::size_t calls = 0;
  const Status stopped = f.compressed.decode_chunks(1, [&](PointCloud&&) {
    ++calls;
    return corrupt("the sink's own error");
  });
  EXPECT_EQ(calls, 1u);
  EXPECT_EQ(stopped.message(), "the sink's own error");
  EXPECT_EQ(f.compressed.decode_chunks(0, [](PointCloud&&) { return Status(); }).code(),
            StatusCode::kInvalidArgument);
}

TEST(DecoderTest, OverlapModeKeepsEveryInstanceWhole) {
  Fixture f = make_fixture(default_shape(), eight_patch_blocks());
  std::size_t expected = 0;
  for (const PatchInstance& p : f.model.patches)
    expected += f.model.codebook[p.codeword].points.size();
  DecodeOptions overlap;
  overlap.overlap = true;
  auto all = f.compressed.decode_all(overlap);
  ASSERT_TRUE(all.ok());
  EXPECT_EQ(all->size(), expected);
  EXPECT_LT(f.all.size(), all->size());
  std::size_t at = 0;
  for (std::size_t k = 0; k < f.compressed.patch_count(); ++k) {
    auto p = f.compressed.decode_patch(k, overlap);
    ASSERT_TRUE(p.ok());
    expect_same(*p, slice(*all, at, at + p->size()), "overlap patch");
    at += p->size();
  }
}

// The default mode's regions are Voronoi cells: every point a patch keeps is (to float rounding)
// at least as near its own centre as any other, and the decoded count is close to the source's.
TEST(DecoderTest, RegionsAreVoronoiCellsAndCoverThePlane) {
  Fixture f = make_fixture(default_shape(), eight_patch_blocks());
  std::vector<Vec3f> centres;
  for (std::size_t k = 0; k < f.compressed.patch_count(); ++k) {
    centres.push_back(f.compressed.patch(k)->translation);
  }
  for (std::size_t k = 0; k < centres.size(); ++k) {
    for (std::size_t i = f.offsets[k]; i < f.offsets[k + 1]; ++i) {
      const Vec3f& p = f.all.positions[i];
      const float own = (p - centres[k]).norm();
      for (const Vec3f& c : centres) ASSERT_LE(own, (p - c).norm() + 1e-4f);
    }
  }
  // Edge patches reach beyond the source square; count what lies on it.
  const Box3f square(Vec3f(-0.5f, -0.5f, -1), Vec3f(39.5f, 39.5f, 1));
  const auto inside = std::count_if(f.all.positions.begin(), f.all.positions.end(),
                                    [&](const Vec3f& p) { return square.contains(p); });
  const double ratio = static_cast<double>(inside) / static_cast<double>(f.model.source_points);
  EXPECT_GT(ratio, 0.8);
  EXPECT_LT(ratio, 1.2);
  // No holes: every source grid point has a decoded point within a spacing.
  for (int y = 0; y < 40; y += 3) {
    for (int x = 0; x < 40; x += 3) {
      const Vec3f g(static_cast<float>(x), static_cast<float>(y), 0);
      float best = 1e9f;
      for (const Vec3f& p : f.all.positions) best = std::min(best, (p - g).norm());
      EXPECT_LT(best, 1.0f) << x << "," << y;
    }
  }
}

TEST(DecoderTest, DecodeAllIsDeterministicAcrossBlockSizes) {
  // Different block sizes change the file, never the decoded points.
  Fixture a = make_fixture(default_shape(), eight_patch_blocks());
  QuantOptions big;
  big.patches_per_block = 1000;
  big.codewords_per_block = 1000;
  Fixture b = make_fixture(default_shape(), big);
  expect_same(a.all, b.all, "block sizes");
}

TEST(DecoderTest, TrimmingUnclaimedPointsKeepsTheDecodedModel) {
  // The writer may drop the code-word points no instance claims: the default decode must not
  // change by a single bit, per patch as well as whole, while the code book shrinks.
  Fixture full = make_fixture(default_shape(), eight_patch_blocks());
  QuantOptions trim = eight_patch_blocks();
  trim.trim_unclaimed = true;
  ContainerStats stats;
  auto bytes = encode_container(full.model, trim, &stats);
  ASSERT_TRUE(bytes.ok()) << bytes.status().to_string();
  auto trimmed = CompressedModel::from_bytes(std::move(bytes).value());
  ASSERT_TRUE(trimmed.ok()) << trimmed.status().to_string();
  ASSERT_TRUE(trimmed->verify().ok());
  // Six code words shared by 200 instances: most of each sphere is some instance's cell.
  EXPECT_LT(stats.codeword_points, stats.untrimmed_codeword_points);
  auto all = trimmed->decode_all();
  ASSERT_TRUE(all.ok());
  expect_same(*all, full.all, "trimmed whole model");
  for (std::size_t k = 0; k < trimmed->patch_count(); ++k) {
    auto p = trimmed->decode_patch(k);
    ASSERT_TRUE(p.ok());
    expect_same(*p, slice(full.all, full.offsets[k], full.offsets[k + 1]), "trimmed patch");
  }
  std::uint64_t stored = 0;
  for (std::size_t c = 0; c < trimmed->codeword_count(); ++c) stored += trimmed->codeword(c)->points.size();
  EXPECT_EQ(stored, stats.codeword_points);
}

TEST(DecoderTest, ConcurrentQueriesAgree) {
  Fixture f = make_fixture(default_shape(), eight_patch_blocks());
  std::vector<std::thread> threads;
  std::atomic<int> mismatches{0};
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&, t] {
      test::TestRng rng(static_cast<std::uint32_t>(100 + t));
      for (int i = 0; i < 300; ++i) {
        // The cache's budget changed under the others' queries: they evict, and still agree.
        if (t == 0 && i % 50 == 0) f.compressed.set_cache_budget(i % 100 == 0 ? 0 : std::uint64_t{1} << 20);
        const std::size_t k = rng.below(static_cast<std::uint32_t>(f.compressed.patch_count()));
        auto p = f.compressed.decode_patch(k);
        if (!p.ok() || p->positions != slice(f.all, f.offsets[k], f.offsets[k + 1]).positions) {
          ++mismatches;
        }
      }
    });
  }
  for (auto& t : threads) t.join();
  EXPECT_EQ(mismatches.load(), 0);
}

// The cache of decoded blocks holds what its budget allows, and what it evicts is decoded again
// the same: with room for all, decoding every patch keeps every block; with a budget of 0 each
// of its shards keeps only the block it last took, fewer than the model has.
TEST(DecoderTest, BlockCacheKeepsWithinItsBudget) {
  QuantOptions small_blocks = eight_patch_blocks();
  small_blocks.patches_per_block = 2;
  Fixture f = make_fixture(default_shape(), small_blocks);
  ASSERT_EQ(f.compressed.info().sections[2].name, "patch blocks");
  ASSERT_GT(f.compressed.info().sections[2].blocks, 32u);  // more than the cache's 16 shards
  EXPECT_EQ(f.compressed.cache_budget(), CompressedModel::kDefaultCacheBudget);
  const std::uint64_t full = f.compressed.cache_bytes();
  EXPECT_GT(full, 0u);
  EXPECT_EQ(f.compressed.cache_peak_bytes(), full);  // nothing evicted
  f.compressed.set_cache_budget(0);  // evicts at once
  const std::uint64_t kept = f.compressed.cache_bytes();
  EXPECT_LT(kept, full);
  EXPECT_EQ(f.compressed.cache_peak_bytes(), full);
  f.compressed.reset_cache_peak();
  EXPECT_EQ(f.compressed.cache_peak_bytes(), kept);
  for (int round = 0; round < 2; ++round) {
    for (std::size_t k = 0; k < f.compressed.patch_count(); ++k) {
      auto p = f.compressed.decode_patch(k);
      ASSERT_TRUE(p.ok());
      expect_same(*p, slice(f.all, f.offsets[k], f.offsets[k + 1]), "patch " + std::to_string(k));
    }
    EXPECT_LT(f.compressed.cache_bytes(), full);
  }
  EXPECT_EQ(f.compressed.cache_budget(), 0u);
}

// However large its blocks against its budget, the cache holds at most the budget and the block
// just inserted: its shards give up even their most recent blocks past the budget (each
// keeping one whatever the budget, 16 shards held 16 blocks), and keep them while within it.
TEST(DecoderTest, BlockCacheHoldsItsBudgetAndOneBlock) {
  BlockCache<int> cache(250);
  for (std::size_t id = 0; id < 64; ++id) {
    cache.insert(id, std::make_shared<const int>(static_cast<int>(id)), 100);
    EXPECT_LE(cache.bytes(), 350u) << "after block " << id;
    ASSERT_NE(cache.find(id), nullptr);  // the block just inserted stays
  }
  EXPECT_LE(cache.peak_bytes(), 350u);
  cache.set_budget(0);
  EXPECT_EQ(cache.bytes(), 0u);
  // Within the budget, a shard keeps a block larger than its sixteenth.
  BlockCache<int> roomy(1000);
  roomy.insert(3, std::make_shared<const int>(3), 400);
  roomy.insert(4, std::make_shared<const int>(4), 400);
  EXPECT_EQ(roomy.bytes(), 800u);
  EXPECT_NE(roomy.find(3), nullptr);
}

}  // namespace
}  // namespace sspc::codec
