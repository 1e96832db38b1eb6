// The LZF decompressor against streams built by hand and by a small compressor.
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "io/lzf_decoder.hpp"
#include "io_test_util.hpp"
#include "lzf_test_compressor.hpp"

namespace sspc::io {
namespace {

using test::bytes_of;

StatusOr<std::string> decompress(std::string_view stream, std::size_t size) {
  std::string out(size, '\0');
  const Status s = lzf_decompress(bytes_of(stream),
                                  std::as_writable_bytes(std::span(out.data(), out.size())), 100);
  if (!s.ok()) return s;
  return out;
}

TEST(LzfDecoder, LiteralRunsAndABackReference) {
  // "abc" as a literal run of 3, then a back-reference of length 5 at distance 3 (a run that
  // overlaps its own output): "abcabcab".
  const std::string stream = std::string(
                                 "\x02"
                                 "abc",
                                 4) +
                             std::string("\x60\x02", 2);
  const StatusOr<std::string> out = decompress(stream, 8);
  ASSERT_TRUE(out.ok()) << out.status().to_string();
  EXPECT_EQ(*out, "abcabcab");
}

TEST(LzfDecoder, LongBackReference) {
  // Length field 7 plus an extra byte of 10: 7 + 10 + 2 = 19 copies of 'z' at distance 1.
  const std::string stream = std::string("\x00z", 2) + std::string("\xe0\x0a\x00", 3);
  const StatusOr<std::string> out = decompress(stream, 20);
  ASSERT_TRUE(out.ok()) << out.status().to_string();
  EXPECT_EQ(*out, std::string(20, 'z'));
}

TEST(LzfDecoder, RoundTripsTheTestCompressor) {
  std::string data;
  for (int i = 0; i < 3000; ++i) data += static_cast<char>((i * i) % 7 + (i / 300));
  const std::string stream = test::lzf_compress(data);
  EXPECT_LT(stream.size(), data.size());
  const StatusOr<std::string> out = decompress(stream, data.size());
  ASSERT_TRUE(out.ok()) << out.status().to_string();
  EXPECT_EQ(*out, data);
}

TEST(LzfDecoder, BackReferenceBeforeTheStartIsCorrupt) {
  // One literal byte, then distance 6.
  const std::string stream = std::string(
                                 "\x00"
                                 "a",
                                 2) +
                             std::string("\x20\x05", 2);
  const StatusOr<std::string> out = decompress(stream, 4);
  ASSERT_FALSE(out.ok());
  EXPECT_EQ(out.status().code(), StatusCode::kCorrupt);
  EXPECT_NE(out.status().message().find("byte offset 102"), std::string::npos)
      << out.status().message();
}

TEST(LzfDecoder, MalformedStreamsAreRefused) {
  struct Case {
    std::string stream;
    std::size_t size;
    const char* why;
  };
  const std::vector<Case> cases = {
      {std::string("\x05"
                   "ab",
                   3),
       6, "literal past the end of the input"},
      {std::string("\x02"
                   "abc",
                   4),
       2, "literal past the end of the output"},
      {std::string("\x02"
                   "abc",
                   4),
       5, "too little output"},
      {std::string("\x02"
                   "abc\x20",
                   5),
       6, "back-reference without its distance byte"},
      {std::string("\x02"
                   "abc\xe0",
                   5),
       20, "long back-reference without its length byte"},
      {std::string("\x02"
                   "abc\x20\x00",
                   6),
       4, "back-reference past the end of the output"},
      {std::string("\x02"
                   "abc\x3f\xff",
                   6),
       6, "distance 8192 before the start"},
      {std::string(), 1, "empty stream, output expected"},
  };
  for (const Case& c : cases) {
    const StatusOr<std::string> out = decompress(c.stream, c.size);
    EXPECT_FALSE(out.ok()) << c.why;
    if (!out.ok()) {
      EXPECT_EQ(out.status().code(), StatusCode::kCorrupt) << c.why;
    }
  }
}

}  // namespace
}  // namespace sspc::io
