// SSPC_DCHECK(condition): an assertion of the code's own invariants (an index the code computed
// is in range, offsets it built are monotone, a buffer it sized has the size it expects). Never
// for input: a file or an argument that breaks a rule gets a Status. Active in debug builds and
// in sanitizer builds (SSPC_ENABLE_DCHECK, set by SSPC_SANITIZE), where a failure aborts with
// the condition, file and line; in release builds the condition is not evaluated.
#pragma once

#include <cstdio>
#include <cstdlib>

namespace sspc::detail {

[[noreturn]] inline void dcheck_failed(const char* condition, const char* file, int line) {
  std::fprintf(stderr, "%s:%d: SSPC_DCHECK(%s) failed\n", file, line, condition);
  std::abort();
}

}  // namespace sspc::detail

#if !defined(NDEBUG) || defined(SSPC_ENABLE_DCHECK)
#define SSPC_DCHECK(condition) \
  ((condition) ? void(0) : ::sspc::detail::dcheck_failed(#condition, __FILE__, __LINE__))
#else
#define SSPC_DCHECK(condition) void(sizeof(bool(condition)))
#endif
