#include "core/byte_reader.hpp"

#include <string>

namespace sspc {

Status ByteReader::overrun(std::size_t wanted) const {
  return corrupt("truncated data at byte offset " + std::to_string(offset()) + ": needs " +
                 std::to_string(wanted) + " bytes, " + std::to_string(remaining()) + " remain");
}

Status ByteReader::skip_items(std::uint64_t count, std::size_t item_size) {
  if (item_size == 0 || count == 0) return Status();
  if (count > remaining() / item_size) {
    return corrupt("truncated data at byte offset " + std::to_string(offset()) + ": " +
                   std::to_string(count) + " items of " + std::to_string(item_size) +
                   " bytes do not fit in the " + std::to_string(remaining()) +
                   " bytes that remain");
  }
  pos_ += static_cast<std::size_t>(count) * item_size;
  return Status();
}

Status ByteReader::seek(std::size_t position) {
  if (position > data_.size()) {
    return corrupt("seek to byte offset " + std::to_string(base_offset_ + position) +
                   " past the end of the data at byte offset " +
                   std::to_string(base_offset_ + data_.size()));
  }
  pos_ = position;
  return Status();
}

Status ByteReader::read_varint(std::uint64_t& out) {
  const std::size_t start = offset();
  std::uint64_t value = 0;
  for (int i = 0; i < 10; ++i) {
    if (at_end()) return overrun(1);
    const auto byte = static_cast<std::uint8_t>(data_[pos_++]);
    const std::uint64_t group = byte & 0x7Fu;
    if (i == 9 && group > 1) break;  // bits past 2^64
    value |= group << (7 * i);
    if ((byte & 0x80u) == 0) {
      if (i > 0 && group == 0) break;  // redundant trailing zero group
      out = value;
      return Status();
    }
  }
  return corrupt("malformed varint at byte offset " + std::to_string(start));
}

}  // namespace sspc
