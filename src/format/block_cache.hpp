// A small least-recently-used cache of decoded blocks, shared by the threads that query one
// CompressedModel (a renderer's rays hit the same few blocks again and again). Sharded by block
// id so that threads rarely wait on one another's lock; values are shared_ptr so that an entry
// evicted while a query still uses it stays alive until the query is done.
#pragma once

#include <array>
#include <cstddef>
#include <list>
#include <memory>
#include <mutex>
#include <unordered_map>
#include <utility>

namespace sspc::codec {

template <typename T>
class BlockCache {
 public:
  explicit BlockCache(std::size_t capacity)
      : per_shard_(std::max<std::size_t>(1, capacity / kShards)) {}

  std::shared_ptr<const T> find(std::size_t id) {
    Shard& s = shards_[id % kShards];
    std::lock_guard<std::mutex> lock(s.mutex);
    auto it = s.map.find(id);
    if (it == s.map.end()) return nullptr;
    s.order.splice(s.order.begin(), s.order, it->second.second);
    return it->second.first;
  }

  void insert(std::size_t id, std::shared_ptr<const T> value) {
    Shard& s = shards_[id % kShards];
    std::lock_guard<std::mutex> lock(s.mutex);
    if (s.map.count(id) != 0) return;  // another thread decoded it first
    s.order.push_front(id);
    s.map.emplace(id, std::make_pair(std::move(value), s.order.begin()));
    if (s.map.size() > per_shard_) {
      s.map.erase(s.order.back());
      s.order.pop_back();
    }
  }

  void clear() {
    for (Shard& s : shards_) {
      std::lock_guard<std::mutex> lock(s.mutex);
      s.map.clear();
      s.order.clear();
    }
  }

 private:
  static constexpr std::size_t kShards = 16;
  struct Shard {
    std::mutex mutex;
    std::list<std::size_t> order;  // most recent first
    std::unordered_map<std::size_t,
                       std::pair<std::shared_ptr<const T>, std::list<std::size_t>::iterator>>
        map;
  };
  std::size_t per_shard_;
  std::array<Shard, kShards> shards_;
};

}  // namespace sspc::codec
