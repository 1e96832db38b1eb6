// Per-point attributes (docs/FORMAT.md, "Attributes"): the coder's round trips, bounds and
// hostile streams, and through the encoder and the decoder: every decoded point carries its
// nearest source point's values, in whole, patch and box decodes alike, also where patches are
// instances of another patch's code word.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "format/attribute_coder.hpp"
#include "sspc/compressed_model.hpp"
#include "sspc/encoder.hpp"
#include "sspc/neighbours.hpp"
#include "sspc/synthetic.hpp"
#include "test_util.hpp"

namespace sspc::codec {
namespace {

// A wavy sheet sampled on a jittered grid, in the order a scanner would give it, with every
// attribute: colours from the place (a gradient, a band with a hard edge) plus noise, intensity
// likewise, a classification by region and returns.
PointCloud attributed_sheet(std::size_t side, std::uint64_t seed) {
  synthetic::Rng rng(seed);
  PointCloud c;
  for (std::size_t i = 0; i < side; ++i) {
    for (std::size_t j = 0; j < side; ++j) {
      const float x = static_cast<float>(i) + static_cast<float>(rng.uniform(-0.2, 0.2));
      const float y = static_cast<float>(j) + static_cast<float>(rng.uniform(-0.2, 0.2));
      c.positions.emplace_back(x, y, 2.0f * std::sin(0.15f * x) * std::cos(0.1f * y));
      const bool band = std::fmod(x + 0.5f * y, 16.0f) < 5.0f;
      const double xd = x, yd = y;
      auto noisy = [&](double v) {
        return static_cast<std::uint8_t>(std::clamp(std::lround(v + 2.0 * rng.gaussian()), 0L, 255L));
      };
      c.colours.push_back({noisy(60 + 2.5 * xd + (band ? 80 : 0)), noisy(90 + 1.5 * yd),
                           noisy(band ? 40 : 160)});
      c.las.intensity.push_back(static_cast<std::uint16_t>(
          std::clamp(std::lround(30000 + 400 * xd - 200 * yd + 500 * rng.gaussian()), 0L, 65535L)));
      c.las.classification.push_back(static_cast<std::uint8_t>(band ? 6 : (x < y ? 2 : 5)));
      const auto returns = static_cast<std::uint8_t>(1 + (i * 7 + j) % 3);
      c.las.number_of_returns.push_back(returns);
      c.las.return_number.push_back(static_cast<std::uint8_t>(1 + (i + j) % returns));
    }
  }
  return c;
}

AttributeParams all_channels(int colour_step, int intensity_step) {
  AttributeParams p;
  p.channels = kKnownChannels;
  p.colour_step = colour_step;
  p.intensity_step = intensity_step;
  return p;
}

PointCloud coder_round_trip(const PointCloud& in, const AttributeParams& params,
                            std::size_t* bytes = nullptr) {
  AttributeReferences refs;
  refs.find(in.positions);
  PointCloud out;
  for (int bit = 0; bit < kChannelCount; ++bit) {
    const auto channel = static_cast<std::uint8_t>(1u << bit);
    const std::string stream = encode_attribute_stream(channel, params, refs, in);
    if (bytes != nullptr) *bytes += stream.size();
    const Status s = decode_attribute_stream(channel, params, refs, std::as_bytes(std::span(stream)), out);
    EXPECT_TRUE(s.ok()) << s.to_string();
  }
  return out;
}

TEST(AttributeCoder, LosslessStepsRoundTripEveryChannel) {
  PointCloud in = attributed_sheet(30, 1);
  in.las.intensity[0] = 65535;  // both ends of the range, and a jump past the escape
  in.las.intensity[1] = 0;
  in.las.classification[2] = 255;
  in.las.return_number[3] = 15;
  in.las.number_of_returns[3] = 15;
  std::size_t bytes = 0;
  const PointCloud out = coder_round_trip(in, all_channels(1, 1), &bytes);
  EXPECT_TRUE(out.colours == in.colours);
  EXPECT_TRUE(out.las.intensity == in.las.intensity);
  EXPECT_TRUE(out.las.classification == in.las.classification);
  EXPECT_TRUE(out.las.return_number == in.las.return_number);
  EXPECT_TRUE(out.las.number_of_returns == in.las.number_of_returns);
  // Prediction pays: the colours' noise (σ = 2 levels) is most of what is left. Raw, the four
  // channels are 24 + 16 + 8 + 8 = 56 bits a point.
  EXPECT_LT(8.0 * static_cast<double>(bytes) / static_cast<double>(in.size()), 32.0);
}

// Version 7's value models, lengths in unary: the same values back, in fewer bytes at a coarse
// step (its residuals are mostly 0 and ±1), and a stream that the tree-coded reader of versions
// 3 to 6 does not read back as the same values.
TEST(AttributeCoder, Version7UnaryLengthsRoundTripEveryChannel) {
  PointCloud in = attributed_sheet(30, 3);
  in.las.intensity[0] = 65535;
  in.las.classification[2] = 255;
  for (const int colour_step : {1, 24}) {
    SCOPED_TRACE("colour step " + std::to_string(colour_step));
    AttributeParams tree = all_channels(colour_step, 1), unary = tree;
    unary.unary_lengths = true;
    std::size_t tree_bytes = 0, unary_bytes = 0;
    const PointCloud out = coder_round_trip(in, unary, &unary_bytes);
    coder_round_trip(in, tree, &tree_bytes);
    EXPECT_TRUE(out.las.intensity == in.las.intensity);
    EXPECT_TRUE(out.las.classification == in.las.classification);
    EXPECT_TRUE(out.las.return_number == in.las.return_number);
    if (colour_step == 1) {
      EXPECT_TRUE(out.colours == in.colours);
    } else {
      EXPECT_EQ(out.colours, coder_round_trip(in, tree).colours);  // the same reconstruction
      EXPECT_LT(unary_bytes, tree_bytes);
    }
  }
  AttributeReferences refs;
  refs.find(in.positions);
  AttributeParams unary = all_channels(1, 1);
  unary.unary_lengths = true;
  const std::string stream = encode_attribute_stream(kChannelIntensity, unary, refs, in);
  PointCloud misread;
  const Status s =
      decode_attribute_stream(kChannelIntensity, all_channels(1, 1), refs, std::as_bytes(std::span(stream)), misread);
  EXPECT_FALSE(s.ok() && misread.las.intensity == in.las.intensity);
}

TEST(AttributeCoder, LossyStepsStayWithinHalfAStep) {
  const PointCloud in = attributed_sheet(30, 2);
  const PointCloud out = coder_round_trip(in, all_channels(8, 100));
  ASSERT_EQ(out.las.intensity.size(), in.size());
  int worst_intensity = 0;
  double colour_error = 0;
  for (std::size_t i = 0; i < in.size(); ++i) {
    worst_intensity = std::max(worst_intensity, std::abs(out.las.intensity[i] - in.las.intensity[i]));
    colour_error += std::abs(out.colours[i].r - in.colours[i].r) +
                    std::abs(out.colours[i].g - in.colours[i].g) +
                    std::abs(out.colours[i].b - in.colours[i].b);
  }
  EXPECT_LE(worst_intensity, 50);
  EXPECT_GT(worst_intensity, 0);
  // Each YCoCg component is within 4; back in RGB the mean error is about two levels.
  EXPECT_LT(colour_error / (3.0 * static_cast<double>(in.size())), 4.0);
  EXPECT_TRUE(out.las.classification == in.las.classification);  // lossless whatever the steps
}

TEST(AttributeCoder, ReferencesAreTheThreeNearestOfTheLast64) {
  std::vector<Vec3f> p;
  for (int i = 0; i < 100; ++i) p.emplace_back(static_cast<float>(i), 0.0f, 0.0f);
  p[99] = Vec3f(10.2f, 0, 0);  // 10 is nearest, but the window is points 35..98
  p.emplace_back(50.5f, 1.0f, 0.0f);  // 50 and 51 tie, as do 49 and 52: the later first
  AttributeReferences refs;
  refs.find(p);
  EXPECT_EQ(refs.count[0], 0);
  EXPECT_EQ(refs.count[1], 1);
  EXPECT_EQ(refs.count[99], 3);
  EXPECT_EQ(refs.index[99][0], 35u);
  EXPECT_EQ(refs.index[99][1], 36u);
  EXPECT_EQ(refs.index[99][2], 37u);
  EXPECT_EQ(refs.index[100][0], 51u);
  EXPECT_EQ(refs.index[100][1], 50u);
  EXPECT_EQ(refs.index[100][2], 52u);
}

TEST(AttributeCoder, HostileStreamsFailWithoutReadingPastThem) {
  const PointCloud in = attributed_sheet(20, 3);
  AttributeReferences refs;
  refs.find(in.positions);
  const AttributeParams params = all_channels(1, 1);
  for (std::uint8_t channel : {kChannelColour, kChannelIntensity, kChannelClassification, kChannelReturns}) {
    std::string stream = encode_attribute_stream(channel, params, refs, in);
    PointCloud out;
    // Cut short, and one byte too many: both refused.
    EXPECT_FALSE(decode_attribute_stream(channel, params, refs,
                                         std::as_bytes(std::span(stream)).first(stream.size() / 2), out).ok());
    stream.push_back('\0');
    out = PointCloud();
    EXPECT_FALSE(decode_attribute_stream(channel, params, refs, std::as_bytes(std::span(stream)), out).ok());
  }
  // Random bytes: an error or values in range, never a crash (ASan and UBSan run this too).
  synthetic::Rng rng(9);
  for (int trial = 0; trial < 200; ++trial) {
    std::string junk(1 + rng.next_u64() % 64, '\0');
    for (char& b : junk) b = static_cast<char>(rng.next_u64());
    junk[0] = '\0';
    PointCloud out;
    const auto channel = static_cast<std::uint8_t>(1u << (trial % 4));
    if (decode_attribute_stream(channel, params, refs, std::as_bytes(std::span(junk)), out).ok()) {
      EXPECT_LE(out.colours.size() + out.las.intensity.size() + out.las.classification.size() +
                    out.las.return_number.size(), in.size());
    }
  }
}

// Through the public API.
struct Encoded {
  test::TempDir dir;
  PointCloud source;
  EncodeStats stats;
  std::filesystem::path path() const { return dir.path() / "m.sspc"; }
};

void encode_into(Encoded& e, const EncodeOptions& options) {
  auto stats = encode(e.source, e.path(), options);
  ASSERT_TRUE(stats.ok()) << stats.status().to_string();
  e.stats = *stats;
}

// Every decoded point against its nearest source point, which is what the encoder coded.
void expect_nearest_source_values(const PointCloud& source, const PointCloud& decoded, bool exact_colour) {
  const KdTree3 tree(source.positions);
  ASSERT_EQ(decoded.colours.size(), decoded.size());
  ASSERT_EQ(decoded.las.classification.size(), decoded.size());
  std::size_t wrong_class = 0, wrong_returns = 0, wrong_intensity = 0, wrong_colour = 0;
  for (std::size_t i = 0; i < decoded.size(); ++i) {
    float d2 = 0;
    const std::uint32_t s = tree.nearest(decoded.positions[i], &d2);
    wrong_class += decoded.las.classification[i] != source.las.classification[s];
    wrong_returns += decoded.las.return_number[i] != source.las.return_number[s] ||
                     decoded.las.number_of_returns[i] != source.las.number_of_returns[s];
    wrong_intensity += decoded.las.intensity[i] != source.las.intensity[s];
    wrong_colour += exact_colour && !(decoded.colours[i] == source.colours[s]);
  }
  EXPECT_EQ(wrong_class, 0u);
  EXPECT_EQ(wrong_returns, 0u);
  EXPECT_EQ(wrong_intensity, 0u);
  EXPECT_EQ(wrong_colour, 0u);
}

TEST(Attributes, EveryDecodedPointCarriesItsPlacesValues) {
  Encoded e;
  e.source = attributed_sheet(90, 4);
  EncodeOptions o;
  o.colour_quality = 100;
  encode_into(e, o);
  EXPECT_EQ(e.stats.attributes, kAllAttributes);
  EXPECT_GT(e.stats.colour_bytes, 0u);
  EXPECT_GT(e.stats.classification_bytes, 0u);
  auto model = CompressedModel::open(e.path());
  ASSERT_TRUE(model.ok()) << model.status().to_string();
  EXPECT_EQ(model->info().attributes, kAllAttributes);
  auto all = model->decode_all();
  ASSERT_TRUE(all.ok()) << all.status().to_string();
  expect_nearest_source_values(e.source, *all, true);
}

TEST(Attributes, InstancedPatchesShowTheirOwnColours) {
  // Exact copies of one bump tile: most patches are instances of a few code words, yet each
  // decoded point has its own place's colour (per code word, every copy would show its
  // representative's).
  Encoded e;
  const PointCloud tile = synthetic::bumps(25, 1.0 / 36, 1, 0.3 / 36);
  for (int i = 0; i < 36; ++i) {
    for (int j = 0; j < 36; ++j) {
      const Vec3f offset(static_cast<float>(i) / 36, static_cast<float>(j) / 36, 0);
      for (const Vec3f& p : tile.positions) e.source.positions.push_back(p + offset);
      e.source.normals.insert(e.source.normals.end(), tile.normals.begin(), tile.normals.end());
    }
  }
  synthetic::Rng rng(5);
  for (const Vec3f& p : e.source.positions) {
    e.source.colours.push_back({static_cast<std::uint8_t>(std::clamp(p.x() * 250.f, 0.f, 255.f)),
                                static_cast<std::uint8_t>(std::clamp(p.y() * 250.f, 0.f, 255.f)), 7});
    e.source.las.intensity.push_back(static_cast<std::uint16_t>(rng.next_u64()));
    e.source.las.classification.push_back(p.x() > 0.5f ? 6 : 2);
    e.source.las.return_number.push_back(1);
    e.source.las.number_of_returns.push_back(1);
  }
  // The paper's regime, where copies are matched (as in ModelBuilder's bump test).
  EncodeOptions o;
  o.patch_points = 64;
  o.epsilon = 0.5f;
  o.tau = 0.4f;
  o.step = 0.1f;
  o.colour_quality = 100;
  encode_into(e, o);
  ASSERT_GT(e.stats.codebook_ratio, 5.0);
  auto model = CompressedModel::open(e.path());
  ASSERT_TRUE(model.ok());
  auto all = model->decode_all();
  ASSERT_TRUE(all.ok());
  expect_nearest_source_values(e.source, *all, true);
}

TEST(Attributes, PatchAndBoxDecodesAgreeWithTheWholeModel) {
  Encoded e;
  e.source = attributed_sheet(70, 6);
  EncodeOptions o;
  o.colour_quality = 60;
  o.intensity_step = 16;
  o.patch_points = 256;
  encode_into(e, o);
  auto model = CompressedModel::open(e.path());
  ASSERT_TRUE(model.ok());
  auto all = model->decode_all();
  ASSERT_TRUE(all.ok());
  PointCloud joined;
  for (std::size_t k = 0; k < model->patch_count(); ++k) {
    auto p = model->decode_patch(k);
    ASSERT_TRUE(p.ok());
    joined.positions.insert(joined.positions.end(), p->positions.begin(), p->positions.end());
    joined.colours.insert(joined.colours.end(), p->colours.begin(), p->colours.end());
    joined.las.intensity.insert(joined.las.intensity.end(), p->las.intensity.begin(), p->las.intensity.end());
  }
  EXPECT_TRUE(joined.positions == all->positions);
  EXPECT_TRUE(joined.colours == all->colours);
  EXPECT_TRUE(joined.las.intensity == all->las.intensity);

  const Box3f box(Vec3f(10, 20, -5), Vec3f(40, 45, 5));
  auto inside = model->decode_box(box);
  ASSERT_TRUE(inside.ok());
  PointCloud expected;
  for (std::size_t i = 0; i < all->size(); ++i) {
    if (!box.contains(all->positions[i])) continue;
    expected.positions.push_back(all->positions[i]);
    expected.colours.push_back(all->colours[i]);
    expected.las.classification.push_back(all->las.classification[i]);
  }
  ASSERT_GT(expected.size(), 100u);
  EXPECT_TRUE(inside->positions == expected.positions);
  EXPECT_TRUE(inside->colours == expected.colours);
  EXPECT_TRUE(inside->las.classification == expected.las.classification);
  EXPECT_EQ(inside->las.intensity.size(), inside->size());
}

TEST(Attributes, NoneKeepsOnlyTheGeometry) {
  Encoded e;
  e.source = attributed_sheet(40, 7);
  EncodeOptions o;
  o.attributes = 0;
  encode_into(e, o);
  auto model = CompressedModel::open(e.path());
  ASSERT_TRUE(model.ok());
  EXPECT_EQ(model->info().attributes, 0u);
  EXPECT_FALSE(model->info().has_colours);
  auto all = model->decode_all();
  ASSERT_TRUE(all.ok());
  EXPECT_FALSE(all->has_colours());
  EXPECT_TRUE(all->las.empty());
}

TEST(Attributes, DamageInTheAttributesPartIsNamed) {
  Encoded e;
  e.source = attributed_sheet(40, 8);
  encode_into(e, EncodeOptions());
  std::ifstream in(e.path(), std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto model = CompressedModel::from_bytes(bytes);
  ASSERT_TRUE(model.ok());
  const std::uint64_t part = model->info().attribute_bytes;
  ASSERT_GT(part, 40u);
  // The part ends the file (no metadata here). A byte of the last block, then of the table.
  const std::size_t part_start = bytes.size() - part;
  std::string damaged = bytes;
  damaged[bytes.size() - 3] = static_cast<char>(damaged[bytes.size() - 3] ^ 0x40);
  auto block_damaged = CompressedModel::from_bytes(damaged);
  ASSERT_TRUE(block_damaged.ok());
  auto all = block_damaged->decode_all();
  ASSERT_FALSE(all.ok());
  EXPECT_NE(all.status().message().find("attributes, block"), std::string::npos) << all.status().to_string();
  EXPECT_NE(all.status().message().find("CRC32"), std::string::npos);
  damaged = bytes;
  damaged[part_start + 9] = static_cast<char>(damaged[part_start + 9] ^ 0x01);
  auto table_damaged = CompressedModel::from_bytes(damaged);
  ASSERT_FALSE(table_damaged.ok());
  EXPECT_NE(table_damaged.status().message().find("attributes table CRC32"), std::string::npos)
      << table_damaged.status().to_string();
}

}  // namespace
}  // namespace sspc::codec
