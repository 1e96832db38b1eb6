// The PLY reader on hand-built files: every scalar type under both names, any property order,
// other elements before and after the vertices, both byte orders, and the header's variants.
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "io_test_util.hpp"
#include "sspc/io.hpp"

namespace sspc {
namespace {

using test::bytes_of;
using test::put;

// Appends `v` stored as the PLY type `type` (either name).
void put_as(std::string& out, std::string_view type, double v, bool big) {
  if (type == "char" || type == "int8")
    put(out, static_cast<std::int8_t>(v), big);
  else if (type == "uchar" || type == "uint8")
    put(out, static_cast<std::uint8_t>(v), big);
  else if (type == "short" || type == "int16")
    put(out, static_cast<std::int16_t>(v), big);
  else if (type == "ushort" || type == "uint16")
    put(out, static_cast<std::uint16_t>(v), big);
  else if (type == "int" || type == "int32")
    put(out, static_cast<std::int32_t>(v), big);
  else if (type == "uint" || type == "uint32")
    put(out, static_cast<std::uint32_t>(v), big);
  else if (type == "float" || type == "float32")
    put(out, static_cast<float>(v), big);
  else if (type == "double" || type == "float64")
    put(out, v, big);
  else
    ADD_FAILURE() << "no such type " << type;
}

bool is_signed_type(std::string_view t) {
  return !(t.starts_with("u"));
}

class PlyScalarType : public ::testing::TestWithParam<const char*> {};

// x y z stored as the type, in all three encodings; signed types also get a negative value.
TEST_P(PlyScalarType, ConvertsToFloatInEveryEncoding) {
  const std::string type = GetParam();
  const double xs[2] = {is_signed_type(type) ? -7.0 : 7.0, 100.0};
  for (const char* format : {"binary_little_endian", "binary_big_endian", "ascii"}) {
    const bool big = std::string(format) == "binary_big_endian";
    std::string ply = std::string("ply\nformat ") + format + " 1.0\nelement vertex 2\n";
    for (const char* axis : {"x", "y", "z"}) ply += "property " + type + " " + axis + "\n";
    ply += "end_header\n";
    for (const double x : xs) {
      const double values[3] = {x, 1.0, 127.0};
      for (const double v : values) {
        if (std::string(format) == "ascii") {
          ply += std::to_string(static_cast<long long>(v)) + " ";
        } else {
          put_as(ply, type, v, big);
        }
      }
      if (std::string(format) == "ascii") ply += "\n";
    }
    const StatusOr<PointCloud> cloud = read_ply(bytes_of(ply), "types.ply");
    ASSERT_TRUE(cloud.ok()) << format << ": " << cloud.status().to_string();
    ASSERT_EQ(cloud->size(), 2u);
    EXPECT_EQ(cloud->positions[0], Vec3f(static_cast<float>(xs[0]), 1.0f, 127.0f)) << format;
    EXPECT_EQ(cloud->positions[1], Vec3f(100.0f, 1.0f, 127.0f)) << format;
  }
}

INSTANTIATE_TEST_SUITE_P(BothNames, PlyScalarType,
                         ::testing::Values("char", "int8", "uchar", "uint8", "short", "int16",
                                           "ushort", "uint16", "int", "int32", "uint", "uint32",
                                           "float", "float32", "double", "float64"));

TEST(PlyReader, PropertiesInAnyOrderWithExtrasSkipped) {
  std::string ply =
      "ply\nformat binary_little_endian 1.0\nelement vertex 2\n"
      "property uchar blue\nproperty float nz\nproperty double z\nproperty float intensity\n"
      "property float x\nproperty uchar green\nproperty float ny\nproperty short y\n"
      "property uchar red\nproperty float nx\nend_header\n";
  for (int i = 0; i < 2; ++i) {
    put<std::uint8_t>(ply, static_cast<std::uint8_t>(30 + i));  // blue
    put<float>(ply, 0.5f);                                      // nz
    put<double>(ply, 3.25 + i);                                 // z
    put<float>(ply, 999.0f);                                    // intensity
    put<float>(ply, 1.5f + static_cast<float>(i));              // x
    put<std::uint8_t>(ply, 20);                                 // green
    put<float>(ply, -0.25f);                                    // ny
    put<std::int16_t>(ply, static_cast<std::int16_t>(-2 - i));  // y
    put<std::uint8_t>(ply, 10);                                 // red
    put<float>(ply, 0.75f);                                     // nx
  }
  const StatusOr<PointCloud> cloud = read_ply(bytes_of(ply), "order.ply");
  ASSERT_TRUE(cloud.ok()) << cloud.status().to_string();
  ASSERT_EQ(cloud->size(), 2u);
  EXPECT_EQ(cloud->positions[1], Vec3f(2.5f, -3.0f, 4.25f));
  EXPECT_EQ(cloud->normals[0], Vec3f(0.75f, -0.25f, 0.5f));
  EXPECT_EQ(cloud->colours[1], (Rgb8{10, 20, 31}));
}

// Hand-built big-endian bytes with known values: 1.0f = 3f800000, -2.0f = c0000000,
// 0.15625f = 3e200000; the int16 0x0102 = 258.
TEST(PlyReader, BigEndianBytesDecodeToKnownValues) {
  std::string ply =
      "ply\nformat binary_big_endian 1.0\nelement vertex 1\nproperty float x\n"
      "property float y\nproperty float z\nproperty short red\nproperty short green\n"
      "property short blue\nend_header\n";
  const unsigned char body[] = {0x3f, 0x80, 0, 0,    0xc0, 0,    0,    0,    0x3e,
                                0x20, 0,    0, 0xff, 0xff, 0x80, 0x80, 0x01, 0x02};
  ply.append(reinterpret_cast<const char*>(body), sizeof body);
  const StatusOr<PointCloud> cloud = read_ply(bytes_of(ply), "be.ply");
  ASSERT_TRUE(cloud.ok()) << cloud.status().to_string();
  EXPECT_EQ(cloud->positions[0], Vec3f(1.0f, -2.0f, 0.15625f));
  // 16-bit colours scale to 8 bits; a negative short (0xffff = -1) clamps to 0.
  EXPECT_EQ(cloud->colours[0], (Rgb8{0, 0, 1}));
}

const std::string kFaceElement =
    "element face 2\nproperty list uchar int vertex_indices\nproperty uchar flags\n";

void put_faces(std::string& out, bool binary) {
  if (!binary) {
    out += "3 0 1 2 7\n4 0 1 2 0 9\n";
    return;
  }
  put<std::uint8_t>(out, 3);
  for (int v : {0, 1, 2}) put<std::int32_t>(out, v);
  put<std::uint8_t>(out, 7);
  put<std::uint8_t>(out, 4);
  for (int v : {0, 1, 2, 0}) put<std::int32_t>(out, v);
  put<std::uint8_t>(out, 9);
}

class PlyFaces : public ::testing::TestWithParam<std::tuple<bool /*binary*/, bool /*before*/>> {};

TEST_P(PlyFaces, FaceListsBeforeOrAfterTheVerticesAreSkipped) {
  const auto [binary, before] = GetParam();
  std::string ply =
      std::string("ply\nformat ") + (binary ? "binary_little_endian" : "ascii") + " 1.0\n";
  const std::string vertex =
      "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
  ply += before ? kFaceElement + vertex : vertex + kFaceElement;
  ply += "end_header\n";
  std::string vertices;
  for (int i = 0; i < 3; ++i) {
    if (binary) {
      for (int k = 0; k < 3; ++k) put<float>(vertices, static_cast<float>(i * 3 + k));
    } else {
      vertices += std::to_string(i * 3) + " " + std::to_string(i * 3 + 1) + " " +
                  std::to_string(i * 3 + 2) + "\n";
    }
  }
  std::string faces;
  put_faces(faces, binary);
  ply += before ? faces + vertices : vertices + faces;
  const StatusOr<PointCloud> cloud = read_ply(bytes_of(ply), "faces.ply");
  ASSERT_TRUE(cloud.ok()) << cloud.status().to_string();
  ASSERT_EQ(cloud->size(), 3u);
  EXPECT_EQ(cloud->positions[2], Vec3f(6, 7, 8));

  // The second face one index short of its declared 4: the skip must notice, whether the
  // vertices then come up short (before) or the file ends inside the face (after).
  std::string short_ply = ply;
  if (before) {
    short_ply.erase(ply.size() - vertices.size() - (binary ? 5 : 4), binary ? 4 : 2);
  } else {
    short_ply.resize(ply.size() - 4);
  }
  EXPECT_FALSE(read_ply(bytes_of(short_ply), "faces.ply").ok());
}

INSTANTIATE_TEST_SUITE_P(BothEncodingsBothPlaces, PlyFaces,
                         ::testing::Combine(::testing::Bool(), ::testing::Bool()));

TEST(PlyReader, VertexWithAListPropertyReadsSequentially) {
  std::string ply =
      "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\n"
      "property list uchar float uv\nproperty float y\nproperty float z\nend_header\n";
  for (int i = 0; i < 2; ++i) {
    put<float>(ply, static_cast<float>(i));
    put<std::uint8_t>(ply, static_cast<std::uint8_t>(i + 1));
    for (int k = 0; k <= i; ++k) put<float>(ply, 9.0f);
    put<float>(ply, 2.0f);
    put<float>(ply, 3.0f);
  }
  const StatusOr<PointCloud> cloud = read_ply(bytes_of(ply), "list.ply");
  ASSERT_TRUE(cloud.ok()) << cloud.status().to_string();
  EXPECT_EQ(cloud->positions[1], Vec3f(1, 2, 3));
}

TEST(PlyReader, CommentsObjInfoAndCrlfHeaders) {
  const std::string ply =
      "ply\r\nformat ascii 1.0\r\ncomment made by hand\r\nobj_info scanner 7\r\n"
      "element vertex 2\r\nproperty float x\r\nproperty float y\r\nproperty float z\r\n"
      "end_header\r\n1 2 3\r\n4 5 6\r\n";
  const StatusOr<PointCloud> cloud = read_ply(bytes_of(ply), "crlf.ply");
  ASSERT_TRUE(cloud.ok()) << cloud.status().to_string();
  ASSERT_EQ(cloud->size(), 2u);
  EXPECT_EQ(cloud->positions[1], Vec3f(4, 5, 6));
}

TEST(PlyReader, AsciiLastLineWithoutNewline) {
  const std::string ply =
      "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
      "property float z\nend_header\n1 2 3";
  const StatusOr<PointCloud> cloud = read_ply(bytes_of(ply), "nonl.ply");
  ASSERT_TRUE(cloud.ok()) << cloud.status().to_string();
  EXPECT_EQ(cloud->positions[0], Vec3f(1, 2, 3));
}

TEST(PlyReader, CrlfHeaderBeforeABinaryBody) {
  std::string ply =
      "ply\r\nformat binary_little_endian 1.0\r\nelement vertex 1\r\nproperty float x\r\n"
      "property float y\r\nproperty float z\r\nend_header\r\n";
  for (float v : {1.0f, 2.0f, 3.0f}) put(ply, v);
  const StatusOr<PointCloud> cloud = read_ply(bytes_of(ply), "crlf.ply");
  ASSERT_TRUE(cloud.ok()) << cloud.status().to_string();
  EXPECT_EQ(cloud->positions[0], Vec3f(1, 2, 3));
}

TEST(PlyReader, FloatColoursScaleAndDiffuseNamesAndNormalAliases) {
  const std::string ply =
      "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
      "property float z\nproperty float normal_x\nproperty float normal_y\n"
      "property float normal_z\nproperty float diffuse_red\nproperty float diffuse_green\n"
      "property float diffuse_blue\nend_header\n0 0 0 0 0 1 1.0 0.5 -3\n";
  const StatusOr<PointCloud> cloud = read_ply(bytes_of(ply), "diffuse.ply");
  ASSERT_TRUE(cloud.ok()) << cloud.status().to_string();
  EXPECT_EQ(cloud->normals[0], Vec3f(0, 0, 1));
  EXPECT_EQ(cloud->colours[0], (Rgb8{255, 128, 0}));
}

TEST(PlyReader, PartialNormalsAreIgnored) {
  const std::string ply =
      "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
      "property float z\nproperty float nx\nend_header\n1 2 3 4\n";
  const StatusOr<PointCloud> cloud = read_ply(bytes_of(ply), "partial.ply");
  ASSERT_TRUE(cloud.ok()) << cloud.status().to_string();
  EXPECT_FALSE(cloud->has_normals());
}

// A newline after the binary body is common (writers that end every file with one) and harmless.
TEST(PlyReader, OneNewlineAfterABinaryBodyIsTolerated) {
  for (const std::string ending : {"\n", "\r\n"}) {
    std::string ply =
        "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\n"
        "property float y\nproperty float z\nend_header\n";
    for (float v : {1.0f, 2.0f, 3.0f}) put(ply, v);
    ply += ending;
    EXPECT_TRUE(read_ply(bytes_of(ply), "trailing.ply").ok());
  }
}

// Anything more means the header's counts are wrong: a vertex count lower than the data would
// otherwise drop points without a word (the ascii reader refuses the same lie).
TEST(PlyReader, BytesAfterTheLastElementOfABinaryBodyAreRefused) {
  const std::string header =
      "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\n"
      "property float y\nproperty float z\nend_header\n";
  std::string ply = header;
  for (float v : {1.0f, 2.0f, 3.0f, 4.0f, 5.0f, 6.0f}) put(ply, v);
  const StatusOr<PointCloud> lie = read_ply(bytes_of(ply), "lie.ply");
  ASSERT_FALSE(lie.ok());
  EXPECT_EQ(lie.status().code(), StatusCode::kCorrupt);
  EXPECT_EQ(lie.status().message(),
            "lie.ply: byte offset " + std::to_string(header.size() + 12) +
                ": 12 bytes after the last element (the header's counts say the data ends here)");

  for (const std::string& ending :
       {std::string("\n\n"), std::string("\r"), std::string(1, '\0'), std::string(" \n")}) {
    std::string padded = header;
    for (float v : {1.0f, 2.0f, 3.0f}) put(padded, v);
    padded += ending;
    EXPECT_FALSE(read_ply(bytes_of(padded), "padded.ply").ok()) << ending.size();
  }
}

}  // namespace
}  // namespace sspc
