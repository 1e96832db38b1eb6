// An adaptive binary range coder and the value models built on it, for the code words' point
// streams (docs/FORMAT.md, "Range coding").
//
// Why our own entropy coder: code-book blocks are small (tens of code words, so that one patch
// decodes without reading much else) and hold three streams of small integers whose
// distributions differ. zstd codes all literals of a block with one Huffman table sent in the
// block: the table costs as much as the gain at this size, and the streams share it. An
// adaptive coder needs no table, adapts per stream and context, and codes fractions of a bit.
//
// The design is the classic carry-less-cache binary range coder (as in LZMA): a 32-bit range,
// 11-bit probabilities that move 1/16 of the way to each coded bit, bytes out through a one-byte
// cache that absorbs carries. Values are coded as their bit length (a bit tree of 5 binary
// decisions, or in unary in format version 7) followed by the bits below the leading
// one, the first two of them modelled.
//
// The decoder is safe on untrusted input: it never reads outside its span (reads past the end
// see zeros and are counted), and finish() tells whether exactly the encoder's bytes were used.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

#include "core/check.hpp"

namespace sspc::codec {

inline constexpr int kProbabilityBits = 11;
inline constexpr std::uint16_t kProbabilityHalf = 1u << (kProbabilityBits - 1);
inline constexpr int kAdaptationShift = 4;
// The range is renormalised (a byte shifted in or out) whenever it falls below this.
inline constexpr std::uint32_t kRangeTop = 1u << 24;

// Moves the probability-of-zero `p` 1/16 of the way towards the bit just coded.
inline void adapt_probability(std::uint16_t& p, unsigned bit) {
  if (bit == 0) {
    p = static_cast<std::uint16_t>(p + (((1u << kProbabilityBits) - p) >> kAdaptationShift));
  } else {
    p = static_cast<std::uint16_t>(p - (p >> kAdaptationShift));
  }
}

class RangeEncoder {
 public:
  explicit RangeEncoder(std::string& out) : out_(out) {}
  // Codes `bit` with probability-of-zero `p`, then adapts `p`.
  void encode(std::uint16_t& p, unsigned bit);
  // Codes `bit` with probability-of-zero `p` in (0, 2048), which stays as it is.
  void encode_with(std::uint32_t p, unsigned bit);
  // Codes the low `bits` bits of `value` as equiprobable bits, the most significant first.
  void encode_direct(std::uint32_t value, int bits);
  // Flushes the last bytes; the encoder must not be used after.
  void finish();

 private:
  void shift_low();
  std::string& out_;
  std::uint64_t low_ = 0;
  std::uint32_t range_ = 0xFFFFFFFFu;
  std::uint8_t cache_ = 0;
  std::uint64_t pending_ = 1;  // bytes held back: the cache and then 0xFF bytes
};

// The per-bit steps are defined in this header, inline: out of line, the call to decode()
// was 24% of decoding dragon_scans (perf, decode_bench), most of it the call itself.
class RangeDecoder {
 public:
  explicit RangeDecoder(std::span<const std::byte> in);
  unsigned decode(std::uint16_t& p);
  // A bit of probability-of-zero `p` in (0, 2048), which stays as it is.
  unsigned decode_with(std::uint32_t p);
  std::uint32_t decode_direct(int bits);
  // True when the stream was well formed (its first byte is 0, as every encoder writes it) and
  // the decoder used exactly all of its bytes.
  bool finish() const { return first_byte_ok_ && position_ == in_.size() && overrun_ == 0; }
  // True once the decoder has read past its span: no well-formed stream does, so a caller may
  // stop there (it bounds the work a hostile stream can ask for).
  bool overrun() const { return overrun_ != 0; }

 private:
  std::uint8_t next();
  std::span<const std::byte> in_;
  std::size_t position_ = 0;
  std::size_t overrun_ = 0;
  std::uint32_t range_ = 0xFFFFFFFFu;
  std::uint32_t code_ = 0;
  bool first_byte_ok_ = false;
};

// An adaptive model of integers below 2^16: bit length by a 5-level bit tree (or, in format
// version 7's columns and attributes, in unary), then the two bits after the leading one
// modelled per length, the rest direct.
//
// Why unary lengths in version 7's columns: their values are mostly short (dragon_scans level 5:
// lengths 0, 1 and 2 are 60%, 19% and 11% of them), and in unary each of those lengths is one
// adaptive decision of its own that learns from every value, where the tree's upper levels learn
// slowly from decisions that are almost always 0. Measured on every code word of the range scans,
// the files 0.5-0.75% smaller at level 5 and 1.6-2.7% at level 9; a painted bunny's colours
// 1.8-19% smaller (docs/FORMAT_NOTES.md, "Value lengths in unary").
class ValueModel {
 public:
  ValueModel() { reset(); }
  // Codes the bit length in unary from now on (version 7's columns and attributes;
  // docs/FORMAT.md, "Range coding"): for each length below L a 1 with its own probability,
  // then a 0 unless L = 16.
  void use_unary_lengths() { unary_ = true; }
  void reset();
  void encode(RangeEncoder& rc, std::uint32_t value);
  std::uint32_t decode(RangeDecoder& rc);
  // What encode() would cost now, in bits: an encoder's estimate, which changes nothing.
  double cost(std::uint32_t value) const;

  static constexpr int kMaxBits = 16;

 private:
  std::array<std::uint16_t, 32> length_;
  std::array<std::array<std::uint16_t, 4>, kMaxBits + 1> mantissa_;
  bool unary_ = false;
};

// What coding `bit` with probability p of a 0 costs, in bits (an encoder's estimate).
// From a table of the same values (−log2 of k / 2^kProbabilityBits: 1 − p / 2^bits is exactly
// (2^bits − p) / 2^bits): computed each time, the logarithm was 1% of autzen's encode.
inline double bit_cost(std::uint16_t p, unsigned bit) {
  constexpr std::uint32_t kOne = 1u << kProbabilityBits;
  static const std::array<double, kOne + 1> table = [] {
    std::array<double, kOne + 1> t{};
    for (std::uint32_t k = 0; k <= kOne; ++k) t[k] = -std::log2(static_cast<double>(k) / static_cast<double>(kOne));
    return t;
  }();
  SSPC_DCHECK(p <= kOne);  // models start at half and adapt_probability keeps them below kOne
  return table[bit == 0 ? p : kOne - p];
}

inline void RangeEncoder::encode_with(std::uint32_t p, unsigned bit) {
  const std::uint32_t bound = (range_ >> kProbabilityBits) * p;
  if (bit == 0) {
    range_ = bound;
  } else {
    low_ += bound;
    range_ -= bound;
  }
  while (range_ < kRangeTop) {
    range_ <<= 8;
    shift_low();
  }
}

inline void RangeEncoder::encode(std::uint16_t& p, unsigned bit) {
  encode_with(p, bit);
  adapt_probability(p, bit);
}

inline std::uint8_t RangeDecoder::next() {
  if (position_ < in_.size()) return static_cast<std::uint8_t>(in_[position_++]);
  ++overrun_;
  return 0;
}

inline unsigned RangeDecoder::decode_with(std::uint32_t p) {
  const std::uint32_t bound = (range_ >> kProbabilityBits) * p;
  unsigned bit;
  if (code_ < bound) {
    range_ = bound;
    bit = 0;
  } else {
    code_ -= bound;
    range_ -= bound;
    bit = 1;
  }
  while (range_ < kRangeTop) {
    range_ <<= 8;
    code_ = (code_ << 8) | next();
  }
  return bit;
}

inline unsigned RangeDecoder::decode(std::uint16_t& p) {
  const unsigned bit = decode_with(p);
  adapt_probability(p, bit);
  return bit;
}

}  // namespace sspc::codec
