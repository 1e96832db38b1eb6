// Counts in headers are never trusted beyond what the file's size can hold: small files that
// claim billions of points (PLY element counts, PCD POINTS and WIDTH × HEIGHT, a PCD compressed
// body's uncompressed size, a PTS point count, .sspc code-word, patch and point counts) are
// refused at once, and no single allocation made while reading one is more than a small
// multiple of its size.
//
// This executable replaces the global operator new to record the largest request (it runs
// alone for that reason), and checks the process's peak RSS as well.
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <new>
#include <string>

#include <zstd.h>

#include "encoder/container_writer.hpp"
#include "format/block_codec.hpp"
#include "format/checksum.hpp"
#include "format/container_format.hpp"
#include "format/container_test_models.hpp"
#include "sspc/compressed_model.hpp"
#include "sspc/io.hpp"
#include "test_util.hpp"

namespace {
std::atomic<std::size_t> g_largest_allocation{0};

void* counted_allocation(std::size_t n) {
  std::size_t seen = g_largest_allocation.load(std::memory_order_relaxed);
  while (n > seen && !g_largest_allocation.compare_exchange_weak(seen, n)) {
  }
  if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}
}  // namespace

void* operator new(std::size_t n) { return counted_allocation(n); }
void* operator new[](std::size_t n) { return counted_allocation(n); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }

namespace sspc {
namespace {

constexpr std::size_t kAllowedBytes = std::size_t{1} << 20;  // far below the claimed gigabytes

long peak_rss_kib() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss;
}

std::span<const std::byte> bytes_of(const std::string& s) {
  return std::as_bytes(std::span<const char>(s.data(), s.size()));
}

using Reader = StatusOr<PointCloud> (*)(std::span<const std::byte>, std::string_view);

// Reads `file` with `read` and expects a quick error naming the claimed count, with no
// allocation above kAllowedBytes and no growth of the peak RSS beyond a few MiB.
void expect_refused_cheaply(Reader read, const std::string& file, const std::string& expected) {
  SCOPED_TRACE(file.substr(0, 60));
  EXPECT_LT(file.size(), 600u);
  const long rss_before = peak_rss_kib();
  g_largest_allocation = 0;
  const auto start = std::chrono::steady_clock::now();
  const StatusOr<PointCloud> r = read(bytes_of(file), "huge");
  const auto elapsed = std::chrono::steady_clock::now() - start;
  const std::size_t largest = g_largest_allocation.load();
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find(expected), std::string::npos) << r.status().message();
  EXPECT_LT(largest, kAllowedBytes);
  EXPECT_LT(peak_rss_kib() - rss_before, 16 * 1024);
  EXPECT_LT(elapsed, std::chrono::milliseconds(500));
}

const std::string kBillions = "4000000000";

TEST(AllocationLimit, PlyElementCounts) {
  const std::string head = "ply\nformat ascii 1.0\nelement vertex " + kBillions +
                           "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
  expect_refused_cheaply(read_ply, head + "0 0 0\n", kBillions);
  for (const char* format : {"binary_little_endian", "binary_big_endian"}) {
    const std::string bin = "ply\nformat " + std::string(format) + " 1.0\nelement vertex " +
                            kBillions +
                            "\nproperty float x\nproperty float y\nproperty float z\nend_header\n" +
                            std::string(12, '\0');
    expect_refused_cheaply(read_ply, bin, kBillions);
  }
  // A list element before the vertices, whose item size is only known while reading.
  const std::string lists =
      "ply\nformat binary_little_endian 1.0\nelement face " + kBillions +
      "\nproperty list uchar int idx\nelement vertex 1\nproperty float x\nproperty float y\n"
      "property float z\nend_header\n" + std::string(16, '\0');
  expect_refused_cheaply(read_ply, lists, "");
}

TEST(AllocationLimit, PcdPointCounts) {
  const auto header = [](const std::string& data) {
    return "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH " + kBillions +
           "\nHEIGHT 1\nPOINTS " + kBillions + "\nDATA " + data + "\n";
  };
  expect_refused_cheaply(read_pcd, header("ascii") + "0 0 0\n", kBillions);
  expect_refused_cheaply(read_pcd, header("binary") + std::string(12, '\0'), kBillions);
  // binary_compressed: 12 bytes of stream claiming 48 GB uncompressed (which also does not
  // match the points), and a claim that matches a small POINTS but not what LZF can expand to.
  std::string bomb = header("binary_compressed");
  const std::string sizes("\x0c\x00\x00\x00\xff\xff\xff\xff", 8);
  expect_refused_cheaply(read_pcd, bomb + sizes + std::string(12, '\0'), "uncompressed size");
  std::string small =
      "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 10000000\n"
      "HEIGHT 1\nPOINTS 10000000\nDATA binary_compressed\n";
  const std::string claim("\x02\x00\x00\x00\x00\x0e\x27\x07", 8);  // 2 bytes -> 120,000,000
  expect_refused_cheaply(read_pcd, small + claim + std::string(2, '\0'), "LZF");
  // WIDTH × HEIGHT overflowing 64 bits.
  expect_refused_cheaply(
      read_pcd,
      "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 4294967296\n"
      "HEIGHT 4294967296\nPOINTS 1\nDATA ascii\n0 0 0\n",
      "");
}

TEST(AllocationLimit, PtsPointCount) {
  expect_refused_cheaply(read_xyz, kBillions + "\n0 0 0\n1 1 1\n", kBillions);
  expect_refused_cheaply(read_xyz, "18446744073709551615\n0 0 0\n", "");
}

// An .sspc file of the golden model whose header is edited to claim 2^32 − 1 code words and
// patches in blocks of one, with a valid header CRC: the seek tables that would need cannot
// be in the file, so open() refuses it before allocating for them.
TEST(AllocationLimit, SspcCounts) {
  std::ifstream in(test::data_path("codec/golden_v2.sspc"), std::ios::binary);
  std::string golden{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  ASSERT_GT(golden.size(), codec::kHeaderSize);
  const auto store_u32 = [](std::string& s, std::size_t at, std::uint32_t v) {
    for (std::size_t i = 0; i < 4; ++i) s[at + i] = static_cast<char>((v >> (8 * i)) & 0xFF);
  };
  const auto fix_crc = [&](std::string& s) {
    store_u32(s, codec::kHeaderCrcOffset,
              codec::crc32_of(bytes_of(s).first(codec::kHeaderCrcOffset)));
  };
  for (const std::size_t field : {std::size_t{72}, std::size_t{76}}) {
    std::string file = golden;
    store_u32(file, field, 0xFFFFFFFFu);
    store_u32(file, 88, 1);
    store_u32(file, 92, 1);
    fix_crc(file);
    const long rss_before = peak_rss_kib();
    g_largest_allocation = 0;
    auto model = CompressedModel::from_bytes(file);
    ASSERT_FALSE(model.ok());
    EXPECT_EQ(model.status().code(), StatusCode::kCorrupt);
    EXPECT_NE(model.status().message().find("seek table"), std::string::npos)
        << model.status().message();
    EXPECT_LT(g_largest_allocation.load(), kAllowedBytes);
    EXPECT_LT(peak_rss_kib() - rss_before, 16 * 1024);
  }
}

void store_le(std::string& s, std::size_t at, std::uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) {
    s[at + static_cast<std::size_t>(i)] = static_cast<char>((v >> (8 * i)) & 0xFF);
  }
}
std::uint64_t load_le(const std::string& s, std::size_t at, int bytes) {
  std::uint64_t v = 0;
  for (int i = bytes - 1; i >= 0; --i) {
    v = (v << 8) | static_cast<std::uint8_t>(s[at + static_cast<std::size_t>(i)]);
  }
  return v;
}

// A decompression bomb with valid CRCs: the code-book block replaced by a zstd frame of a few
// hundred bytes that expands to 8 MiB, a payload that holds, by the format's 64 points per
// byte, 2^29 points (15 GB once decoded). The reader refuses the seek entry, whose raw size is
// more than kMaxBlockExpansion times its stored size, before it allocates anything.
TEST(AllocationLimit, SspcZstdBomb) {
  test::ModelShape shape;
  shape.side = 8;
  shape.normals = false;
  shape.colours = false;
  codec::QuantOptions options;
  options.codewords_per_block = 1024;  // one code-book block
  auto encoded = codec::encode_container(test::make_plane_model(shape), options);
  ASSERT_TRUE(encoded.ok()) << encoded.status().to_string();
  const std::string& file = *encoded;
  const auto section = [&](std::size_t i, std::size_t field) {
    return load_le(file, codec::kSectionTableOffset + i * codec::kSectionEntrySize + field, 8);
  };
  const std::uint64_t codewords = load_le(file, 72, 4);
  ASSERT_EQ(section(1, 16), codec::kCodebookSeekEntrySize);  // one block

  // The payload: all points in the first code word, then the position stream of zeros.
  const std::size_t stream = std::size_t{8} << 20;
  std::string raw;
  const auto varint = [&raw](std::uint64_t v) {
    for (; v >= 0x80; v >>= 7) raw.push_back(static_cast<char>((v & 0x7F) | 0x80));
    raw.push_back(static_cast<char>(v));
  };
  const std::uint64_t points = std::uint64_t{codec::kMaxPointsPerByte} * stream;
  varint(points);
  for (std::uint64_t c = 1; c < codewords; ++c) varint(0);
  varint(stream);
  raw.append(stream, '\0');
  std::string frame(ZSTD_compressBound(raw.size()), '\0');
  const std::size_t n = ZSTD_compress(frame.data(), frame.size(), raw.data(), raw.size(), 19);
  ASSERT_FALSE(ZSTD_isError(n));
  frame.resize(n);
  ASSERT_LT(frame.size(), 2048u);

  // Splice it in and make every size, offset and CRC consistent.
  std::string bomb = file.substr(0, codec::kHeaderSize) + frame +
                     file.substr(section(1, 8));
  const std::int64_t shift = static_cast<std::int64_t>(frame.size()) -
                             static_cast<std::int64_t>(section(0, 16));
  store_le(bomb, codec::kSectionTableOffset + 16, frame.size(), 8);
  for (std::size_t i = 1; i < codec::kSectionCount; ++i) {
    const std::size_t at = codec::kSectionTableOffset + i * codec::kSectionEntrySize + 8;
    store_le(bomb, at, static_cast<std::uint64_t>(static_cast<std::int64_t>(load_le(bomb, at, 8)) + shift), 8);
  }
  const std::size_t seek = codec::kHeaderSize + frame.size();
  store_le(bomb, seek + 8, frame.size(), 4);
  store_le(bomb, seek + 12, raw.size(), 4);
  store_le(bomb, seek + 16, codec::crc32_of(bytes_of(frame)), 4);
  store_le(bomb, seek + 28, points, 4);
  store_le(bomb, 80, points, 8);
  const auto crc = [&bomb](std::uint64_t offset, std::uint64_t size) {
    return codec::crc32_of(bytes_of(bomb).subspan(offset, size));
  };
  for (std::size_t i = 0; i < codec::kSectionCount; ++i) {
    const std::size_t e = codec::kSectionTableOffset + i * codec::kSectionEntrySize;
    store_le(bomb, e + 4, crc(load_le(bomb, e + 8, 8), load_le(bomb, e + 16, 8)), 4);
  }
  store_le(bomb, codec::kHeaderCrcOffset, crc(0, codec::kHeaderCrcOffset), 4);
  ASSERT_LT(bomb.size(), 4096u);

  const long rss_before = peak_rss_kib();
  g_largest_allocation = 0;
  auto model = CompressedModel::from_bytes(bomb);
  if (model.ok()) {
    // Without the expansion limit the file opens; decoding it must not allocate for 2^29 points.
    auto all = model->decode_all();
    ADD_FAILURE() << "the bomb opened; decode: " << all.status().to_string();
  } else {
    EXPECT_EQ(model.status().code(), StatusCode::kCorrupt);
    EXPECT_NE(model.status().message().find("cannot expand"), std::string::npos)
        << model.status().message();
  }
  EXPECT_LT(g_largest_allocation.load(), kAllowedBytes);
  EXPECT_LT(peak_rss_kib() - rss_before, 16 * 1024);
}

}  // namespace
}  // namespace sspc
