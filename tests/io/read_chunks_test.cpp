// read_point_cloud_chunks against read_point_cloud: for every format and every chunk size from one
// point to more than the file holds, the chunks joined are the whole cloud bit for bit, each with
// its origin and metadata; truncated and corrupt files give the whole reader's error; a sink's
// error ends the read.
#include <algorithm>
#include <cstring>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "double_cloud_files.hpp"
#include "io_test_util.hpp"
#include "las_test_files.hpp"
#include "sspc/io.hpp"
#include "test_util.hpp"

namespace sspc {
namespace {

void write_file(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

struct Chunked {
  Status status;
  std::vector<PointCloud> chunks;
};

// `take`: the sink moves each chunk away; otherwise it copies it, and the reader may reuse the
// chunk's memory for the next one.
Chunked read_chunks(const std::filesystem::path& path, std::size_t chunk_points,
                    const ReadOptions& options = {}, bool take = true) {
  Chunked out;
  out.status = read_point_cloud_chunks(
      path, chunk_points,
      [&](PointCloud&& chunk) {
        if (take) {
          out.chunks.push_back(std::move(chunk));
        } else {
          out.chunks.push_back(chunk);
        }
        return Status();
      },
      options);
  return out;
}

template <typename T>
bool same_bytes(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

::testing::AssertionResult same_las(const LasPointAttributes& a, const LasPointAttributes& b) {
  const bool same =
      a.intensity == b.intensity && a.return_number == b.return_number &&
      a.number_of_returns == b.number_of_returns && a.classification == b.classification &&
      a.classification_flags == b.classification_flags && same_bytes(a.scan_angle, b.scan_angle) &&
      a.scan_flags == b.scan_flags && a.user_data == b.user_data &&
      a.point_source_id == b.point_source_id && same_bytes(a.gps_time, b.gps_time) &&
      a.rgb == b.rgb && a.nir == b.nir && a.extra_bytes == b.extra_bytes &&
      a.extra_bytes_per_point == b.extra_bytes_per_point;
  if (same) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure()
         << "LAS attributes differ (" << a.names() << " / " << b.names() << ")";
}

// The chunks are `whole` cut every `n` points, each with its origin and metadata.
::testing::AssertionResult chunks_make(const std::vector<PointCloud>& chunks,
                                       const PointCloud& whole, std::size_t n) {
  PointCloud joined;
  for (std::size_t c = 0; c < chunks.size(); ++c) {
    const PointCloud& chunk = chunks[c];
    const std::size_t expected = std::min(n, whole.size() - joined.size());
    if (chunk.size() != expected || expected == 0) {
      return ::testing::AssertionFailure()
             << "chunk " << c << " holds " << chunk.size() << " points, not " << expected;
    }
    if (!chunk.validate().ok()) return ::testing::AssertionFailure() << "chunk " << c << " invalid";
    if (chunk.origin != whole.origin) {
      return ::testing::AssertionFailure()
             << "chunk " << c << " origin " << chunk.origin.transpose() << " against "
             << whole.origin.transpose();
    }
    if (!(chunk.metadata == whole.metadata)) {
      return ::testing::AssertionFailure() << "chunk " << c << " metadata differs";
    }
    joined.append(chunk);
  }
  if (!same_bytes(joined.positions, whole.positions)) {
    return ::testing::AssertionFailure()
           << "positions differ (" << joined.size() << " of " << whole.size() << " points)";
  }
  if (!same_bytes(joined.normals, whole.normals)) return ::testing::AssertionFailure() << "normals";
  if (joined.colours != whole.colours) return ::testing::AssertionFailure() << "colours";
  return same_las(joined.las, whole.las);
}

// Every chunk size from 1 to past the end: a boundary falls after every point.
void expect_chunks_equal_whole(const std::filesystem::path& path) {
  SCOPED_TRACE(path.filename().string());
  std::vector<std::string> whole_warnings;
  ReadOptions whole_options;
  whole_options.warnings = &whole_warnings;
  const StatusOr<PointCloud> whole = read_point_cloud(path, whole_options);
  ASSERT_TRUE(whole.ok()) << whole.status().to_string();
  for (std::size_t n = 1; n <= whole->size() + 2; ++n) {
    std::vector<std::string> warnings;
    ReadOptions options;
    options.warnings = &warnings;
    const Chunked chunked = read_chunks(path, n, options, /*take=*/n % 2 == 0);
    ASSERT_TRUE(chunked.status.ok()) << chunked.status.to_string();
    ASSERT_TRUE(chunks_make(chunked.chunks, *whole, n)) << "chunks of " << n;
    EXPECT_EQ(warnings, whole_warnings);
  }
}

// The whole reader's error, or, where it reads the file, the same cloud.
void expect_same_outcome(const std::filesystem::path& path, std::size_t chunk_points) {
  const StatusOr<PointCloud> whole = read_point_cloud(path);
  const Chunked chunked = read_chunks(path, chunk_points);
  if (!whole.ok()) {
    EXPECT_EQ(chunked.status.code(), whole.status().code()) << whole.status().to_string();
    EXPECT_EQ(chunked.status.message(), whole.status().message());
    return;
  }
  ASSERT_TRUE(chunked.status.ok()) << chunked.status.to_string();
  EXPECT_TRUE(chunks_make(chunked.chunks, *whole, chunk_points));
}

PointCloud sample(std::size_t n, bool normals, bool colours) {
  return test::sample_cloud(n, normals, colours);
}

std::string ply(const PointCloud& cloud, PlyEncoding encoding) {
  PlyWriteOptions options;
  options.encoding = encoding;
  options.comments = {"from read_chunks_test"};
  return encode_ply(cloud, options);
}

const Vec3d kFar(500000, 4500000, 100);

TEST(ReadChunks, PlyBinaryBothByteOrdersAndAscii) {
  test::TempDir dir;
  PointCloud cloud = sample(11, true, true);
  cloud.metadata.crs_wkt = "GEOGCS[\"WGS 84\"]";
  write_file(dir.path() / "le.ply", ply(cloud, PlyEncoding::kBinaryLittleEndian));
  write_file(dir.path() / "be.ply", ply(cloud, PlyEncoding::kBinaryBigEndian));
  write_file(dir.path() / "ascii.ply", ply(cloud, PlyEncoding::kAscii));
  write_file(dir.path() / "plain.ply", ply(sample(7, false, false), PlyEncoding::kAscii));
  for (const char* name : {"le.ply", "be.ply", "ascii.ply", "plain.ply"}) {
    expect_chunks_equal_whole(dir.path() / name);
  }
}

TEST(ReadChunks, PlyDoublePositionsFarFromZeroGetTheWholeFilesOrigin) {
  test::TempDir dir;
  const std::vector<Vec3d> points = test::shifted(test::wavy_patch(4), kFar);
  write_file(dir.path() / "far.ply", test::ply_double(points, /*binary=*/true));
  write_file(dir.path() / "far_ascii.ply", test::ply_double(points, /*binary=*/false));
  write_file(dir.path() / "near.ply", test::ply_double(test::wavy_patch(3), /*binary=*/true));
  const StatusOr<PointCloud> far = read_point_cloud(dir.path() / "far.ply");
  ASSERT_TRUE(far.ok());
  ASSERT_NE(far->origin, Vec3d::Zero()) << "the test needs a file that gets an origin";
  for (const char* name : {"far.ply", "far_ascii.ply", "near.ply"}) {
    expect_chunks_equal_whole(dir.path() / name);
  }
}

// Faces before and after the vertices, and vertices with a list property (read item by item).
TEST(ReadChunks, PlyWithOtherElementsAndVariableVertices) {
  test::TempDir dir;
  std::string faces_around =
      "ply\nformat binary_little_endian 1.0\nelement face 2\nproperty list uchar int "
      "vertex_indices\n"
      "element vertex 5\nproperty float x\nproperty float y\nproperty float z\n"
      "element edge 3\nproperty list uchar int vertex_indices\nend_header\n";
  for (int f = 0; f < 2; ++f) {
    test::put<std::uint8_t>(faces_around, 3);
    for (int k = 0; k < 3; ++k) test::put<std::int32_t>(faces_around, f + k);
  }
  for (int i = 0; i < 15; ++i) test::put<float>(faces_around, 0.5f * static_cast<float>(i) - 1.0f);
  for (int e = 0; e < 3; ++e) {
    test::put<std::uint8_t>(faces_around, 2);
    for (int k = 0; k < 2; ++k) test::put<std::int32_t>(faces_around, e + k);
  }
  write_file(dir.path() / "faces.ply", faces_around);

  std::string listed =
      "ply\nformat binary_big_endian 1.0\nelement vertex 6\nproperty double x\nproperty float y\n"
      "property list uchar float uv\nproperty double z\nproperty uchar red\nproperty uchar green\n"
      "property uchar blue\nend_header\n";
  for (int i = 0; i < 6; ++i) {
    test::put<double>(listed, kFar.x() + 0.001 * i, /*big_endian=*/true);
    test::put<float>(listed, 0.25f * static_cast<float>(i), true);
    test::put<std::uint8_t>(listed, static_cast<std::uint8_t>(i % 3));
    for (int k = 0; k < i % 3; ++k) test::put<float>(listed, 1.0f, true);
    test::put<double>(listed, kFar.z() - 0.002 * i, true);
    for (int k = 0; k < 3; ++k)
      test::put<std::uint8_t>(listed, static_cast<std::uint8_t>(40 * i + k));
  }
  write_file(dir.path() / "listed.ply", listed);

  std::string ascii =
      "ply\nformat ascii 1.0\ncomment two faces first\nelement face 2\n"
      "property list uchar int vertex_indices\nelement vertex 4\nproperty float x\n"
      "property float y\nproperty float z\nproperty list uchar int extra\nend_header\n"
      "3 0 1 2\n\n3 1 2 3\n1 2 3 0\n4 5 6 2 7 7\n\n7 8 9 1 5\n10 11 12 0\n";
  write_file(dir.path() / "ascii_faces.ply", ascii);
  for (const char* name : {"faces.ply", "listed.ply", "ascii_faces.ply"}) {
    expect_chunks_equal_whole(dir.path() / name);
  }
}

std::uint16_t u16_at(const std::string& bytes, std::size_t at) {
  std::uint16_t v = 0;
  std::memcpy(&v, bytes.data() + at, sizeof v);
  return v;
}

// The same LAS file with 29 bytes of waveform packet descriptor after each record (point formats
// 1 → 4, 3 → 5, 6 → 9, 8 → 10), which the reader drops.
std::string with_waveform(const std::string& las, int format) {
  std::uint32_t data_offset = 0;
  std::memcpy(&data_offset, las.data() + 96, 4);
  const std::uint16_t length = u16_at(las, 105);
  std::string out = las.substr(0, data_offset);
  out[104] = static_cast<char>(format);
  const auto wider = static_cast<std::uint16_t>(length + 29);
  std::memcpy(out.data() + 105, &wider, 2);
  for (std::size_t at = data_offset; at + length <= las.size(); at += length) {
    out += las.substr(at, length);
    for (int k = 0; k < 29; ++k) out += static_cast<char>(at + static_cast<std::size_t>(k));
  }
  return out;
}

TEST(ReadChunks, LasEveryPointFormatGeoreferencedWithAnOrigin) {
  test::TempDir dir;
  const std::vector<test::HandVlr> vlrs = {{"LASF_Projection", 34735, std::string(16, '\1')},
                                           {"someone", 7, "dropped, with a note"}};
  for (const int format : {0, 1, 2, 3}) {
    write_file(dir.path() / ("f" + std::to_string(format) + ".las"),
               test::hand_las12(format, test::hand_points(9), 0.01, 0, 0, 0, vlrs));
  }
  const StatusOr<PointCloud> source = read_point_cloud(dir.path() / "f3.las");
  ASSERT_TRUE(source.ok());
  ASSERT_NE(source->origin, Vec3d::Zero()) << "the test needs a file that gets an origin";
  PointCloud cloud = *source;
  cloud.las.nir.assign(cloud.size(), 0);
  for (std::size_t i = 0; i < cloud.size(); ++i) cloud.las.nir[i] = static_cast<std::uint16_t>(i);
  cloud.las.extra_bytes_per_point = 2;
  cloud.las.extra_bytes.assign(cloud.size() * 2, 9);
  cloud.metadata.extra_bytes_records.push_back({"LASF_Spec", 4, "extra", std::string(192, '\0')});
  for (const int format : {1, 3, 6, 7, 8}) {
    LasWriteOptions options;
    options.point_format = format;
    const StatusOr<std::string> bytes = encode_las(cloud, options);
    ASSERT_TRUE(bytes.ok()) << bytes.status().to_string();
    write_file(dir.path() / ("w" + std::to_string(format) + ".las"), *bytes);
    const int waveform = format == 1   ? 4
                         : format == 3 ? 5
                         : format == 6 ? 9
                         : format == 8 ? 10
                                       : -1;
    if (waveform > 0) {
      write_file(dir.path() / ("w" + std::to_string(waveform) + ".las"),
                 with_waveform(*bytes, waveform));
    }
  }
  for (const char* name : {"f0.las", "f1.las", "f2.las", "f3.las", "w1.las", "w3.las", "w4.las",
                           "w5.las", "w6.las", "w7.las", "w8.las", "w9.las", "w10.las"}) {
    expect_chunks_equal_whole(dir.path() / name);
  }
}

// Which fields are kept, and how colours scale, is decided by every record: here by one record in
// the last chunk or the first.
TEST(ReadChunks, LasFieldsAreKeptOrDroppedByTheWholeFile) {
  test::TempDir dir;
  std::vector<test::HandLasPoint> points(10);
  for (std::size_t i = 0; i < points.size(); ++i) {
    points[i].x = 100 + static_cast<std::int32_t>(i);
    points[i].y = -200 - static_cast<std::int32_t>(i);
    points[i].z = 7;
    points[i].r = points[i].g = points[i].b = static_cast<std::uint16_t>(20 * i);
  }
  points[9].intensity = 5;
  points[0].point_source_id = 3;
  points[8].return_number = 2;
  points[8].number_of_returns = 2;
  points[4].scan_angle = -3;
  points[9].r = 300;  // one value above 255: every colour scales by its high byte
  write_file(dir.path() / "fields.las", test::hand_las12(3, points, 0.01, 0, 0, 0));
  points[9].r = 30;
  write_file(dir.path() / "low_colours.las", test::hand_las12(2, points, 0.001, 10, 20, 30));
  // An axis wider than float32 keeps exactly: the whole reader warns, so must the chunked one.
  points[5].x = 2000000000;
  points[6].x = -2000000000;
  write_file(dir.path() / "wide.las", test::hand_las12(0, points, 0.01, 0, 0, 0));
  for (const char* name : {"fields.las", "low_colours.las", "wide.las"}) {
    expect_chunks_equal_whole(dir.path() / name);
  }
}

TEST(ReadChunks, XyzEveryVariant) {
  test::TempDir dir;
  write_file(dir.path() / "plain.xyz",
             "\xEF\xBB\xBF# a comment\n1 2 3\n\n// another\n4.5 -5 6e-3\r\n7,8,9\n10 11 12");
  write_file(dir.path() / "intensity.pts", "4\n1 2 3 9\n4 5 6 9\n7 8 9 9\n1 1 1 9\n");
  write_file(dir.path() / "rgb.pts", "3\n1 2 3 9 10 20 30\n4 5 6 9 0 0 255\n7 8 9 9 1 2 3\n");
  // Six columns: colours only because of the last line's 200, normals because of its 0.5.
  const std::string zeros_and_ones = "1 2 3 0 1 0\n4 5 6 1 1 0\n7 8 9 0 0 1\n1 1 1 1 0 1\n";
  write_file(dir.path() / "colours_late.xyz", zeros_and_ones + "2 2 2 200 0 1\n");
  write_file(dir.path() / "normals_late.xyz", zeros_and_ones + "2 2 2 0.5 0 1\n");
  write_file(dir.path() / "only_01.xyz", zeros_and_ones);
  write_file(dir.path() / "unit.xyzrgb", "1 2 3 0 0.5 1\n4 5 6 0.25 1 0\n7 8 9 1 1 1\n");
  write_file(dir.path() / "bytes.xyzrgb", "1 2 3 0 50 1\n4 5 6 25 1 0\n7 8 9 255 1 1\n");
  write_file(dir.path() / "n.xyzn", "1 2 3 0 0 1\n4 5 6 0 1 0\n7 8 9 200 0 0\n");
  write_file(dir.path() / "nine.txt", "1 2 3 0 0 1 10 20 30\n4 5 6 0 1 0 40 50 60\n");
  const std::vector<Vec3d> far = test::shifted(test::wavy_patch(3), kFar);
  write_file(dir.path() / "far.xyz", test::xyz_text(far));
  const StatusOr<PointCloud> far_cloud = read_point_cloud(dir.path() / "far.xyz");
  ASSERT_TRUE(far_cloud.ok());
  ASSERT_NE(far_cloud->origin, Vec3d::Zero()) << "the test needs a file that gets an origin";
  for (const char* name :
       {"plain.xyz", "intensity.pts", "rgb.pts", "colours_late.xyz", "normals_late.xyz",
        "only_01.xyz", "unit.xyzrgb", "bytes.xyzrgb", "n.xyzn", "nine.txt", "far.xyz"}) {
    expect_chunks_equal_whole(dir.path() / name);
  }
}

TEST(ReadChunks, FormatChosenByOptionThenExtensionThenContent) {
  test::TempDir dir;
  write_file(dir.path() / "ply.dat", ply(sample(5, true, false), PlyEncoding::kBinaryLittleEndian));
  write_file(dir.path() / "las.dat", test::hand_las12(1, test::hand_points(4), 0.01, 0, 0, 0));
  write_file(dir.path() / "xyz.dat", "1 2 3\n4 5 6\n");
  write_file(dir.path() / "pcd.dat",
             "# .PCD v0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 3\nDATA ascii\n1 2 3\n4 5 "
             "6\n7 8 9\n");
  for (const char* name : {"ply.dat", "las.dat", "xyz.dat", "pcd.dat"}) {
    expect_chunks_equal_whole(dir.path() / name);
  }
  write_file(dir.path() / "points.ply", "1 2 3 0.5 0.5 0.5\n");
  ReadOptions options;
  options.format = PointCloudFormat::kXyzRgb;
  const Chunked chunked = read_chunks(dir.path() / "points.ply", 1, options);
  ASSERT_TRUE(chunked.status.ok()) << chunked.status.to_string();
  ASSERT_EQ(chunked.chunks.size(), 1u);
  EXPECT_EQ(chunked.chunks[0].colours[0], (Rgb8{128, 128, 128}));
}

// A file cut at every length: the whole reader's error, or where it still reads, its cloud.
TEST(ReadChunks, TruncatedFilesGiveTheWholeReadersError) {
  test::TempDir dir;
  const struct {
    const char* name;
    std::string bytes;
  } files[] = {
      {"t.ply", ply(sample(4, true, true), PlyEncoding::kBinaryLittleEndian)},
      {"t_ascii.ply", ply(sample(3, false, true), PlyEncoding::kAscii)},
      {"t_far.ply", test::ply_double(test::shifted(test::wavy_patch(2), kFar), true)},
      {"t.las", test::hand_las12(3, test::hand_points(3), 0.01, 0, 0, 0)},
      {"t.pts", "3\n1 2 3 9 10 20 30\n4 5 6 9 0 0 255\n7 8 9 9 1 2 3\n"},
  };
  for (const auto& file : files) {
    const auto path = dir.path() / file.name;
    write_file(path, file.bytes);
    // Shortened in place, longest first: rewriting a file is a hundred times slower on ext4.
    for (std::size_t length = file.bytes.size(); length-- > 0;) {
      SCOPED_TRACE(std::string(file.name) + " cut at " + std::to_string(length));
      std::filesystem::resize_file(path, length);
      expect_same_outcome(path, 2);
    }
  }
}

TEST(ReadChunks, CorruptValuesGiveTheWholeReadersErrorWithTheFilesNumbering) {
  test::TempDir dir;
  PointCloud bad = sample(12, true, false);
  bad.positions[7].y() = std::numeric_limits<float>::quiet_NaN();
  write_file(dir.path() / "nan.ply", ply(bad, PlyEncoding::kBinaryLittleEndian));
  write_file(dir.path() / "nan_ascii.ply", ply(bad, PlyEncoding::kAscii));
  write_file(dir.path() / "nan.xyz", "1 2 3\n4 5 6\n7 8 9\n1 2 3\n1 nan 3\n");
  write_file(dir.path() / "word.xyz", "1 2 3\n4 5 6\n7 8 9\n1 2 3\n1 two 3\n");
  write_file(dir.path() / "columns.xyz", "1 2 3\n4 5 6\n7 8 9\n1 2 3 4 5\n");
  write_file(dir.path() / "count.pts", "5\n1 2 3\n4 5 6\n7 8 9\n");
  write_file(dir.path() / "neither.xyzrgb", "1 2 3 0 0 1\n4 5 6 0 1 0\n7 8 9 0.5 0 2\n");
  write_file(dir.path() / "empty.ply",
             "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\n"
             "property float z\nend_header\n");
  write_file(dir.path() / "empty.xyz", "");
  write_file(dir.path() / "trailing.ply",
             ply(sample(3, false, false), PlyEncoding::kBinaryLittleEndian) + "junk");
  for (const char* name :
       {"nan.ply", "nan_ascii.ply", "nan.xyz", "word.xyz", "columns.xyz", "count.pts",
        "neither.xyzrgb", "empty.ply", "empty.xyz", "trailing.ply"}) {
    SCOPED_TRACE(name);
    ASSERT_FALSE(read_point_cloud(dir.path() / name).ok());
    for (const std::size_t n : {1u, 2u, 3u, 100u}) expect_same_outcome(dir.path() / name, n);
  }
  const Chunked nan_chunks = read_chunks(dir.path() / "nan.ply", 3);
  EXPECT_NE(nan_chunks.status.message().find("point 7 "), std::string::npos)
      << nan_chunks.status.message();
  EXPECT_EQ(nan_chunks.chunks.size(), 2u) << "the chunks before the bad point are handed on";
}

// Enough points for the parallel decoders to split a chunk into several ranges.
TEST(ReadChunks, LargerFilesDecodedInParallelRanges) {
  test::TempDir dir;
  PointCloud cloud = sample(150000, true, true);
  write_file(dir.path() / "big.ply", ply(cloud, PlyEncoding::kBinaryBigEndian));
  cloud.normals[140001].z() = std::numeric_limits<float>::infinity();
  write_file(dir.path() / "bad.ply", ply(cloud, PlyEncoding::kBinaryLittleEndian));
  write_file(dir.path() / "big.las", test::hand_las12(3, test::hand_points(100000), 0.01, 0, 0, 0));
  for (const char* name : {"big.ply", "bad.ply", "big.las"}) {
    SCOPED_TRACE(name);
    for (const std::size_t n : {65537u, 140001u}) expect_same_outcome(dir.path() / name, n);
  }
  EXPECT_NE(read_chunks(dir.path() / "bad.ply", 65537).status.message().find("point 140001 "),
            std::string::npos);
}

TEST(ReadChunks, TheSinksErrorEndsTheRead) {
  test::TempDir dir;
  write_file(dir.path() / "s.ply", ply(sample(10, false, false), PlyEncoding::kBinaryLittleEndian));
  write_file(dir.path() / "s.las", test::hand_las12(0, test::hand_points(10), 0.01, 0, 0, 0));
  write_file(dir.path() / "s.xyz", test::xyz_text(test::wavy_patch(3)) + "0 0 0\n");
  write_file(dir.path() / "s.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 10\nDATA ascii\n" +
                                       test::xyz_text(test::wavy_patch(3)) + "0 0 0\n");
  for (const char* name : {"s.ply", "s.las", "s.xyz", "s.pcd"}) {
    int calls = 0;
    const Status status = read_point_cloud_chunks(dir.path() / name, 3, [&](PointCloud&& chunk) {
      EXPECT_EQ(chunk.size(), 3u);
      return ++calls == 2 ? io_error("the disk is full") : Status();
    });
    EXPECT_EQ(calls, 2) << name;
    EXPECT_EQ(status.code(), StatusCode::kIoError) << name;
    EXPECT_EQ(status.message(), "the disk is full") << name;
  }
}

TEST(ReadChunks, RefusesWhatItCannotDo) {
  test::TempDir dir;
  const auto path = dir.path() / "r.xyz";
  write_file(path, "1 2 3\n");
  const auto sink = [](PointCloud&&) { return Status(); };
  EXPECT_EQ(read_point_cloud_chunks(path, 0, sink).code(), StatusCode::kInvalidArgument);
  std::vector<Vec3d> doubles;
  ReadOptions options;
  options.positions_f64 = &doubles;
  EXPECT_EQ(read_point_cloud_chunks(path, 1, sink, options).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(read_point_cloud_chunks(dir.path() / "missing.ply", 1, sink).code(),
            StatusCode::kNotFound);
}

class StageProgress : public Progress {
 public:
  struct Stage {
    std::string name;
    std::uint64_t total = 0, done = 0;
  };
  void begin_stage(std::string_view name, std::uint64_t total, std::string_view) override {
    stages.push_back({std::string(name), total, 0});
  }
  void advance(std::uint64_t done) override { stages.back().done += done; }
  void end_stage() override {}
  std::vector<Stage> stages;
};

TEST(ReadChunks, ProgressCountsEveryPassOverTheFilesBytes) {
  test::TempDir dir;
  write_file(dir.path() / "p.ply", ply(sample(50, true, true), PlyEncoding::kBinaryLittleEndian));
  write_file(dir.path() / "p_ascii.ply", ply(sample(20, true, true), PlyEncoding::kAscii));
  write_file(dir.path() / "p_far.ply",
             test::ply_double(test::shifted(test::wavy_patch(5), kFar), true) + "\n");
  write_file(dir.path() / "p.las", test::hand_las12(1, test::hand_points(30), 0.01, 0, 0, 0));
  write_file(dir.path() / "p.xyz", "\xEF\xBB\xBF" + test::xyz_text(test::wavy_patch(5)));
  const struct {
    const char* name;
    std::vector<std::string> stages;
  } cases[] = {
      {"p.ply", {"reading p.ply"}},
      {"p_ascii.ply", {"reading p_ascii.ply"}},
      {"p_far.ply", {"scanning p_far.ply", "reading p_far.ply"}},
      {"p.las", {"scanning p.las", "reading p.las"}},
      {"p.xyz", {"scanning p.xyz", "reading p.xyz"}},
  };
  for (const auto& c : cases) {
    StageProgress progress;
    ReadOptions options;
    options.progress = &progress;
    ASSERT_TRUE(read_chunks(dir.path() / c.name, 7, options).status.ok()) << c.name;
    ASSERT_EQ(progress.stages.size(), c.stages.size()) << c.name;
    for (std::size_t s = 0; s < c.stages.size(); ++s) {
      EXPECT_EQ(progress.stages[s].name, c.stages[s]);
      EXPECT_EQ(progress.stages[s].total, std::filesystem::file_size(dir.path() / c.name));
      EXPECT_EQ(progress.stages[s].done, progress.stages[s].total) << c.stages[s];
    }
  }
}

}  // namespace
}  // namespace sspc
