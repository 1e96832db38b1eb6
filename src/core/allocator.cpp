#include "sspc/allocator.hpp"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace sspc {

void keep_freed_memory() {
#if defined(__GLIBC__)
  constexpr int kLarge = 1 << 30;  // a block's own mapping only above 1 GiB; trim only above 1 GiB free
  mallopt(M_MMAP_THRESHOLD, kLarge);
  mallopt(M_TRIM_THRESHOLD, kLarge);
#endif
}

}  // namespace sspc
