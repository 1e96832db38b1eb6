// Hostile and broken inputs: every one must give an error naming the file and the place, never
// a crash, an exception or a large allocation.
#include <chrono>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "io_test_util.hpp"
#include "sspc/io.hpp"

namespace sspc {
namespace {

using test::bytes_of;
using test::put;

std::string small_binary_ply() {
  PlyWriteOptions options;
  options.comments = {"truncation test"};
  return encode_ply(test::sample_cloud(3, true, true), options);
}

TEST(MalformedPly, EveryTruncationOfABinaryFileIsRefused) {
  for (const PlyEncoding encoding :
       {PlyEncoding::kBinaryLittleEndian, PlyEncoding::kBinaryBigEndian}) {
    PlyWriteOptions options;
    options.encoding = encoding;
    const std::string full = encode_ply(test::sample_cloud(3, true, true), options);
    ASSERT_TRUE(read_ply(bytes_of(full), "whole.ply").ok());
    for (std::size_t n = 0; n < full.size(); ++n) {
      const StatusOr<PointCloud> r =
          read_ply(bytes_of(std::string_view(full).substr(0, n)), "cut.ply");
      ASSERT_FALSE(r.ok()) << "prefix of " << n << " bytes was accepted";
      EXPECT_EQ(r.status().message().rfind("cut.ply: ", 0), 0u) << r.status().message();
    }
  }
}

TEST(MalformedPly, TruncatedBinaryBodyGivesTheByteOffset) {
  const std::string full = small_binary_ply();
  const StatusOr<PointCloud> r =
      read_ply(bytes_of(std::string_view(full).substr(0, full.size() - 1)), "cut.ply");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), StatusCode::kCorrupt);
  EXPECT_NE(
      r.status().message().find("byte offset " + std::to_string(full.find("end_header\n") + 11)),
      std::string::npos)
      << r.status().message();
}

TEST(MalformedPly, EveryTruncationOfAnAsciiFileIsRefusedOrWhole) {
  PlyWriteOptions options;
  options.encoding = PlyEncoding::kAscii;
  const std::string full = encode_ply(test::sample_cloud(3, true, true), options);
  for (std::size_t n = 0; n < full.size(); ++n) {
    const StatusOr<PointCloud> r =
        read_ply(bytes_of(std::string_view(full).substr(0, n)), "cut.ply");
    // A cut inside the very last value leaves a valid file with a shorter number (or the same
    // one, when only the newline goes); every cut that loses a value must fail.
    if (r.ok()) {
      EXPECT_GT(n, full.find_last_of(' ')) << "prefix of " << n << " bytes accepted";
    } else {
      EXPECT_EQ(r.status().message().rfind("cut.ply: ", 0), 0u) << r.status().message();
    }
  }
}

struct BadCase {
  const char* label;
  std::string text;
  StatusCode code;
  const char* expected;  // a substring of the message
};

std::string ply_header(const std::string& format, const std::string& rest) {
  return "ply\nformat " + format + " 1.0\n" + rest;
}

const std::string kXyz = "property float x\nproperty float y\nproperty float z\n";

std::string binary_vertex(float x, float y, float z) {
  std::string s;
  put(s, x);
  put(s, y);
  put(s, z);
  return s;
}

std::vector<BadCase> ply_cases() {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  const std::string le = "binary_little_endian";
  return {
      {"not ply", "plx\nformat ascii 1.0\n", StatusCode::kParseError, "bad.ply: not a PLY file"},
      {"empty file", "", StatusCode::kParseError, "bad.ply: "},
      {"unknown keyword", ply_header("ascii", "elemnt vertex 1\n"), StatusCode::kParseError,
       "bad.ply: line 3: unknown header keyword 'elemnt'"},
      {"unknown format", "ply\nformat binary_middle_endian 1.0\nend_header\n",
       StatusCode::kUnsupported, "bad.ply: line 2"},
      {"bad version", "ply\nformat ascii 2.0\nend_header\n", StatusCode::kUnsupported,
       "bad.ply: line 2"},
      {"unknown type", ply_header("ascii", "element vertex 1\nproperty float128 x\n"),
       StatusCode::kUnsupported, "bad.ply: line 4: unknown property type 'float128'"},
      {"float list count", ply_header("ascii", "element f 1\nproperty list float int i\n"),
       StatusCode::kParseError, "bad.ply: line 4"},
      {"negative count", ply_header("ascii", "element vertex -1\n"), StatusCode::kParseError,
       "bad.ply: line 3"},
      {"property before element", ply_header("ascii", "property float x\n"),
       StatusCode::kParseError, "bad.ply: line 3"},
      {"no end_header", ply_header("ascii", "element vertex 1\n" + kXyz), StatusCode::kParseError,
       "bad.ply: the header has no 'end_header'"},
      {"no vertex", ply_header("ascii", "element face 0\nend_header\n"), StatusCode::kParseError,
       "bad.ply: the header declares no 'vertex'"},
      {"no z",
       ply_header("ascii",
                  "element vertex 1\nproperty float x\nproperty float y\nend_header\n1 2\n"),
       StatusCode::kParseError, "bad.ply: line 3: element 'vertex' has no property 'z'"},
      {"ascii too few tokens",
       ply_header("ascii", "element vertex 1\n" + kXyz + "end_header\n10 20\n"),
       StatusCode::kParseError, "bad.ply: line 8"},
      {"ascii too many tokens",
       ply_header("ascii", "element vertex 1\n" + kXyz + "end_header\n1 2 3 4\n"),
       StatusCode::kParseError, "bad.ply: line 8"},
      {"ascii too few lines",
       ply_header("ascii", "element vertex 2\n" + kXyz + "end_header\n100 200 300\n"),
       StatusCode::kParseError, "bad.ply: line 9"},
      {"ascii extra line",
       ply_header("ascii", "element vertex 1\n" + kXyz + "end_header\n1 2 3\n4 5 6\n"),
       StatusCode::kParseError, "bad.ply: line 9"},
      {"ascii not a number",
       ply_header("ascii", "element vertex 1\n" + kXyz + "end_header\n1 two 3\n"),
       StatusCode::kParseError, "bad.ply: line 8"},
      {"ascii nan",
       ply_header("ascii", "element vertex 2\n" + kXyz + "end_header\n1 2 3\nnan 2 3\n"),
       StatusCode::kInvalidArgument, "bad.ply: line 9: point 1 has a non-finite coordinate"},
      {"binary nan",
       ply_header(le, "element vertex 2\n" + kXyz + "end_header\n") + binary_vertex(1, 2, 3) +
           binary_vertex(1, nan, 3),
       StatusCode::kInvalidArgument, "point 1 has a non-finite coordinate"},
      {"binary inf",
       ply_header(le, "element vertex 1\n" + kXyz + "end_header\n") + binary_vertex(inf, 2, 3),
       StatusCode::kInvalidArgument, "bad.ply: byte offset 115: point 0"},
      {"double beyond float",
       ply_header("ascii",
                  "element vertex 1\nproperty double x\nproperty double y\nproperty double "
                  "z\nend_header\n1e300 0 0\n"),
       StatusCode::kInvalidArgument, "point 0 has a non-finite"},
      {"empty cloud", ply_header(le, "element vertex 0\n" + kXyz + "end_header\n"),
       StatusCode::kInvalidArgument, "bad.ply: the file holds no points"},
      {"huge count",
       ply_header(le, "element vertex 4000000000000\n" + kXyz + "end_header\n") +
           binary_vertex(1, 2, 3),
       StatusCode::kCorrupt, "bad.ply: byte offset 127: element 'vertex' declares 4000000000000"},
      {"max count", ply_header(le, "element vertex 18446744073709551615\n" + kXyz + "end_header\n"),
       StatusCode::kCorrupt, "bad.ply: byte offset"},
      {"huge ascii count",
       ply_header("ascii", "element vertex 18446744073709551615\n" + kXyz + "end_header\n1 2 3\n"),
       StatusCode::kParseError, "bad.ply: line 3"},
      {"count beyond 64 bits", ply_header(le, "element vertex 99999999999999999999\n"),
       StatusCode::kParseError, "bad.ply: line 3"},
      {"huge face count",
       ply_header(le, "element face 4000000000\nproperty list uchar int i\nelement vertex 1\n" +
                          kXyz + "end_header\n") +
           binary_vertex(1, 2, 3),
       StatusCode::kCorrupt, "bad.ply: "},
      {"huge list length",
       ply_header(le, "element vertex 1\n" + kXyz +
                          "element face 1\nproperty list uint int i\nend_header\n") +
           binary_vertex(1, 2, 3) + "\xff\xff\xff\xff",
       StatusCode::kCorrupt, "bad.ply: "},
      {"negative list length",
       ply_header(le, "element vertex 1\n" + kXyz +
                          "element face 1\nproperty list char int i\nend_header\n") +
           binary_vertex(1, 2, 3) + "\xff",
       StatusCode::kCorrupt, "negative length"},
  };
}

TEST(MalformedPly, TableOfBadFiles) {
  for (const BadCase& c : ply_cases()) {
    const auto start = std::chrono::steady_clock::now();
    const StatusOr<PointCloud> r = read_ply(bytes_of(c.text), "bad.ply");
    const auto elapsed = std::chrono::steady_clock::now() - start;
    ASSERT_FALSE(r.ok()) << c.label;
    EXPECT_EQ(r.status().code(), c.code) << c.label << ": " << r.status().to_string();
    EXPECT_NE(r.status().message().find(c.expected), std::string::npos)
        << c.label << ": " << r.status().message();
    EXPECT_LT(elapsed, std::chrono::seconds(1)) << c.label;
  }
}

std::vector<BadCase> pcd_cases() {
  const std::string head = "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n";
  std::string nan_body;
  put(nan_body, 1.0f);
  put(nan_body, std::numeric_limits<float>::quiet_NaN());
  put(nan_body, 1.0f);
  std::string huge_raw;
  put<std::uint32_t>(huge_raw, 4);
  put<std::uint32_t>(huge_raw, 0xfffffff0u);
  huge_raw +=
      "\x03"
      "abcd";
  return {
      {"unknown keyword", head + "WIDHT 1\n", StatusCode::kParseError,
       "bad.pcd: line 4: unknown header keyword 'WIDHT'"},
      {"unknown type", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F Q\nWIDTH 1\nDATA ascii\n1 2 3\n",
       StatusCode::kUnsupported, "bad.pcd: line 5: field 'z' has TYPE 'Q'"},
      {"float of 2 bytes", "FIELDS x y z\nSIZE 4 4 2\nTYPE F F F\nWIDTH 1\nDATA ascii\n1 2 3\n",
       StatusCode::kUnsupported, "bad.pcd: line 5"},
      {"sizes disagree", "FIELDS x y z\nSIZE 4 4\nTYPE F F F\nWIDTH 1\nDATA ascii\n1 2 3\n",
       StatusCode::kParseError, "bad.pcd: line 5"},
      {"no data line", head + "WIDTH 1\n", StatusCode::kParseError,
       "bad.pcd: the header has no DATA"},
      {"unknown data", head + "WIDTH 1\nDATA zip\n", StatusCode::kUnsupported, "bad.pcd: line 5"},
      {"points disagree", head + "WIDTH 2\nPOINTS 3\nDATA ascii\n", StatusCode::kParseError,
       "bad.pcd: line 5: POINTS 3"},
      {"no x", "FIELDS a y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nDATA ascii\n1 2 3\n",
       StatusCode::kParseError, "bad.pcd: line 5: FIELDS has no 'x'"},
      {"ascii nan", head + "WIDTH 2\nDATA ascii\n1 2 3\nnan 2 3\n", StatusCode::kInvalidArgument,
       "bad.pcd: line 7: point 1"},
      {"binary nan", head + "WIDTH 1\nDATA binary\n" + nan_body, StatusCode::kInvalidArgument,
       "point 0 has a non-finite coordinate"},
      {"empty", head + "WIDTH 0\nDATA ascii\n", StatusCode::kInvalidArgument,
       "bad.pcd: the file holds no points"},
      {"truncated binary", head + "WIDTH 2\nDATA binary\n" + nan_body, StatusCode::kCorrupt,
       "bad.pcd: byte offset 55"},
      {"huge binary count", head + "WIDTH 4000000000\nHEIGHT 4000000000\nDATA binary\n" + nan_body,
       StatusCode::kCorrupt, "bad.pcd: byte offset"},
      {"width x height overflows", head + "WIDTH 18446744073709551615\nHEIGHT 2\nDATA binary\n",
       StatusCode::kParseError, "bad.pcd: line"},
      {"huge ascii count", head + "WIDTH 1000000000000\nDATA ascii\n1 2 3\n",
       StatusCode::kParseError, "bad.pcd: line 5"},
      {"huge uncompressed size", head + "WIDTH 357913940\nDATA binary_compressed\n" + huge_raw,
       StatusCode::kCorrupt, "more than LZF can produce"},
      {"compressed size past the end",
       head + "WIDTH 1\nDATA binary_compressed\n" +
           std::string("\xff\x00\x00\x00\x0c\x00\x00\x00", 8),
       StatusCode::kCorrupt, "bad.pcd: byte offset"},
      {"compressed header cut", head + "WIDTH 1\nDATA binary_compressed\n\x05\x00",
       StatusCode::kCorrupt, "bad.pcd: "},
      {"huge count", head + "COUNT 1 1 99999999999\nWIDTH 1\nDATA ascii\n1 2 3\n",
       StatusCode::kParseError, "bad.pcd: line 6"},
  };
}

TEST(MalformedPcd, TableOfBadFiles) {
  for (const BadCase& c : pcd_cases()) {
    const auto start = std::chrono::steady_clock::now();
    const StatusOr<PointCloud> r = read_pcd(bytes_of(c.text), "bad.pcd");
    const auto elapsed = std::chrono::steady_clock::now() - start;
    ASSERT_FALSE(r.ok()) << c.label;
    EXPECT_EQ(r.status().code(), c.code) << c.label << ": " << r.status().to_string();
    EXPECT_NE(r.status().message().find(c.expected), std::string::npos)
        << c.label << ": " << r.status().message();
    EXPECT_LT(elapsed, std::chrono::seconds(1)) << c.label;
  }
}

TEST(MalformedPcd, EveryTruncationOfACompressedFileIsRefused) {
  std::string pcd = "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 3\nDATA binary_compressed\n";
  std::string raw;
  for (int i = 0; i < 9; ++i) put(raw, static_cast<float>(i % 4));
  // literal-only stream: one run of 32 bytes and one of 4
  std::string lzf =
      std::string(1, '\x1f') + raw.substr(0, 32) + std::string(1, '\x03') + raw.substr(32);
  put<std::uint32_t>(pcd, static_cast<std::uint32_t>(lzf.size()));
  put<std::uint32_t>(pcd, static_cast<std::uint32_t>(raw.size()));
  pcd += lzf;
  ASSERT_TRUE(read_pcd(bytes_of(pcd), "whole.pcd").ok());
  for (std::size_t n = 0; n < pcd.size(); ++n) {
    const StatusOr<PointCloud> r =
        read_pcd(bytes_of(std::string_view(pcd).substr(0, n)), "cut.pcd");
    ASSERT_FALSE(r.ok()) << "prefix of " << n << " bytes was accepted";
    EXPECT_EQ(r.status().message().rfind("cut.pcd", 0), 0u) << r.status().message();
  }
}

// Readers given no name (bytes from memory) must not start their messages with ": ", and the
// place and the problem are joined by exactly one separator.
TEST(ErrorMessages, AnEmptyNameLeavesNoDanglingSeparator) {
  EXPECT_EQ(read_xyz(bytes_of("1 2 3\n1 2\n"), "").status().message(),
            "line 2: 2 columns where the first data line (line 1) has 3");
  EXPECT_EQ(read_xyz(bytes_of("nan 2 3\n"), "").status().message(),
            "line 1: point 0 has a non-finite coordinate (nan, 2, 3)");
  EXPECT_EQ(read_xyz(bytes_of("# nothing\n"), "").status().message(), "the file holds no points");
  std::string ply =
      "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\n"
      "property float y\nproperty float z\nend_header\n";
  put(ply, 1.0f);
  EXPECT_EQ(read_ply(bytes_of(ply), "").status().message(),
            "byte offset 115: element 'vertex' declares 2 items of at least 12 bytes, but only 4 "
            "bytes remain (the file is truncated or the count is wrong)");
  EXPECT_EQ(read_ply(bytes_of(ply), "cut.ply").status().message(),
            "cut.ply: byte offset 115: element 'vertex' declares 2 items of at least 12 bytes, "
            "but only 4 bytes remain (the file is truncated or the count is wrong)");
}

}  // namespace
}  // namespace sspc
