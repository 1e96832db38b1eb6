// Parallel loops on TBB that keep sspc deterministic whatever the thread count.
//
// parallel_for hands out index ranges; a body that writes only to its own indices gives the
// same result on 1 or 32 threads. deterministic_sum splits the range into fixed chunks that do
// not depend on the thread count and adds the partial sums in order, so floating-point sums are
// bit-identical across runs and thread counts.
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace sspc {

// body(begin, end) for consecutive sub-ranges of [begin, end).
template <typename Body>
void parallel_for_ranges(std::size_t begin, std::size_t end, std::size_t grain, Body&& body) {
  if (end <= begin) return;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(begin, end, std::max<std::size_t>(grain, 1)),
                    [&](const tbb::blocked_range<std::size_t>& r) { body(r.begin(), r.end()); });
}

// body(i) for every i in [begin, end).
template <typename Body>
void parallel_for(std::size_t begin, std::size_t end, std::size_t grain, Body&& body) {
  parallel_for_ranges(begin, end, grain, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) body(i);
  });
}

// Sum of term(i) over [begin, end), identical bit for bit whatever the thread count.
// `T` needs a value-initialised zero and operator+=.
template <typename T, typename Term>
T deterministic_sum(std::size_t begin, std::size_t end, Term&& term, std::size_t chunk = 4096) {
  if (end <= begin) return T{};
  const std::size_t chunks = (end - begin + chunk - 1) / chunk;
  std::vector<T> partial(chunks, T{});
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    const std::size_t b = begin + c * chunk;
    const std::size_t e = std::min(end, b + chunk);
    T acc{};
    for (std::size_t i = b; i < e; ++i) acc += term(i);
    partial[c] = acc;
  });
  T total{};
  for (const T& p : partial) total += p;
  return total;
}

}  // namespace sspc
