// The range coder of code-word positions: exact round trips over every value range, a cost
// close to the entropy of skewed data, and streams that are cut, padded or malformed are told
// apart by the decoder.
#include "format/range_coder.hpp"

#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace sspc::codec {
namespace {

std::span<const std::byte> bytes_of(const std::string& s) {
  return std::as_bytes(std::span<const char>(s.data(), s.size()));
}

std::vector<ValueModel> value_models(int models, bool unary) {
  std::vector<ValueModel> m(static_cast<std::size_t>(models));
  if (unary) {
    for (ValueModel& v : m) v.use_unary_lengths();
  }
  return m;
}

std::string encode_values(const std::vector<std::uint32_t>& values, int models, bool unary = false) {
  std::string out;
  RangeEncoder rc(out);
  std::vector<ValueModel> m = value_models(models, unary);
  for (std::size_t i = 0; i < values.size(); ++i) m[i % m.size()].encode(rc, values[i]);
  rc.finish();
  return out;
}

// Decodes `count` values; false when the decoder says the stream was not exactly this one.
bool decode_values(const std::string& stream, std::size_t count, int models,
                   std::vector<std::uint32_t>& out, bool unary = false) {
  RangeDecoder rc(bytes_of(stream));
  std::vector<ValueModel> m = value_models(models, unary);
  out.clear();
  for (std::size_t i = 0; i < count; ++i) out.push_back(m[i % m.size()].decode(rc));
  return rc.finish();
}

// 200 random values of each bit width 0 … 16.
std::vector<std::uint32_t> every_width(std::mt19937& rng) {
  std::vector<std::uint32_t> values;
  for (int bits = 0; bits <= 16; ++bits) {
    for (int i = 0; i < 200; ++i) values.push_back(bits == 0 ? 0 : static_cast<std::uint32_t>(rng() % (1u << bits)));
  }
  return values;
}

TEST(RangeCoder, RoundTripsEveryValueWidth) {
  std::mt19937 rng(7);
  std::vector<std::uint32_t> values = every_width(rng);
  values.push_back(0xFFFF);
  values.push_back(1);
  const std::string stream = encode_values(values, 3);
  std::vector<std::uint32_t> decoded;
  ASSERT_TRUE(decode_values(stream, values.size(), 3, decoded));
  EXPECT_EQ(decoded, values);
}

// Version 7's lengths in unary: the same round trips, 16 included (sixteen 1s and no 0), a
// stream that a tree-coded reader does not read back, and what coding costs: a fresh model
// codes a 0 in one decision of ½ (1 bit) where the tree spends five.
TEST(RangeCoder, UnaryLengthsRoundTripAndCostOneDecisionALength) {
  std::mt19937 rng(11);
  std::vector<std::uint32_t> values = every_width(rng);
  values.push_back(0xFFFF);
  values.push_back(0x8000);
  const std::string stream = encode_values(values, 3, true);
  std::vector<std::uint32_t> decoded;
  ASSERT_TRUE(decode_values(stream, values.size(), 3, decoded, true));
  EXPECT_EQ(decoded, values);
  EXPECT_FALSE(decode_values(stream, values.size(), 3, decoded, false) && decoded == values);

  ValueModel tree, unary;
  unary.use_unary_lengths();
  EXPECT_DOUBLE_EQ(unary.cost(0), 1.0);
  EXPECT_DOUBLE_EQ(tree.cost(0), 5.0);
  EXPECT_DOUBLE_EQ(unary.cost(1), 2.0);                // 1 then 0
  EXPECT_DOUBLE_EQ(unary.cost(0xFFFF), 16.0 + 15.0);  // sixteen 1s, two modelled and 13 direct bits
  // Geometric values: the unary lengths learn them at least as well as the tree.
  std::vector<std::uint32_t> geometric;
  for (int i = 0; i < 5000; ++i) {
    std::uint32_t v = 0;
    while ((rng() & 3u) == 0 && v < 60) ++v;
    geometric.push_back(v);
  }
  EXPECT_LT(encode_values(geometric, 1, true).size(), encode_values(geometric, 1, false).size());
}

TEST(RangeCoder, SkewedDataCostsCloseToItsEntropy) {
  // Geometric values (p = 1/2 per step: entropy 2 bits) code in little more than 2 bits each;
  // a constant stream in a small fraction of a bit.
  std::mt19937 rng(3);
  std::vector<std::uint32_t> geometric;
  for (int i = 0; i < 20000; ++i) {
    std::uint32_t v = 0;
    while ((rng() & 1u) != 0 && v < 60) ++v;
    geometric.push_back(v);
  }
  const double bits = 8.0 * static_cast<double>(encode_values(geometric, 1).size()) / 20000.0;
  EXPECT_LT(bits, 2.4);
  EXPECT_GT(bits, 1.9);
  const std::vector<std::uint32_t> constant(20000, 5);
  EXPECT_LT(8.0 * static_cast<double>(encode_values(constant, 1).size()) / 20000.0, 0.25);
}

TEST(RangeCoder, CutPaddedAndMalformedStreamsAreDetected) {
  std::mt19937 rng(5);
  std::vector<std::uint32_t> values;
  for (int i = 0; i < 500; ++i) values.push_back(static_cast<std::uint32_t>(rng() % 300));
  const std::string stream = encode_values(values, 2);
  ASSERT_EQ(stream[0], '\0');  // every stream starts with the encoder's empty cache byte
  std::vector<std::uint32_t> decoded;
  for (std::size_t cut = 0; cut < stream.size(); ++cut) {
    EXPECT_FALSE(decode_values(stream.substr(0, cut), values.size(), 2, decoded)) << cut;
  }
  EXPECT_FALSE(decode_values(stream + '\0', values.size(), 2, decoded));
  std::string bad_first = stream;
  bad_first[0] = '\x01';
  EXPECT_FALSE(decode_values(bad_first, values.size(), 2, decoded));
  // Garbage never reads outside its bytes and yields values below 2^16, whatever it says.
  std::string garbage(64, '\0');
  for (char& c : garbage) c = static_cast<char>(rng());
  garbage[0] = '\0';
  decode_values(garbage, 1000, 2, decoded);
  for (std::uint32_t v : decoded) EXPECT_LT(v, 1u << 16);
}

}  // namespace
}  // namespace sspc::codec
