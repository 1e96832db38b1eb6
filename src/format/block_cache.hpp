// A least-recently-used cache of decoded blocks, shared by the threads that query one
// CompressedModel (a renderer's rays hit the same few blocks again and again), bounded in bytes.
// Sharded by block id so that threads rarely wait on one another's lock; values are shared_ptr
// so that an entry evicted while a query still uses it stays alive until the query is done.
//
// The bound was a count of blocks; with format 3's patches of up to 4096 points a code-word
// block decodes to about 0.45 MB (autzen, level 5: 32 code words of 870 points, 16 bytes a
// point), so 512 blocks held autzen's whole code book decoded, 160 MB, beside a renderer's
// 64 MiB budget for its bricks (heaptrack, docs/RESULTS.md "Renderer: speed and memory").
#pragma once

#include <algorithm>
#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <list>
#include <memory>
#include <mutex>
#include <unordered_map>
#include <utility>

namespace sspc::codec {

template <typename T>
class BlockCache {
 public:
  explicit BlockCache(std::uint64_t budget_bytes) { set_budget(budget_bytes); }

  // Evicts down to the new budget. A shard keeps its most recent block beyond its share of the
  // budget while the whole cache is within it, so that a block larger than a share is not
  // decoded again by the next query; past the budget, other shards give up theirs (trim), and
  // the cache holds at most the budget and the block just decoded. (Each shard keeping one
  // block whatever the budget held 16 of autzen's code-word blocks of 16,384-point patches,
  // about 8 MB each, under a renderer's 64 MiB.)
  void set_budget(std::uint64_t bytes) {
    budget_.store(bytes, std::memory_order_relaxed);
    per_shard_.store(bytes / kShards, std::memory_order_relaxed);
    for (Shard& s : shards_) {
      std::lock_guard<std::mutex> lock(s.mutex);
      evict(s);
    }
    trim(kShards);
  }
  std::uint64_t budget() const { return budget_.load(std::memory_order_relaxed); }
  // What the cache holds now, and the most it has held since the last reset_peak().
  std::uint64_t bytes() const { return bytes_.load(std::memory_order_relaxed); }
  std::uint64_t peak_bytes() const { return peak_.load(std::memory_order_relaxed); }
  void reset_peak() { peak_.store(bytes(), std::memory_order_relaxed); }

  std::shared_ptr<const T> find(std::size_t id) {
    Shard& s = shards_[id % kShards];
    std::lock_guard<std::mutex> lock(s.mutex);
    auto it = s.map.find(id);
    if (it == s.map.end()) return nullptr;
    s.order.splice(s.order.begin(), s.order, it->second.at);
    return it->second.value;
  }

  // `bytes`: what the value holds (its vectors' capacities).
  void insert(std::size_t id, std::shared_ptr<const T> value, std::uint64_t bytes) {
    const std::size_t shard = id % kShards;
    {
      Shard& s = shards_[shard];
      std::lock_guard<std::mutex> lock(s.mutex);
      if (s.map.count(id) != 0) return;  // another thread decoded it first
      s.order.push_front(id);
      s.map.emplace(id, Entry{std::move(value), s.order.begin(), bytes});
      s.bytes += bytes;
      add(static_cast<std::int64_t>(bytes));
      evict(s);
    }
    // With the shard's lock released: a thread never holds two shards' locks.
    if (this->bytes() > budget()) trim(shard);
  }

  void clear() {
    for (Shard& s : shards_) {
      std::lock_guard<std::mutex> lock(s.mutex);
      add(-static_cast<std::int64_t>(s.bytes));
      s.bytes = 0;
      s.map.clear();
      s.order.clear();
    }
  }

 private:
  static constexpr std::size_t kShards = 16;
  struct Entry {
    std::shared_ptr<const T> value;
    std::list<std::size_t>::iterator at;
    std::uint64_t bytes = 0;
  };
  struct Shard {
    std::mutex mutex;
    std::list<std::size_t> order;  // most recent first
    std::unordered_map<std::size_t, Entry> map;
    std::uint64_t bytes = 0;
  };
  // The least recently used of the shard (its lock held) until within its part of the budget.
  void evict(Shard& s) {
    const std::uint64_t limit = per_shard_.load(std::memory_order_relaxed);
    while (s.bytes > limit && s.order.size() > 1) drop_oldest(s);
  }
  // Removes the shard's least recently used block (its lock held; the shard not empty).
  void drop_oldest(Shard& s) {
    auto victim = s.map.find(s.order.back());
    s.bytes -= victim->second.bytes;
    add(-static_cast<std::int64_t>(victim->second.bytes));
    s.map.erase(victim);
    s.order.pop_back();
  }
  // Evicts the other shards' blocks than shard `keep`'s (none, for kShards), least recently
  // used first in each, one shard's lock at a time, until the cache is within its budget.
  void trim(std::size_t keep) {
    for (std::size_t i = 0; i < kShards && bytes() > budget(); ++i) {
      if (i == keep) continue;
      Shard& o = shards_[i];
      std::lock_guard<std::mutex> lock(o.mutex);
      while (!o.order.empty() && bytes() > budget()) drop_oldest(o);
    }
  }
  void add(std::int64_t delta) {
    const std::uint64_t now = bytes_.fetch_add(static_cast<std::uint64_t>(delta), std::memory_order_relaxed) +
                              static_cast<std::uint64_t>(delta);
    std::uint64_t peak = peak_.load(std::memory_order_relaxed);
    while (now > peak && !peak_.compare_exchange_weak(peak, now, std::memory_order_relaxed)) {
    }
  }
  std::atomic<std::uint64_t> budget_{0};
  std::atomic<std::uint64_t> per_shard_{0};
  std::atomic<std::uint64_t> bytes_{0};
  std::atomic<std::uint64_t> peak_{0};
  std::array<Shard, kShards> shards_;
};

}  // namespace sspc::codec
