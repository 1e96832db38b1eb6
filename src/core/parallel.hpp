// Parallel loops on TBB that keep sspc deterministic whatever the thread count.
//
// parallel_for hands out index ranges; a body that writes only to its own indices gives the
// same result on 1 or 32 threads. deterministic_sum splits the range into fixed chunks that do
// not depend on the thread count and adds the partial sums in order, so floating-point sums are
// bit-identical across runs and thread counts.
//
// Under ThreadSanitizer the same loops run on std::threads instead (see detail::run_chunks):
// TSan sees only the synchronisation of instrumented code, and the system's TBB is not
// instrumented, so every hand-off of a task between TBB's threads looks like a race. Threads
// that are started and joined are synchronisation TSan understands, so what it reports there are
// races in sspc's own loop bodies, which is what the TSan build is for.
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_sort.h>
#include <tbb/task_arena.h>

#if defined(__SANITIZE_THREAD__)
#define SSPC_THREAD_SANITIZER 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define SSPC_THREAD_SANITIZER 1
#endif
#endif

#ifdef SSPC_THREAD_SANITIZER
#include <tbb/global_control.h>

#include <atomic>
#include <thread>
#endif

namespace sspc {

#ifdef SSPC_THREAD_SANITIZER
namespace detail {

// body(c) for every c in [0, chunks), on as many std::threads as TBB would use (at least two
// when allowed, so that TSan sees bodies run concurrently even on one core).
template <typename Body>
void run_chunks(std::size_t chunks, Body&& body) {
  const std::size_t allowed =
      tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism);
  const std::size_t cores = std::max(2u, std::thread::hardware_concurrency());
  const std::size_t n = std::min({allowed, cores, chunks});
  std::atomic<std::size_t> next{0};
  const auto work = [&] {
    for (std::size_t c = next.fetch_add(1); c < chunks; c = next.fetch_add(1)) body(c);
  };
  std::vector<std::thread> threads;
  for (std::size_t t = 1; t < n; ++t) threads.emplace_back(work);
  work();
  for (std::thread& t : threads) t.join();
}

}  // namespace detail
#endif

// body(begin, end) for consecutive sub-ranges of [begin, end).
template <typename Body>
void parallel_for_ranges(std::size_t begin, std::size_t end, std::size_t grain, Body&& body) {
  if (end <= begin) return;
#ifdef SSPC_THREAD_SANITIZER
  // Ranges of at least `grain`, about 64 in all: enough for the threads to interleave.
  const std::size_t size = std::max({grain, std::size_t{1}, (end - begin + 63) / 64});
  detail::run_chunks((end - begin + size - 1) / size, [&](std::size_t c) {
    const std::size_t b = begin + c * size;
    body(b, std::min(end, b + size));
  });
#else
  tbb::parallel_for(tbb::blocked_range<std::size_t>(begin, end, std::max<std::size_t>(grain, 1)),
                    [&](const tbb::blocked_range<std::size_t>& r) { body(r.begin(), r.end()); });
#endif
}

// body(i) for every i in [begin, end).
template <typename Body>
void parallel_for(std::size_t begin, std::size_t end, std::size_t grain, Body&& body) {
  parallel_for_ranges(begin, end, grain, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) body(i);
  });
}

// a() and b(), possibly at the same time.
template <typename A, typename B>
void parallel_invoke(A&& a, B&& b) {
#ifdef SSPC_THREAD_SANITIZER
  detail::run_chunks(2, [&](std::size_t c) { c == 0 ? a() : b(); });
#else
  tbb::parallel_invoke(a, b);
#endif
}

// Runs f() so that the thread running it, while it waits inside a parallel loop of f's, takes
// on only f's own tasks. Needed where a task waits for work that another task does (a cache
// entry being built): without it, the builder's nested loop may pick up a waiting task and
// wait for itself.
template <typename F>
void isolated(F&& f) {
#ifdef SSPC_THREAD_SANITIZER
  f();
#else
  tbb::this_task_arena::isolate(f);
#endif
}

// Sorts [first, last) by `less`. With a total order (no two elements equivalent) the result is
// the same whatever the thread count. std::sort under TSan (TBB's sort is not instrumented).
template <typename It, typename Less>
void parallel_sort(It first, It last, Less less) {
#ifdef SSPC_THREAD_SANITIZER
  std::sort(first, last, less);
#else
  tbb::parallel_sort(first, last, less);
#endif
}

// Sum of term(i) over [begin, end), identical bit for bit whatever the thread count.
// `T` needs a value-initialised zero and operator+=.
template <typename T, typename Term>
T deterministic_sum(std::size_t begin, std::size_t end, Term&& term, std::size_t chunk = 4096) {
  if (end <= begin) return T{};
  const std::size_t chunks = (end - begin + chunk - 1) / chunk;
  std::vector<T> partial(chunks, T{});
  parallel_for(0, chunks, 1, [&](std::size_t c) {
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
