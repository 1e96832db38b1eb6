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

#include "codec/checksum.hpp"
#include "codec/container_format.hpp"
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

}  // namespace
}  // namespace sspc
