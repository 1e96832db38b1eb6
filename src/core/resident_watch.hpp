// --memory-limit as a bound, not only an estimate: the process's resident size, sampled every
// 20 ms on a thread of its own, is checked where the work can stop (a tiled encode: at each
// tile's end); past the limit the caller stops with the error check() gives, which says by how
// much. The tiles are sized to stay well under it (tile_points_for_memory: 1B points peaked at
// half a 2 GiB limit, docs/RESULTS.md "Scale").
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <stop_token>
#include <string>
#include <thread>

#include "sspc/allocator.hpp"
#include "sspc/status.hpp"

namespace sspc {

class ResidentWatch {
 public:
  // `limit` 0: no limit, no thread.
  explicit ResidentWatch(std::uint64_t limit) : limit_(limit) {
    if (limit_ == 0) return;
    sampler_ = std::jthread([this](const std::stop_token& stop) {
      while (!stop.stop_requested()) {
        sample();
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
    });
  }
  ResidentWatch(const ResidentWatch&) = delete;
  ResidentWatch& operator=(const ResidentWatch&) = delete;

  std::uint64_t peak() {
    sample();
    return peak_.load();
  }
  // kResourceExhausted once the resident size has passed the limit; `where` says how far the
  // work got ("tile 3 of 16").
  Status check(const std::string& where) {
    if (limit_ == 0) return Status();
    const std::uint64_t held = peak();
    if (held <= limit_) return Status();
    return resource_exhausted("the process held " + std::to_string(held >> 20) + " MiB by " + where +
                              ", past the memory limit of " + std::to_string(limit_ >> 20) +
                              " MiB; give a larger limit or smaller tiles");
  }

 private:
  void sample() {
    const std::uint64_t now = resident_bytes();
    std::uint64_t seen = peak_.load();
    while (now > seen && !peak_.compare_exchange_weak(seen, now)) {
    }
  }
  std::uint64_t limit_;
  std::atomic<std::uint64_t> peak_{0};
  std::jthread sampler_;  // last: stopped and joined before the members it reads go
};

}  // namespace sspc
