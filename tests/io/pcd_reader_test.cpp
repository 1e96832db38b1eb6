// The PCD reader: ascii, binary and binary_compressed bodies built in the test, packed colours,
// skipped and padding fields, COUNT > 1.
#include <bit>
#include <charconv>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "io_test_util.hpp"
#include "lzf_test_compressor.hpp"
#include "sspc/io.hpp"

namespace sspc {
namespace {

using test::bytes_of;
using test::put;

// Fields: x y z, a 3-value histogram, normal_x normal_y normal_z, rgb, a padding byte, an
// intensity.
const char* kHeader =
    "# .PCD v0.7 - Point Cloud Data file format\n"
    "VERSION 0.7\n"
    "FIELDS x y z hist normal_x normal_y normal_z rgb _ intensity\n"
    "SIZE 4 4 4 2 4 4 4 4 1 8\n"
    "TYPE F F F U F F F F U F\n"
    "COUNT 1 1 1 3 1 1 1 1 1 1\n"
    "WIDTH 2\n"
    "HEIGHT 2\n"
    "VIEWPOINT 0 0 0 1 0 0 0\n"
    "POINTS 4\n";

constexpr std::size_t kPoints = 4;

Vec3f position(std::size_t i) {
  return Vec3f(static_cast<float>(i) + 0.5f, -1.0f / 3.0f, 1e20f * static_cast<float>(i));
}
Vec3f normal(std::size_t i) {
  return Vec3f(0.0f, i % 2 == 0 ? 1.0f : -1.0f, 0.0f);
}
Rgb8 colour(std::size_t i) {
  return Rgb8{static_cast<std::uint8_t>(200 + i), static_cast<std::uint8_t>(i * 50), 7};
}
std::uint32_t packed(std::size_t i) {
  const Rgb8 c = colour(i);
  return 0xff000000u | std::uint32_t{c.r} << 16 | std::uint32_t{c.g} << 8 | c.b;
}

void expect_sample(const StatusOr<PointCloud>& cloud) {
  ASSERT_TRUE(cloud.ok()) << cloud.status().to_string();
  ASSERT_EQ(cloud->size(), kPoints);
  ASSERT_TRUE(cloud->has_normals());
  ASSERT_TRUE(cloud->has_colours());
  for (std::size_t i = 0; i < kPoints; ++i) {
    EXPECT_TRUE(test::same_bits(cloud->positions[i], position(i))) << i;
    EXPECT_EQ(cloud->normals[i], normal(i)) << i;
    EXPECT_EQ(cloud->colours[i], colour(i)) << i;
  }
}

// One field of point i as bytes, for the binary layouts.
void put_field(std::string& out, std::size_t field, std::size_t i) {
  switch (field) {
    case 0:
    case 1:
    case 2: put<float>(out, position(i)[static_cast<int>(field)]); break;
    case 3:
      for (int k = 0; k < 3; ++k) put<std::uint16_t>(out, 0xbeef);
      break;
    case 4:
    case 5:
    case 6: put<float>(out, normal(i)[static_cast<int>(field - 4)]); break;
    case 7: put<std::uint32_t>(out, packed(i)); break;
    case 8: put<std::uint8_t>(out, 0); break;
    case 9: put<double>(out, 0.25); break;
  }
}
constexpr std::size_t kFields = 10;

std::string float_text(float f) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, f);
  return std::string(buf, r.ptr);
}

TEST(PcdReader, Ascii) {
  std::string pcd = std::string(kHeader) + "DATA ascii\n";
  for (std::size_t i = 0; i < kPoints; ++i) {
    const Vec3f p = position(i), n = normal(i);
    pcd += float_text(p.x()) + " " + float_text(p.y()) + " " + float_text(p.z()) + " 1 2 3 " +
           float_text(n.x()) + " " + float_text(n.y()) + " " + float_text(n.z()) + " " +
           std::to_string(packed(i)) + " 0 0.25\n";
  }
  expect_sample(read_pcd(bytes_of(pcd), "ascii.pcd"));
}

TEST(PcdReader, AsciiRgbPrintedAsAFloat) {
  // Older PCL printed a float rgb field as the float whose bits hold the colour.
  const float bits = std::bit_cast<float>(std::uint32_t{0x00ff8040});
  const std::string pcd =
      "FIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F F\nWIDTH 1\nDATA ascii\n"
      "1 2 3 " +
      float_text(bits) + "\n";
  const StatusOr<PointCloud> cloud = read_pcd(bytes_of(pcd), "float-rgb.pcd");
  ASSERT_TRUE(cloud.ok()) << cloud.status().to_string();
  EXPECT_EQ(cloud->colours[0], (Rgb8{0xff, 0x80, 0x40}));
}

TEST(PcdReader, Binary) {
  std::string pcd = std::string(kHeader) + "DATA binary\n";
  for (std::size_t i = 0; i < kPoints; ++i) {
    for (std::size_t f = 0; f < kFields; ++f) put_field(pcd, f, i);
  }
  expect_sample(read_pcd(bytes_of(pcd), "binary.pcd"));
}

std::string compressed_body() {
  std::string raw;  // field by field: all points' x, then all points' y, ...
  for (std::size_t f = 0; f < kFields; ++f) {
    for (std::size_t i = 0; i < kPoints; ++i) put_field(raw, f, i);
  }
  const std::string lzf = test::lzf_compress(raw);
  std::string body;
  put<std::uint32_t>(body, static_cast<std::uint32_t>(lzf.size()));
  put<std::uint32_t>(body, static_cast<std::uint32_t>(raw.size()));
  return body + lzf;
}

TEST(PcdReader, BinaryCompressed) {
  const std::string pcd = std::string(kHeader) + "DATA binary_compressed\n" + compressed_body();
  expect_sample(read_pcd(bytes_of(pcd), "compressed.pcd"));
}

TEST(PcdReader, BinaryCompressedWithAHandMadeBackReference) {
  // Two points, x y z only: raw = x0 x1 y0 y1 z0 z1 with every value 1.0f (00 00 80 3f): one
  // literal of 4 bytes, then a back-reference of 20 bytes at distance 4.
  std::string lzf = std::string("\x03\x00\x00\x80\x3f", 5);
  lzf += std::string("\xe0\x0b\x03", 3);  // length 7 + 11 + 2 = 20, distance 3 + 1
  std::string pcd =
      "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nHEIGHT 1\nPOINTS 2\n"
      "DATA binary_compressed\n";
  put<std::uint32_t>(pcd, static_cast<std::uint32_t>(lzf.size()));
  put<std::uint32_t>(pcd, 24);
  pcd += lzf;
  const StatusOr<PointCloud> cloud = read_pcd(bytes_of(pcd), "handmade.pcd");
  ASSERT_TRUE(cloud.ok()) << cloud.status().to_string();
  ASSERT_EQ(cloud->size(), 2u);
  EXPECT_EQ(cloud->positions[1], Vec3f(1, 1, 1));
}

TEST(PcdReader, CompressedWithOutOfRangeBackReferenceNamesTheFile) {
  std::string pcd = "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nDATA binary_compressed\n";
  const std::string lzf = std::string("\x00\x01", 2) + std::string("\xe0\x05\x10", 3);
  put<std::uint32_t>(pcd, static_cast<std::uint32_t>(lzf.size()));
  put<std::uint32_t>(pcd, 12);
  pcd += lzf;
  const StatusOr<PointCloud> cloud = read_pcd(bytes_of(pcd), "backref.pcd");
  ASSERT_FALSE(cloud.ok());
  EXPECT_EQ(cloud.status().code(), StatusCode::kCorrupt);
  EXPECT_NE(cloud.status().message().find("backref.pcd"), std::string::npos);
  EXPECT_NE(cloud.status().message().find("back-reference"), std::string::npos)
      << cloud.status().message();
}

TEST(PcdReader, RgbaAndIntegerCoordinates) {
  std::string pcd = "FIELDS rgba z y x\nSIZE 4 2 4 1\nTYPE U I F U\nWIDTH 1\nDATA binary\n";
  put<std::uint32_t>(pcd, 0x80102030u);
  put<std::int16_t>(pcd, -300);
  put<float>(pcd, 0.5f);
  put<std::uint8_t>(pcd, 200);
  const StatusOr<PointCloud> cloud = read_pcd(bytes_of(pcd), "rgba.pcd");
  ASSERT_TRUE(cloud.ok()) << cloud.status().to_string();
  EXPECT_EQ(cloud->positions[0], Vec3f(200.0f, 0.5f, -300.0f));
  EXPECT_EQ(cloud->colours[0], (Rgb8{0x10, 0x20, 0x30}));
  EXPECT_FALSE(cloud->has_normals());
}

TEST(PcdReader, AsciiLastLineWithoutNewline) {
  const std::string pcd = "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nDATA ascii\n1 2 3";
  const StatusOr<PointCloud> cloud = read_pcd(bytes_of(pcd), "nonl.pcd");
  ASSERT_TRUE(cloud.ok()) << cloud.status().to_string();
  EXPECT_EQ(cloud->positions[0], Vec3f(1, 2, 3));
}

TEST(PcdReader, AsciiCountMismatchesAreLineErrors) {
  const std::string head = "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nDATA ascii\n";
  const StatusOr<PointCloud> few = read_pcd(bytes_of(head + "100 200 300\n"), "few.pcd");
  ASSERT_FALSE(few.ok());
  EXPECT_NE(few.status().message().find("few.pcd: line 7"), std::string::npos)
      << few.status().message();
  const StatusOr<PointCloud> extra =
      read_pcd(bytes_of(head + "1 2 3\n4 5 6\n7 8 9\n"), "extra.pcd");
  ASSERT_FALSE(extra.ok());
  EXPECT_NE(extra.status().message().find("extra.pcd: line 8"), std::string::npos)
      << extra.status().message();
  const StatusOr<PointCloud> tokens = read_pcd(bytes_of(head + "1 2 3 4\n4 5 6\n"), "tok.pcd");
  ASSERT_FALSE(tokens.ok());
  EXPECT_NE(tokens.status().message().find("tok.pcd: line 6"), std::string::npos)
      << tokens.status().message();
}

}  // namespace
}  // namespace sspc
