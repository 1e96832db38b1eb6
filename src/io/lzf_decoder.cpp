#include "io/lzf_decoder.hpp"

#include <cstring>
#include <string>

namespace sspc::io {

namespace {

Status lzf_error(std::size_t offset, const std::string& what) {
  return corrupt("byte offset " + std::to_string(offset) + ": LZF stream: " + what);
}

}  // namespace

Status lzf_decompress(std::span<const std::byte> in, std::span<std::byte> out,
                      std::size_t base_offset) {
  // Positions, not pointers: a hostile distance then cannot form an out-of-range pointer.
  std::size_t ip = 0;
  std::size_t op = 0;
  const std::size_t in_size = in.size();
  const std::size_t out_size = out.size();
  while (ip < in_size) {
    const std::size_t at = base_offset + ip;
    const auto ctrl = std::to_integer<std::size_t>(in[ip++]);
    if (ctrl < 32) {
      const std::size_t len = ctrl + 1;
      if (len > in_size - ip) {
        return lzf_error(at, "a literal run of " + std::to_string(len) +
                                 " bytes runs past the end of the compressed data");
      }
      if (len > out_size - op) {
        return lzf_error(at, "the data decompresses to more than the " + std::to_string(out_size) +
                                 " bytes declared");
      }
      std::memcpy(out.data() + op, in.data() + ip, len);
      ip += len;
      op += len;
      continue;
    }
    std::size_t len = ctrl >> 5;
    if (len == 7) {
      if (ip >= in_size) return lzf_error(at, "a back-reference is cut off by the end of the data");
      len += std::to_integer<std::size_t>(in[ip++]);
    }
    if (ip >= in_size) return lzf_error(at, "a back-reference is cut off by the end of the data");
    const std::size_t distance = ((ctrl & 0x1f) << 8) + std::to_integer<std::size_t>(in[ip++]) + 1;
    len += 2;
    if (distance > op) {
      return lzf_error(at, "a back-reference reaches " + std::to_string(distance) +
                               " bytes back but only " + std::to_string(op) +
                               " bytes have been produced");
    }
    if (len > out_size - op) {
      return lzf_error(at, "the data decompresses to more than the " + std::to_string(out_size) +
                               " bytes declared");
    }
    // Byte by byte: when distance < len the copy reads bytes it has just written (a run).
    std::byte* dst = out.data() + op;
    const std::byte* src = dst - distance;
    if (distance >= len) {
      std::memcpy(dst, src, len);
    } else {
      for (std::size_t k = 0; k < len; ++k) dst[k] = src[k];
    }
    op += len;
  }
  if (op != out_size) {
    return lzf_error(base_offset + in_size, "the data decompresses to " + std::to_string(op) +
                                                " bytes, not the " + std::to_string(out_size) +
                                                " declared");
  }
  return Status();
}

}  // namespace sspc::io
