// The C library's allocator told to keep freed memory for reuse (a process-wide policy, for
// programs that encode large clouds: the CLI and Dask workers call it; the library never does).
//
// By default glibc gives every block above a sliding threshold (at most 32 MB) its own mapping
// and returns freed memory at the heap's top beyond 128 KB, so an encode that allocates and frees
// tens of megabytes per patch batch and per tile faults the same pages in again and again
// (the kernel zeroes each). Keeping them: autzen under --memory-limit 2G on 2 cores 107.8 s ->
// 77.2 s (system time 24.7 -> 9.3 s), peak 1.99 -> 1.92 GB; one 1M-point tile job 14.2 -> 12.8 s.
// The process's resident size then stays near its peak until it exits, and the peak itself grows
// with what is kept: 100M points in tiles of 5.75M peaked at 2.47 GB, 1.85 without;
// tile_points_for_memory sizes tiles with it.
#pragma once

#include <cstddef>

namespace sspc {

void keep_freed_memory();

// The process's resident memory now (Linux's /proc/self/statm), in bytes; 0 where unknown.
std::size_t resident_bytes();

// Gives the freed memory the allocator keeps back to the system, wherever it lies in the heap
// (glibc's malloc_trim), not only at the heap's top; returns whether any was given back. A no-op
// returning false outside glibc.
//
// A tiled encode under a memory limit calls it between tiles once the process holds more than 7/8 of
// the limit (TiledEncoder::run). Blocks that outlive a tile (the model's patch records, grown as
// tiles are added) end up above freed space that no later block fits, and that space stays
// resident: 1B points in 344 tiles under a 2 GiB limit peaked at 2,275 MiB. Giving memory back
// after every tile instead costs 15-25% more CPU time (10M points in 15 tiles under 512 MiB:
// 133-152 CPU s against 116-121; the next tile faults its pages in again) for a 5% lower peak.
bool release_freed_memory();

// One allocator arena for every thread (glibc's M_ARENA_MAX = 1), for a program whose memory is
// a budget it reports (the renderer: the CLI's render calls it; the library never does). glibc
// gives each thread that allocates at once an arena of its own, and what one thread frees in it
// only that arena reuses: a compressed scene's bricks, built and evicted by every worker, then
// held up to a budget in each. autzen level 5 at 1024², 2 threads: resident growth 88.9 ->
// 73.4 MB at a 32 MiB budget (6.9 bytes a point; scene and frame buffers as --json reports them,
// 67.7 MB, now 92% of it, 76% before), 129 -> 109 MB at 64 MiB, the frame as fast (23.95 s ->
// 23.93 s, 20.36 -> 20.55 s). Must run before other threads allocate. A no-op outside glibc.
void use_one_arena();

}  // namespace sspc
