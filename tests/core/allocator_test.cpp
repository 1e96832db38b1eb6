// keep_freed_memory (sspc/allocator.hpp): after it, a large block comes from the heap, not from a
// mapping of its own that free() would return to the system (to be faulted in again next time).
#include "sspc/allocator.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "core/resident_watch.hpp"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace sspc {
namespace {

TEST(Allocator, ALargeBlockIsNotMappedOnItsOwnAfterKeepFreedMemory) {
#if !defined(__GLIBC__) || defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  GTEST_SKIP() << "glibc's own allocator only (a sanitizer replaces it)";
#else
  constexpr std::size_t kBlock = 64u << 20;  // above glibc's largest default threshold (32 MB)
  keep_freed_memory();
  const std::size_t mapped_before = mallinfo2().hblkhd;
  void* block = std::malloc(kBlock);
  ASSERT_NE(block, nullptr);
  std::memset(block, 1, kBlock);
  EXPECT_LT(mallinfo2().hblkhd, mapped_before + kBlock);  // glibc's default maps it on its own
  std::free(block);
#endif
}

// Freed memory below a block still in use stays resident after keep_freed_memory, and
// release_freed_memory gives it back (what a tiled encode does between tiles near its limit).
TEST(Allocator, ReleaseGivesBackFreedMemoryBelowABlockInUse) {
#if !defined(__GLIBC__) || !defined(__linux__) || defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  GTEST_SKIP() << "glibc's own allocator on Linux only (a sanitizer replaces it)";
#else
  constexpr std::size_t kBlock = 64u << 20;
  keep_freed_memory();
  void* below = std::malloc(kBlock);
  void* above = std::malloc(1u << 20);  // pins the heap's top above `below`
  ASSERT_NE(below, nullptr);
  ASSERT_NE(above, nullptr);
  std::memset(below, 1, kBlock);
  std::memset(above, 1, 1u << 20);
  asm volatile("" : : "r"(below), "r"(above) : "memory");  // the pages written, not elided with the frees
  std::free(below);
  const std::size_t kept = resident_bytes();
  ASSERT_GT(kept, kBlock);
  EXPECT_TRUE(release_freed_memory());
  EXPECT_LT(resident_bytes() + kBlock / 2, kept);
  std::free(above);
#endif
}

// After use_one_arena, memory one thread frees is reused by another: small blocks the main
// thread freed (and the allocator kept) take no new pages when a worker, which allocated before,
// allocates as many again. With an arena a thread, the worker's own arena grows by all of them.
TEST(Allocator, OneArenaReusesWhatAnotherThreadFreed) {
#if !defined(__GLIBC__) || !defined(__linux__) || defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  GTEST_SKIP() << "glibc's own allocator on Linux only (a sanitizer replaces it)";
#else
  keep_freed_memory();
  use_one_arena();
  constexpr std::size_t kBlocks = 32768, kSize = 1024;  // 32 MiB in blocks under the mmap threshold
  const auto allocate = [] {
    std::vector<void*> blocks(kBlocks);
    for (void*& b : blocks) {
      b = std::malloc(kSize);
      std::memset(b, 1, kSize);
    }
    asm volatile("" : : "r"(blocks.data()) : "memory");
    return blocks;
  };
  std::atomic<int> step{0};
  std::size_t grown = 0;
  std::thread worker([&] {
    void* first = std::malloc(64);  // the worker takes its arena now, while the main thread has one
    asm volatile("" : : "r"(first) : "memory");
    step = 1;
    while (step.load() != 2) std::this_thread::yield();
    const std::size_t before = resident_bytes();
    const std::vector<void*> blocks = allocate();
    grown = resident_bytes() - before;
    for (void* b : blocks) std::free(b);
    std::free(first);
  });
  while (step.load() != 1) std::this_thread::yield();
  for (void* b : allocate()) std::free(b);  // on the main thread, kept by the allocator
  step = 2;
  worker.join();
  EXPECT_LT(grown, kBlocks * kSize / 4);
#endif
}

// --memory-limit enforced: past its limit the watch's check fails and says by how much; under
// it, or without one, it passes.
TEST(ResidentWatch, FailsOncePastItsLimit) {
  const std::uint64_t now = resident_bytes();
  ASSERT_GT(now, 1u << 20);
  ResidentWatch small(now / 2);
  const Status past = small.check("tile 2 of 5");
  ASSERT_FALSE(past.ok());
  EXPECT_EQ(past.code(), StatusCode::kResourceExhausted);
  EXPECT_NE(past.message().find("by tile 2 of 5, past the memory limit of " + std::to_string((now / 2) >> 20) + " MiB"),
            std::string::npos)
      << past.message();
  EXPECT_TRUE(ResidentWatch(now * 4 + (1u << 30)).check("tile 1 of 1").ok());
  EXPECT_TRUE(ResidentWatch(0).check("tile 1 of 1").ok());
  // The sampler sees a peak between checks: a block touched and freed is still counted.
  release_freed_memory();  // what earlier tests kept would take the block without a fault
  ResidentWatch watch(now * 4 + (1u << 30));
  const std::uint64_t before = watch.peak();
  {
    std::vector<char> block(std::size_t{64} << 20, 1);
    std::this_thread::sleep_for(std::chrono::milliseconds(80));
    EXPECT_NE(block[12345], 0);
  }
  release_freed_memory();
  EXPECT_GE(watch.peak(), before + (std::uint64_t{48} << 20));
}

}  // namespace
}  // namespace sspc
