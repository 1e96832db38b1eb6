// The XYZ/PTS reader: every column layout, the six-column rule, comments, counts.
#include <string>

#include <gtest/gtest.h>

#include "io_test_util.hpp"
#include "sspc/io.hpp"

namespace sspc {
namespace {

using test::bytes_of;

StatusOr<PointCloud> read(const std::string& text) {
  return read_xyz(bytes_of(text), "t.xyz");
}

TEST(XyzReader, ThreeColumnsWithCommentsBlankLinesAndCrlf) {
  const StatusOr<PointCloud> c =
      read("# exported\r\n// also a comment\r\n\r\n1 2 3\r\n  4.5\t-5e-1 +6\r\n\n");
  ASSERT_TRUE(c.ok()) << c.status().to_string();
  ASSERT_EQ(c->size(), 2u);
  EXPECT_EQ(c->positions[1], Vec3f(4.5f, -0.5f, 6.0f));
  EXPECT_FALSE(c->has_normals());
  EXPECT_FALSE(c->has_colours());
}

TEST(XyzReader, Utf8ByteOrderMark) {
  const StatusOr<PointCloud> c = read(
      "\xEF\xBB\xBF"
      "1 2 3\n");
  ASSERT_TRUE(c.ok()) << c.status().to_string();
  EXPECT_EQ(c->positions[0], Vec3f(1, 2, 3));
}

TEST(XyzReader, CommaSeparated) {
  const StatusOr<PointCloud> c = read("1,2,3\n4, 5, 6\n");
  ASSERT_TRUE(c.ok()) << c.status().to_string();
  EXPECT_EQ(c->positions[1], Vec3f(4, 5, 6));
}

TEST(XyzReader, SixDecimalColumnsAreNormals) {
  const StatusOr<PointCloud> c = read("0 0 0 0.6 0.8 0\n1 1 1 0 0 1\n");
  ASSERT_TRUE(c.ok()) << c.status().to_string();
  ASSERT_TRUE(c->has_normals());
  EXPECT_FALSE(c->has_colours());
  EXPECT_EQ(c->normals[0], Vec3f(0.6f, 0.8f, 0.0f));
}

TEST(XyzReader, SixColumnsOfOnlyZerosAndOnesAreNormals) {
  const StatusOr<PointCloud> c = read("0 0 0 0 0 1\n1 1 1 1 0 0\n");
  ASSERT_TRUE(c.ok()) << c.status().to_string();
  EXPECT_TRUE(c->has_normals());
  EXPECT_FALSE(c->has_colours());
}

TEST(XyzReader, SixIntegerColumnsUpTo255AreColours) {
  const StatusOr<PointCloud> c = read("0 0 0 0 0 1\n1 1 1 255 128 0\n");
  ASSERT_TRUE(c.ok()) << c.status().to_string();
  EXPECT_FALSE(c->has_normals());
  ASSERT_TRUE(c->has_colours());
  EXPECT_EQ(c->colours[0], (Rgb8{0, 0, 1}));
  EXPECT_EQ(c->colours[1], (Rgb8{255, 128, 0}));
}

TEST(XyzReader, SixColumnsWithOneDecimalAreNormals) {
  const StatusOr<PointCloud> c = read("0 0 0 0 0 1\n1 1 1 255 128 0.5\n");
  ASSERT_TRUE(c.ok()) << c.status().to_string();
  EXPECT_TRUE(c->has_normals());
  EXPECT_FALSE(c->has_colours());
}

TEST(XyzReader, NineColumns) {
  const StatusOr<PointCloud> c = read("1 2 3 0 1 0 10 20 30\n");
  ASSERT_TRUE(c.ok()) << c.status().to_string();
  EXPECT_EQ(c->normals[0], Vec3f(0, 1, 0));
  EXPECT_EQ(c->colours[0], (Rgb8{10, 20, 30}));
}

TEST(XyzReader, PtsWithCountIntensityAndColour) {
  const StatusOr<PointCloud> c = read("2\n1 2 3 -1200 10 20 30\n4 5 6 17 40 50 60\n");
  ASSERT_TRUE(c.ok()) << c.status().to_string();
  ASSERT_EQ(c->size(), 2u);
  EXPECT_EQ(c->positions[1], Vec3f(4, 5, 6));
  EXPECT_EQ(c->colours[1], (Rgb8{40, 50, 60}));
}

TEST(XyzReader, PtsWithIntensityOnly) {
  const StatusOr<PointCloud> c = read("1 2 3 0.5\n4 5 6 0.25\n");
  ASSERT_TRUE(c.ok()) << c.status().to_string();
  EXPECT_EQ(c->size(), 2u);
  EXPECT_FALSE(c->has_colours());
}

TEST(XyzReader, ErrorsNameTheLine) {
  struct Case {
    const char* text;
    const char* where;
  };
  const Case cases[] = {
      {"1 2 3\n4 5\n", "t.xyz: line 2"},           // column count changes
      {"# c\n1 2 x\n", "t.xyz: line 2"},           // not a number
      {"1 2\n", "t.xyz: line 1"},                  // 2 columns
      {"1 2 3 4 5\n", "t.xyz: line 1"},            // 5 columns
      {"1 2 3\n1 2 nan\n", "t.xyz: line 2"},       // NaN
      {"1 2 3\n1 inf 3\n", "t.xyz: line 2"},       // infinity
      {"1 2 3 0 0 1 300 0 0\n", "t.xyz: line 1"},  // colour out of range
      {"1 2 3 0 0 nan\n", "t.xyz: line 1"},        // NaN normal
      {"3\n1 2 3\n", "t.xyz: line 1"},             // PTS count disagrees
      {"1 2 1e99\n", "t.xyz: line 1"},             // beyond float
  };
  for (const Case& c : cases) {
    const StatusOr<PointCloud> r = read(c.text);
    ASSERT_FALSE(r.ok()) << c.text;
    EXPECT_NE(r.status().message().find(c.where), std::string::npos)
        << c.text << " -> " << r.status().message();
  }
}

TEST(XyzReader, NonFiniteNamesThePointIndex) {
  const StatusOr<PointCloud> r = read("1 2 3\n4 5 6\n7 nan 9\n");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("point 2"), std::string::npos) << r.status().message();
}

TEST(XyzReader, EmptyAndCommentOnlyFilesAreErrors) {
  for (const char* text : {"", "# nothing\n\n", "0\n"}) {
    const StatusOr<PointCloud> r = read(text);
    ASSERT_FALSE(r.ok()) << text;
    EXPECT_EQ(r.status().code(), StatusCode::kInvalidArgument) << r.status().to_string();
  }
}

TEST(XyzReader, HugePtsCountInATinyFileFailsWithoutAllocating) {
  const StatusOr<PointCloud> r = read("18446744073709551615\n1 2 3\n");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("t.xyz: line 1"), std::string::npos);
}

}  // namespace
}  // namespace sspc
