// keep_freed_memory (sspc/allocator.hpp): after it, a large block comes from the heap, not from a
// mapping of its own that free() would return to the system (to be faulted in again next time).
#include "sspc/allocator.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>

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

}  // namespace
}  // namespace sspc
