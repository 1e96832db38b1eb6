#include "format/range_coder.hpp"

#include <bit>

namespace sspc::codec {

void RangeEncoder::encode_direct(std::uint32_t value, int bits) {
  for (int i = bits - 1; i >= 0; --i) {
    range_ >>= 1;
    if ((value >> i) & 1u) low_ += range_;
    while (range_ < kRangeTop) {
      range_ <<= 8;
      shift_low();
    }
  }
}

void RangeEncoder::shift_low() {
  // A byte can be emitted once no carry can reach it: low is below 0xFF000000, or the carry
  // has just happened. Until then 0xFF bytes wait behind the cache.
  if (static_cast<std::uint32_t>(low_) < 0xFF000000u || (low_ >> 32) != 0) {
    const auto carry = static_cast<std::uint8_t>(low_ >> 32);
    std::uint8_t byte = cache_;
    do {
      out_.push_back(static_cast<char>(static_cast<std::uint8_t>(byte + carry)));
      byte = 0xFF;
    } while (--pending_ != 0);
    cache_ = static_cast<std::uint8_t>((low_ >> 24) & 0xFF);
  }
  ++pending_;
  low_ = (low_ & 0x00FFFFFFu) << 8;
}

void RangeEncoder::finish() {
  for (int i = 0; i < 5; ++i) shift_low();
}

RangeDecoder::RangeDecoder(std::span<const std::byte> in) : in_(in) {
  first_byte_ok_ = next() == 0;
  for (int i = 0; i < 4; ++i) code_ = (code_ << 8) | next();
}

std::uint32_t RangeDecoder::decode_direct(int bits) {
  std::uint32_t value = 0;
  for (int i = 0; i < bits; ++i) {
    range_ >>= 1;
    unsigned bit = 0;
    if (code_ >= range_) {
      code_ -= range_;
      bit = 1;
    }
    value = (value << 1) | bit;
    while (range_ < kRangeTop) {
      range_ <<= 8;
      code_ = (code_ << 8) | next();
    }
  }
  return value;
}

void ValueModel::reset() {
  length_.fill(kProbabilityHalf);
  for (auto& m : mantissa_) m.fill(kProbabilityHalf);
}

double ValueModel::cost(std::uint32_t value) const {
  const auto length = static_cast<std::uint32_t>(std::bit_width(value));
  double bits = 0;
  std::uint32_t node = 1;
  if (unary_) {
    for (std::uint32_t i = 0; i < length; ++i) bits += bit_cost(length_[i], 1);
    if (length < kMaxBits) bits += bit_cost(length_[length], 0);
  } else {
    for (int i = 4; i >= 0; --i) {
      const unsigned bit = (length >> i) & 1u;
      bits += bit_cost(length_[node], bit);
      node = (node << 1) | bit;
    }
  }
  if (length < 2) return bits;
  const int rest = static_cast<int>(length) - 1;
  const int modelled = rest < 2 ? rest : 2;
  node = 1;
  for (int i = 0; i < modelled; ++i) {
    const unsigned bit = (value >> (rest - 1 - i)) & 1u;
    bits += bit_cost(mantissa_[length][node], bit);
    node = (node << 1) | bit;
  }
  return bits + (rest - modelled);
}

void ValueModel::encode(RangeEncoder& rc, std::uint32_t value) {
  const auto length = static_cast<std::uint32_t>(std::bit_width(value));  // 0 for 0, ≤ 16
  std::uint32_t node = 1;
  if (unary_) {
    for (std::uint32_t i = 0; i < length; ++i) rc.encode(length_[i], 1);
    if (length < kMaxBits) rc.encode(length_[length], 0);
  } else {
    for (int i = 4; i >= 0; --i) {
      const unsigned bit = (length >> i) & 1u;
      rc.encode(length_[node], bit);
      node = (node << 1) | bit;
    }
  }
  if (length < 2) return;
  const int rest = static_cast<int>(length) - 1;  // bits below the leading one
  const int modelled = rest < 2 ? rest : 2;
  node = 1;
  for (int i = 0; i < modelled; ++i) {
    const unsigned bit = (value >> (rest - 1 - i)) & 1u;
    rc.encode(mantissa_[length][node], bit);
    node = (node << 1) | bit;
  }
  if (rest > modelled) rc.encode_direct(value, rest - modelled);
}

std::uint32_t ValueModel::decode(RangeDecoder& rc) {
  std::uint32_t node = 1;
  std::uint32_t length = 0;
  if (unary_) {
    // At most 16 decisions: a length cannot pass 16.
    while (length < kMaxBits && rc.decode(length_[length]) != 0) ++length;
  } else {
    for (int i = 0; i < 5; ++i) node = (node << 1) | rc.decode(length_[node]);
    length = node - 32;
  }
  if (length < 2) return length;  // 0 → 0, 1 → 1
  // A corrupt stream may code a length past 16 in the tree: clamp, the caller's range checks
  // catch the value (and the block's CRC has already failed for a corrupt stream).
  const std::uint32_t bits = length > kMaxBits ? kMaxBits : length;
  const int rest = static_cast<int>(bits) - 1;
  const int modelled = rest < 2 ? rest : 2;
  std::uint32_t value = 1;
  node = 1;
  for (int i = 0; i < modelled; ++i) {
    const unsigned bit = rc.decode(mantissa_[bits][node]);
    node = (node << 1) | bit;
    value = (value << 1) | bit;
  }
  if (rest > modelled) value = (value << (rest - modelled)) | rc.decode_direct(rest - modelled);
  return value;
}

}  // namespace sspc::codec
