// The columns of version 3's to 5's code words (docs/FORMAT.md, "The columns"): exact round
// trips of surfaces, overlapping layers, repeated points and empty code words, several code words
// sharing one block's models, in each version; a smooth surface costs what the least-squares
// prediction promises, a steep one less in version 4, a sparse tilted one less in version 5, and
// version 5's stream is pinned; the writer's choice of heights moves only first points, one step
// towards the prediction; and a hostile stream is refused without running away.
#include "format/column_coder.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "format/checksum.hpp"

namespace sspc::codec {
namespace {

// ColumnCoder.Version5StreamIsPinned's to Version7StreamIsPinned's streams (written by these
// tests when versions 5, 6 and 7 were made).
constexpr std::size_t kPinnedVersion5Bytes = 43715;
constexpr std::uint32_t kPinnedVersion5Crc = 3607470155u;
constexpr std::size_t kPinnedVersion6Bytes = 42975;
constexpr std::uint32_t kPinnedVersion6Crc = 560384068u;
constexpr std::size_t kPinnedVersion7Bytes = 42811;
constexpr std::uint32_t kPinnedVersion7Crc = 3481959976u;

using Point = std::array<std::uint32_t, 3>;
using Points = std::vector<Point>;

std::span<const std::byte> stream_bytes(const std::string& s) {
  return std::as_bytes(std::span<const char>(s.data(), s.size()));
}

void sort_raster(Points& p, bool unique) {
  std::sort(p.begin(), p.end(), [](const Point& a, const Point& b) {
    return std::tie(a[1], a[0], a[2]) < std::tie(b[1], b[0], b[2]);
  });
  if (unique) p.erase(std::unique(p.begin(), p.end()), p.end());
}

// A tilted, curved height field on a 2^bits grid, with holes and a second layer above part of
// it (an overlapping scan).
Points surface(int bits, std::uint32_t seed, bool second_layer) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  const std::uint32_t size = 1u << bits;
  Points p;
  for (std::uint32_t y = 2; y + 3 < size; ++y) {
    for (std::uint32_t x = 1; x + 2 < size; ++x) {
      if (u(rng) < 0.3) continue;
      const double h = 0.5 * size + 0.3 * (x - size / 2.0) + 0.01 * (y - 8.0) * (y - 8.0) + u(rng);
      const auto z = static_cast<std::uint32_t>(std::clamp(h, 0.0, size - 1.0));
      p.push_back({x, y, z});
      if (second_layer && x > size / 2 && z + 3 < size) p.push_back({x, y, z + 3});
    }
  }
  sort_raster(p, true);
  return p;
}

// 300 points scattered over a 2^bits grid on a gentle slope: sparse enough for cells of several
// grid columns (a positive shift), with two points in one column.
Points scattered(int bits, std::uint32_t seed) {
  std::mt19937 rng(seed);
  const std::uint32_t size = 1u << bits;
  const auto next = [&rng](std::uint32_t below) { return static_cast<std::uint32_t>(rng() % below); };
  Points p;
  for (int i = 0; i < 300; ++i) {
    const std::uint32_t x = next(size), y = next(size);
    p.push_back({x, y, (x + y) / 4 + next(3)});
  }
  p.push_back({p[0][0], p[0][1], p[0][2] + 5 < size ? p[0][2] + 5 : 0});
  sort_raster(p, true);
  return p;
}

// `w` (sorted by y, x, z) in the columns' order.
Points in_column_order(const Points& w, int bits) {
  Points out;
  for (const std::uint32_t k : column_order(w, column_shift(w, bits))) out.push_back(w[k]);
  return out;
}

// A tilted plane, z = 0.5·x + 0.2·y, voxelised: each column holds every cell the plane crosses
// over it, one or two stacked points by where the cell boundaries fall, as a coarse grid sees a
// tilted surface.
Points steep_plane(int bits) {
  const std::uint32_t size = 1u << bits;
  Points p;
  for (std::uint32_t y = 0; y < size / 2; ++y) {
    for (std::uint32_t x = 0; x < size / 2; ++x) {
      const double low = 0.5 * (x - 0.5) + 0.2 * (y - 0.5) + 2, high = low + 0.5 + 0.2;
      for (auto z = static_cast<std::uint32_t>(std::max(0.0, low)); z <= static_cast<std::uint32_t>(high); ++z) {
        if (z < size) p.push_back({x, y, z});
      }
    }
  }
  sort_raster(p, true);
  return p;
}

std::string encode_all(const std::vector<Points>& words, int bits, bool duplicates, int version = 5) {
  std::string out;
  RangeEncoder rc(out);
  ColumnModels m(version);
  for (const Points& w : words) encode_columns(rc, m, in_column_order(w, bits), bits, column_shift(w, bits), duplicates);
  rc.finish();
  return out;
}

// Decodes `words` code words; false when one fails or the stream is not exactly used.
bool decode_all(const std::string& stream, std::size_t words, int bits, bool duplicates, std::size_t max_points,
                std::vector<Points>& out, int version = 5) {
  RangeDecoder rc(stream_bytes(stream));
  ColumnModels m(version);
  out.clear();
  Points all;
  for (std::size_t i = 0; i < words; ++i) {
    const std::size_t before = all.size();
    if (!decode_columns(rc, m, bits, max_points, duplicates, all)) return false;
    out.emplace_back(all.begin() + static_cast<std::ptrdiff_t>(before), all.end());
  }
  return rc.finish();
}

TEST(ColumnCoder, RoundTripsSurfacesLayersAndEmptyCodewords) {
  for (const int version : {3, 4, 5, 6}) {
    for (const int bits : {4, 6, 9}) {
      SCOPED_TRACE(testing::Message() << "version " << version << ", " << bits << " bits");
      const std::vector<Points> words = {surface(bits, 1, false), {}, surface(bits, 2, true), scattered(bits, 3),
                                         steep_plane(bits), Points{{0, 0, 0}},
                                         Points{{(1u << bits) - 1, (1u << bits) - 1, (1u << bits) - 1}}};
      if (bits >= 6) {
        EXPECT_GT(column_shift(words[3], bits), 0);
      }
      const std::string stream = encode_all(words, bits, false, version);
      std::vector<Points> back;
      ASSERT_TRUE(decode_all(stream, words.size(), bits, false, 1u << 20, back, version));
      ASSERT_EQ(back.size(), words.size());
      for (std::size_t i = 0; i < words.size(); ++i) {
        EXPECT_EQ(back[i], in_column_order(words[i], bits)) << "code word " << i;
      }
      // Another version's models read a different stream: it must not decode to the same.
      std::vector<Points> other;
      const int other_version = version == 3 ? 4 : version - 1;
      EXPECT_FALSE(decode_all(stream, words.size(), bits, false, 1u << 20, other, other_version) && other == back);
    }
  }
}

// Version 4's contexts of "another point" by where the predicted plane reaches: on a tilted
// plane, whose columns hold one cell or two by where the boundaries fall, they foretell which,
// where version 3's slope classes see the same slope everywhere.
TEST(ColumnCoder, PlaneReachMakesTiltedSurfacesCheaper) {
  const std::vector<Points> words = {steep_plane(7)};
  const std::size_t v3 = encode_all(words, 7, false, 3).size();
  const std::size_t v4 = encode_all(words, 7, false, 4).size();
  EXPECT_LT(static_cast<double>(v4), 0.8 * static_cast<double>(v3)) << "version 3 " << v3 << " bytes, version 4 " << v4;
}

// A sparse tilted surface on cells of several columns: version 5 predicts each first height at
// the point's own column, where version 4 took every point at its cell's offset and so missed by
// the slope times the point's place in its cell; and sizes its residuals' contexts by the fit.
Points sparse_slope(int bits, std::uint32_t seed) {
  std::mt19937 rng(seed);
  const std::uint32_t size = 1u << bits;
  const auto next = [&rng](std::uint32_t below) { return static_cast<std::uint32_t>(rng() % below); };
  Points p;
  for (int i = 0; i < 3000; ++i) {
    const std::uint32_t x = next(size), y = next(size);
    p.push_back({x, y, (3 * x + y) / 4 + next(2)});
  }
  sort_raster(p, true);
  return p;
}

TEST(ColumnCoder, Version5PredictsEachHeightAtItsOwnColumn) {
  const std::vector<Points> words = {sparse_slope(10, 1), sparse_slope(10, 2)};
  ASSERT_GE(column_shift(words[0], 10), 2);
  const std::size_t v4 = encode_all(words, 10, false, 4).size();
  const std::size_t v5 = encode_all(words, 10, false, 5).size();
  // Measured: 10,520 bytes against 11,183 (most of either is the points' places in their cells).
  EXPECT_LT(static_cast<double>(v5), 0.97 * static_cast<double>(v4)) << "version 4 " << v4 << " bytes, version 5 " << v5;
}

// The pinned streams' code words, coded one after the other with one version's models.
std::string pinned_words_stream(int version) {
  const std::vector<Points> words = {surface(9, 1, false), scattered(9, 3), sparse_slope(10, 4), steep_plane(7)};
  std::string stream;
  RangeEncoder rc(stream);
  ColumnModels m(version);
  for (std::size_t i = 0; i < words.size(); ++i) {
    const int bits = i == 2 ? 10 : i == 3 ? 7 : 9;
    encode_columns(rc, m, in_column_order(words[i], bits), bits, column_shift(words[i], bits), false);
  }
  rc.finish();
  return stream;
}

// Version 5's stream, pinned: any change to its predictions or contexts changes these bytes (the
// golden files' small planes code the same stream in versions 4 and 5).
TEST(ColumnCoder, Version5StreamIsPinned) {
  const std::string stream = pinned_words_stream(5);
  EXPECT_EQ(stream.size(), kPinnedVersion5Bytes);
  EXPECT_EQ(crc32_of(stream_bytes(stream)), kPinnedVersion5Crc);
}

// Version 6's, pinned as version 5's is: any change to the secondary estimates changes it.
TEST(ColumnCoder, Version6StreamIsPinned) {
  const std::string stream = pinned_words_stream(6);
  EXPECT_EQ(stream.size(), kPinnedVersion6Bytes);
  EXPECT_EQ(crc32_of(stream_bytes(stream)), kPinnedVersion6Crc);
}

// Version 7's, pinned as version 6's is: any change to how its values code lengths changes it.
TEST(ColumnCoder, Version7StreamIsPinned) {
  const std::string stream = pinned_words_stream(7);
  EXPECT_EQ(stream.size(), kPinnedVersion7Bytes);
  EXPECT_EQ(crc32_of(stream_bytes(stream)), kPinnedVersion7Crc);
}

// Samples on a lattice of 4 × 4 columns (a scanner's grid at four columns a pitch), a few
// missing, coded one column a cell: in the rows between the lattice's, and between its points
// along a row, the ten cells see nothing occupied, as they do before a lattice point; the cells
// three columns or three rows away (version 6's secondary context) tell them apart. Version 5's
// own stream (which version 6's models must not read as the same points) is the reference.
TEST(ColumnCoder, Version6LearnsWhatTheFartherCellsForetell) {
  std::mt19937 rng(5);
  Points lattice;
  for (std::uint32_t y = 0; y < 256; y += 4) {
    for (std::uint32_t x = 0; x < 256; x += 4) {
      if (rng() % 16 != 0) lattice.push_back({x, y, 100 + (x + 2 * y) / 16});
    }
  }
  const auto code = [&](int version) {
    std::string out;
    RangeEncoder rc(out);
    ColumnModels m(version);
    for (int w = 0; w < 3; ++w) encode_columns(rc, m, lattice, 8, 0, false);
    rc.finish();
    return out;
  };
  const std::string v5 = code(5), v6 = code(6);
  EXPECT_LT(static_cast<double>(v6.size()), 0.8 * static_cast<double>(v5.size()))
      << "version 5 " << v5.size() << " bytes, version 6 " << v6.size();
  RangeDecoder rc(stream_bytes(v6));
  ColumnModels m(6);
  for (int w = 0; w < 3; ++w) {
    Points back;
    ASSERT_TRUE(decode_columns(rc, m, 8, 1u << 20, false, back));
    EXPECT_EQ(back, lattice);
  }
  EXPECT_TRUE(rc.finish());
}

// The writer's choice of heights: only a cell's first point moves, by one step towards the
// prediction, only where its true height lies on that side of its step's centre; the stream
// decodes to the moved points; the moves make the stream smaller; λ = 0 moves nothing.
TEST(ColumnCoder, ChosenHeightsMoveOneStepTowardsThePrediction) {
  // A noisy curved surface, sampled where it truly lies: each point's grid step and where in it.
  const int bits = 8;
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> noise(0, 0.6);
  Points sorted;
  std::vector<float> true_fraction;
  for (std::uint32_t y = 0; y < 256; ++y) {
    for (std::uint32_t x = 0; x < 256; ++x) {
      if (u(rng) < 0.3) continue;
      const double h = 128 + 0.3 * (x - 128.0) + 0.002 * (y - 100.0) * (y - 100.0) + noise(rng);
      sorted.push_back({x, y, static_cast<std::uint32_t>(std::floor(h))});
      true_fraction.push_back(static_cast<float>(h - std::floor(h) - 0.5));
    }
  }
  const int shift = column_shift(sorted, bits);
  ASSERT_EQ(shift, 0);
  const Points& w = sorted;  // raster order is the columns' order at shift 0
  const auto code = [&](double lambda, Points& chosen) {
    std::string out;
    RangeEncoder rc(out);
    ColumnModels m(5);
    encode_columns(rc, m, w, bits, shift, false, {true_fraction, lambda}, &chosen);
    rc.finish();
    return out;
  };
  Points same, moved;
  const std::string plain = code(0, same), chosen = code(0.05, moved);
  EXPECT_EQ(same, w);
  ASSERT_EQ(moved.size(), w.size());
  std::size_t changed = 0;
  for (std::size_t i = 0; i < w.size(); ++i) {
    EXPECT_EQ(moved[i][0], w[i][0]);
    EXPECT_EQ(moved[i][1], w[i][1]);
    if (moved[i][2] == w[i][2]) continue;
    ++changed;
    const auto d = static_cast<std::int64_t>(moved[i][2]) - static_cast<std::int64_t>(w[i][2]);
    ASSERT_EQ(std::abs(d), 1) << i;
    EXPECT_TRUE(d > 0 ? true_fraction[i] > 0 : true_fraction[i] < 0) << "moved away from where it lies: " << i;
  }
  std::printf("%zu of %zu heights moved, %zu -> %zu bytes\n", changed, w.size(), plain.size(), chosen.size());
  EXPECT_GT(changed, w.size() / 50);
  EXPECT_LT(static_cast<double>(chosen.size()), 0.99 * static_cast<double>(plain.size()));
  std::vector<Points> back;
  ASSERT_TRUE(decode_all(chosen, 1, bits, false, 1u << 20, back));
  EXPECT_EQ(back[0], moved);
}

TEST(ColumnCoder, RepeatedPointsNeedTheDuplicatesFlag) {
  Points w = surface(5, 3, true);
  const Points copy = w;
  w.insert(w.end(), copy.begin(), copy.begin() + 40);  // 40 points twice
  w.push_back(copy[7]);                                  // one three times
  sort_raster(w, false);
  const std::string stream = encode_all({w}, 5, true);
  std::vector<Points> back;
  ASSERT_TRUE(decode_all(stream, 1, 5, true, 1u << 20, back));
  ASSERT_EQ(back.size(), 1u);
  EXPECT_EQ(back[0], in_column_order(w, 5));
}

// The heights of a plane are what the least-squares prediction makes free: a tilted plane costs
// little more than its occupancy, which for a full rectangle is nearly nothing.
TEST(ColumnCoder, APlaneCostsUnderHalfABitAPoint) {
  Points plane;
  for (std::uint32_t y = 0; y < 64; ++y) {
    for (std::uint32_t x = 0; x < 64; ++x) plane.push_back({x, y, 100 + (x + 2 * y) / 3});
  }
  const std::string stream = encode_all({plane}, 8, false);
  EXPECT_LT(8.0 * static_cast<double>(stream.size()) / static_cast<double>(plane.size()), 0.5);
}

TEST(ColumnCoder, TooManyPointsAreRefused) {
  const Points w = surface(6, 4, false);
  const std::string stream = encode_all({w}, 6, false);
  std::vector<Points> back;
  EXPECT_FALSE(decode_all(stream, 1, 6, false, w.size() - 1, back));
  EXPECT_TRUE(decode_all(stream, 1, 6, false, w.size(), back));
}

// Random bytes, cut streams and a stream read with the wrong grid: refused or decoded, always
// on the grid and within the point budget, never running away.
TEST(ColumnCoder, HostileStreamsStayBounded) {
  std::mt19937 rng(7);
  const std::string good = encode_all({surface(6, 5, true), surface(6, 6, false)}, 6, false);
  std::vector<std::string> streams;
  for (std::size_t cut = 1; cut < good.size(); cut += 7) streams.push_back(good.substr(0, cut));
  for (int i = 0; i < 200; ++i) {
    std::string s(1 + rng() % 300, '\0');
    for (std::size_t k = 1; k < s.size(); ++k) s[k] = static_cast<char>(rng());
    streams.push_back(s);
  }
  for (const std::string& s : streams) {
    for (const int bits : {4, 6, 16}) {
      RangeDecoder rc(stream_bytes(s));
      ColumnModels m;
      Points out;
      const std::size_t budget = 1024 * s.size();
      for (int word = 0; word < 3; ++word) {
        if (!decode_columns(rc, m, bits, budget - std::min(budget, out.size()), word == 1, out)) break;
      }
      EXPECT_LE(out.size(), budget);
      for (const Point& p : out) {
        for (const std::uint32_t v : p) ASSERT_LT(v, 1u << bits);
      }
    }
  }
}

// The writer's cell size (cheapest_shift): column_shift's, or one size up or down where that
// codes the code word in fewer bytes with the block's models as they stand, which are left as
// they were. Over code words of many densities it codes no worse than the rule, and sometimes
// better; where the density sits between the rule's bounds it keeps the rule's.
TEST(ColumnCoder, TheWrittenShiftCodesNoWorseThanTheRulesOne) {
  const int bits = 10;
  const auto cost = [&](const ColumnModels& models, const Points& w, int shift) {
    ColumnModels copy = models;
    std::string out;
    RangeEncoder rc(out);
    Points ordered;
    for (const std::uint32_t k : column_order(w, shift)) ordered.push_back(w[k]);
    encode_columns(rc, copy, ordered, bits, shift, false);
    rc.finish();
    return out.size();
  };
  ColumnModels models(4);
  std::mt19937 rng(5);
  int changed = 0, kept = 0;
  for (int word = 0; word < 60; ++word) {
    // 400 points on a slope over a square whose side sets the density: from 1.3 to 60 grid
    // columns a point.
    const auto side = static_cast<std::uint32_t>(24 + 6 * word);
    Points w;
    for (int i = 0; i < 400; ++i) {
      const auto x = static_cast<std::uint32_t>(rng() % side), y = static_cast<std::uint32_t>(rng() % side);
      w.push_back({x, y, (x + 2 * y) / 8 + static_cast<std::uint32_t>(rng() % 3)});
    }
    sort_raster(w, true);
    const ColumnModels before = models;
    const int rule = column_shift(w, bits);
    const int chosen = cheapest_shift(models, w, bits, false);
    EXPECT_EQ(models.occupied, before.occupied) << "word " << word;
    EXPECT_LE(std::abs(chosen - rule), 1) << "word " << word;
    EXPECT_LE(cost(models, w, chosen), cost(models, w, rule)) << "word " << word << ": shift " << chosen << ", rule " << rule;
    (chosen != rule ? changed : kept) += 1;
    // The block's models move on as the writer's do, with the code word coded at its shift.
    std::string sink;
    RangeEncoder rc(sink);
    Points ordered;
    for (const std::uint32_t k : column_order(w, chosen)) ordered.push_back(w[k]);
    encode_columns(rc, models, ordered, bits, chosen, false);
  }
  EXPECT_GT(changed, 0);
  EXPECT_GT(kept, 0);
  // A density between the rule's bounds (x in [1.75, 2), docs in column_coder.cpp): the rule's
  // shift without pricing, whatever the models.
  // A point every other column each way: 39² columns for 400 points, x = 1.90 at shift 0.
  Points middle;
  for (std::uint32_t y = 0; y < 40; y += 2) {
    for (std::uint32_t x = 0; x < 40; x += 2) middle.push_back({x, y, 7});
  }
  sort_raster(middle, true);
  EXPECT_EQ(column_shift(middle, bits), 0);
  EXPECT_EQ(cheapest_shift(ColumnModels(4), middle, bits, false), 0);
}

}  // namespace
}  // namespace sspc::codec
