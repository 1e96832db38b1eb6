// A bounds-checked cursor over bytes in memory: the one way sspc reads binary data it did not
// write itself (PLY and PCD bodies today, .sspc containers later).
//
// Every read checks that the bytes exist and reports an overrun as kCorrupt with the byte
// offset, so a decoder built on it cannot read past its input whatever the input says. The
// offsets it reports are file offsets when the reader is given the span's position in the file
// (`base_offset`), which is what a user needs to find the problem with a hex editor.
//
// Hot loops that have already checked a whole block with `can_read()` may decode values from it
// with the unchecked `load<T>()`; everything else goes through `read<T>()`.
#pragma once

#include <bit>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <type_traits>

#include "sspc/status.hpp"

namespace sspc {

enum class Endian { kLittle, kBig };

inline constexpr Endian kNativeEndian =
    std::endian::native == std::endian::little ? Endian::kLittle : Endian::kBig;

// Types a ByteReader can decode: fixed-size integers and IEEE floats.
template <typename T>
concept ByteReadable = (std::is_integral_v<T> && !std::is_same_v<T, bool>) ||
                       std::is_same_v<T, float> || std::is_same_v<T, double>;

namespace byte_reader_detail {

template <typename U>
constexpr U byteswap(U v) {
  if constexpr (sizeof(U) == 1) {
    return v;
  } else if constexpr (sizeof(U) == 2) {
    return static_cast<U>(__builtin_bswap16(v));
  } else if constexpr (sizeof(U) == 4) {
    return static_cast<U>(__builtin_bswap32(v));
  } else {
    static_assert(sizeof(U) == 8);
    return static_cast<U>(__builtin_bswap64(v));
  }
}

template <std::size_t N>
struct UnsignedOfSize;
template <>
struct UnsignedOfSize<1> {
  using type = std::uint8_t;
};
template <>
struct UnsignedOfSize<2> {
  using type = std::uint16_t;
};
template <>
struct UnsignedOfSize<4> {
  using type = std::uint32_t;
};
template <>
struct UnsignedOfSize<8> {
  using type = std::uint64_t;
};

}  // namespace byte_reader_detail

// Decodes a T stored at `p` in byte order `endian`. Unchecked: the caller has verified that
// sizeof(T) bytes exist at `p`. No alignment is required.
template <ByteReadable T>
inline T load(const std::byte* p, Endian endian) {
  using U = typename byte_reader_detail::UnsignedOfSize<sizeof(T)>::type;
  U bits;
  std::memcpy(&bits, p, sizeof(T));
  if (endian != kNativeEndian) bits = byte_reader_detail::byteswap(bits);
  return std::bit_cast<T>(bits);
}

class ByteReader {
 public:
  ByteReader() = default;
  // `base_offset` is the position of `data` in the enclosing file; offsets in errors and from
  // offset() include it.
  explicit ByteReader(std::span<const std::byte> data, std::size_t base_offset = 0)
      : data_(data), base_offset_(base_offset) {}

  // Position of the next byte to read, counted from the start of the file.
  std::size_t offset() const { return base_offset_ + pos_; }
  // Position within the span this reader was given.
  std::size_t position() const { return pos_; }
  std::size_t size() const { return data_.size(); }
  std::size_t remaining() const { return data_.size() - pos_; }
  bool at_end() const { return pos_ == data_.size(); }
  bool can_read(std::size_t n) const { return n <= remaining(); }

  // The unread bytes, without consuming them.
  std::span<const std::byte> rest() const { return data_.subspan(pos_); }
  const std::byte* current() const { return data_.data() + pos_; }

  template <ByteReadable T>
  StatusOr<T> read(Endian endian = Endian::kLittle) {
    T value{};
    SSPC_RETURN_IF_ERROR(read_into(value, endian));
    return value;
  }

  // The same without the StatusOr wrapper, for loops that read many values.
  template <ByteReadable T>
  Status read_into(T& out, Endian endian = Endian::kLittle) {
    if (!can_read(sizeof(T))) return overrun(sizeof(T));
    out = load<T>(current(), endian);
    pos_ += sizeof(T);
    return Status();
  }

  // The next `n` bytes as a span into the underlying data.
  StatusOr<std::span<const std::byte>> read_bytes(std::size_t n) {
    if (!can_read(n)) return overrun(n);
    std::span<const std::byte> out = data_.subspan(pos_, n);
    pos_ += n;
    return out;
  }

  Status skip(std::size_t n) {
    if (!can_read(n)) return overrun(n);
    pos_ += n;
    return Status();
  }

  // Skips `count` items of `item_size` bytes, checking the product for overflow first so that a
  // hostile count cannot wrap around to a small skip.
  Status skip_items(std::uint64_t count, std::size_t item_size);

  // Moves to `position` within the span (not a file offset); at most size().
  Status seek(std::size_t position);

  // An unsigned LEB128 varint (src/core/varint.hpp writes them): at most 10 bytes, nothing
  // past 64 bits, no redundant trailing zero group. On failure the position is unspecified.
  Status read_varint(std::uint64_t& out);

  // The kCorrupt status an overrun of `wanted` bytes at the current position produces; public
  // so that callers checking a block with can_read() report it the same way.
  Status overrun(std::size_t wanted) const;

 private:
  std::span<const std::byte> data_;
  std::size_t base_offset_ = 0;
  std::size_t pos_ = 0;
};

}  // namespace sspc
