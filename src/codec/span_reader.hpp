// A bounds-checked cursor over the bytes of one decompressed block payload.
//
// Every read of container bytes goes through this reader (or checks `can_read` first, as
// meshoptimizer's decoders do), so a hostile payload cannot make the decoder read past its end.
// Failures are reported as `false` with the reader left failed; the block decoder turns that into
// one kCorrupt status naming the block, which is all a user can act on.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>

namespace sspc::codec {

class SpanReader {
 public:
  explicit SpanReader(std::span<const std::byte> data) : data_(data) {}

  std::size_t position() const { return pos_; }
  std::size_t remaining() const { return data_.size() - pos_; }
  bool can_read(std::size_t n) const { return n <= remaining(); }
  bool at_end() const { return pos_ == data_.size(); }

  // The next `n` bytes, or an empty span (and no progress) when they do not exist.
  bool take(std::size_t n, std::span<const std::byte>& out) {
    if (!can_read(n)) return false;
    out = data_.subspan(pos_, n);
    pos_ += n;
    return true;
  }

  // Unsigned LEB128, at most 10 bytes, no overflow past 64 bits, no redundant zero groups.
  bool varint(std::uint64_t& out) {
    std::uint64_t value = 0;
    for (int i = 0; i < 10; ++i) {
      if (pos_ >= data_.size()) return false;
      const auto byte = static_cast<std::uint8_t>(data_[pos_++]);
      const std::uint64_t group = byte & 0x7Fu;
      if (i == 9 && group > 1) return false;  // bits past 2^64
      value |= group << (7 * i);
      if ((byte & 0x80u) == 0) {
        if (i > 0 && group == 0) return false;  // redundant trailing zero group
        out = value;
        return true;
      }
    }
    return false;
  }

 private:
  std::span<const std::byte> data_;
  std::size_t pos_ = 0;
};

inline std::uint64_t zigzag_encode(std::int64_t s) {
  return (static_cast<std::uint64_t>(s) << 1) ^ static_cast<std::uint64_t>(s >> 63);
}
inline std::int64_t zigzag_decode(std::uint64_t u) {
  return static_cast<std::int64_t>(u >> 1) ^ -static_cast<std::int64_t>(u & 1);
}

}  // namespace sspc::codec
