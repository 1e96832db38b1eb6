// What the fuzz targets share: a check that aborts (so libFuzzer and the CTest replay both see
// a broken invariant as a crash) and byte-span helpers.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <span>

#include "sspc/point_cloud.hpp"

namespace sspc::fuzz {

[[noreturn]] inline void fail(const char* file, int line, const char* what) {
  std::fprintf(stderr, "%s:%d: fuzz invariant broken: %s\n", file, line, what);
  std::abort();
}

inline std::span<const std::byte> as_bytes(const std::uint8_t* data, std::size_t size) {
  return {reinterpret_cast<const std::byte*>(data), size};
}

}  // namespace sspc::fuzz

#define SSPC_FUZZ_CHECK(cond) \
  ((cond) ? static_cast<void>(0) : ::sspc::fuzz::fail(__FILE__, __LINE__, #cond))

// A reader's success must be a cloud that every later stage may trust.
#define SSPC_FUZZ_CHECK_CLOUD(cloud)         \
  do {                                       \
    SSPC_FUZZ_CHECK((cloud).validate().ok()); \
    SSPC_FUZZ_CHECK(!(cloud).empty());       \
  } while (0)
