// A small, slow, correct LZF compressor for building PCD binary_compressed test files: greedy
// longest match over the whole 8 KiB window, literal runs of up to 32 bytes.
#pragma once

#include <algorithm>
#include <cstddef>
#include <string>

namespace sspc::test {

inline std::string lzf_compress(const std::string& in) {
  std::string out;
  std::string literal;
  const auto flush = [&] {
    for (std::size_t at = 0; at < literal.size(); at += 32) {
      const std::size_t n = std::min<std::size_t>(32, literal.size() - at);
      out += static_cast<char>(n - 1);
      out.append(literal, at, n);
    }
    literal.clear();
  };
  std::size_t i = 0;
  while (i < in.size()) {
    std::size_t best_len = 0, best_distance = 0;
    for (std::size_t d = 1; d <= std::min<std::size_t>(i, 8192); ++d) {
      std::size_t len = 0;
      while (i + len < in.size() && len < 264 && in[i + len] == in[i - d + len]) ++len;
      if (len > best_len) {
        best_len = len;
        best_distance = d;
      }
    }
    if (best_len < 3) {
      literal += in[i++];
      continue;
    }
    flush();
    const std::size_t len = best_len - 2;
    const std::size_t off = best_distance - 1;
    if (len < 7) {
      out += static_cast<char>((len << 5) | (off >> 8));
    } else {
      out += static_cast<char>((7 << 5) | (off >> 8));
      out += static_cast<char>(len - 7);
    }
    out += static_cast<char>(off & 0xff);
    i += best_len;
  }
  flush();
  return out;
}

}  // namespace sspc::test
