// Elapsed wall time, for the seconds the encoder's and the renderer's statistics report.
#pragma once

#include <chrono>

namespace sspc {

inline double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace sspc
