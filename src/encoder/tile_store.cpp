// Tile stores: a cloud in memory, or an input spilled to one file per tile (encoder/tile_store.hpp).
#include "encoder/tile_store.hpp"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "core/atomic_file.hpp"
#include "format/attribute_coder.hpp"
#include "sspc/encoder.hpp"
#include "sspc/tiled_encoder.hpp"

namespace sspc::codec {
namespace {

// The per-point arrays a tile's job and its attributes need: positions, normals when the input
// has them, and the kept channels' arrays.
struct Columns {
  bool normals = false;
  std::uint8_t channels = 0;

  void reserve(PointCloud& c, std::size_t n) const {
    c.positions.reserve(n);
    if (normals) c.normals.reserve(n);
    if (channels & kChannelColour) c.colours.reserve(n);
    if (channels & kChannelIntensity) c.las.intensity.reserve(n);
    if (channels & kChannelClassification) c.las.classification.reserve(n);
    if (channels & kChannelReturns) {
      c.las.return_number.reserve(n);
      c.las.number_of_returns.reserve(n);
    }
  }
  void copy(PointCloud& to, const PointCloud& from, std::size_t i) const {
    to.positions.push_back(from.positions[i]);
    if (normals) to.normals.push_back(from.normals[i]);
    if (channels & kChannelColour) to.colours.push_back(from.colours[i]);
    if (channels & kChannelIntensity) to.las.intensity.push_back(from.las.intensity[i]);
    if (channels & kChannelClassification) to.las.classification.push_back(from.las.classification[i]);
    if (channels & kChannelReturns) {
      to.las.return_number.push_back(from.las.return_number[i]);
      to.las.number_of_returns.push_back(from.las.number_of_returns[i]);
    }
  }

  // A spilled point: the same fields, fixed size, native byte order (the files live only as
  // long as the encode that wrote them).
  std::size_t record_bytes() const {
    std::size_t n = 12;
    if (normals) n += 12;
    if (channels & kChannelColour) n += 3;
    if (channels & kChannelIntensity) n += 2;
    if (channels & kChannelClassification) n += 1;
    if (channels & kChannelReturns) n += 2;
    return n;
  }
  void write(char* out, const PointCloud& c, std::size_t i) const {
    auto put = [&out](const void* v, std::size_t n) {
      std::memcpy(out, v, n);
      out += n;
    };
    put(c.positions[i].data(), 12);
    if (normals) put(c.normals[i].data(), 12);
    if (channels & kChannelColour) put(&c.colours[i], 3);
    if (channels & kChannelIntensity) put(&c.las.intensity[i], 2);
    if (channels & kChannelClassification) put(&c.las.classification[i], 1);
    if (channels & kChannelReturns) {
      put(&c.las.return_number[i], 1);
      put(&c.las.number_of_returns[i], 1);
    }
  }
  static Vec3f position(const char* record) {
    Vec3f p;
    std::memcpy(p.data(), record, 12);
    return p;
  }
  void read(const char* in, PointCloud& c) const {
    auto get = [&in](void* v, std::size_t n) {
      std::memcpy(v, in, n);
      in += n;
    };
    Vec3f v;
    get(v.data(), 12);
    c.positions.push_back(v);
    if (normals) {
      get(v.data(), 12);
      c.normals.push_back(v);
    }
    if (channels & kChannelColour) {
      Rgb8 rgb;
      get(&rgb, 3);
      c.colours.push_back(rgb);
    }
    if (channels & kChannelIntensity) {
      std::uint16_t i = 0;
      get(&i, 2);
      c.las.intensity.push_back(i);
    }
    if (channels & kChannelClassification) {
      std::uint8_t k = 0;
      get(&k, 1);
      c.las.classification.push_back(k);
    }
    if (channels & kChannelReturns) {
      std::uint8_t r[2];
      get(r, 2);
      c.las.return_number.push_back(r[0]);
      c.las.number_of_returns.push_back(r[1]);
    }
  }
};
static_assert(sizeof(Rgb8) == 3);

// The load rule both stores share: own points, then each other tile's within reach, in order.
// `each_point(u, keep, out)` appends tile u's points for which keep(position) holds.
using TileVisitor = std::function<Status(std::size_t, const std::function<bool(const Vec3f&)>&, PointCloud&)>;

StatusOr<PointCloud> load_with_margin(const TilePlan& plan, std::size_t t, float reach, const TileVisitor& each_point) {
  if (t >= plan.size()) return invalid_argument("tile " + std::to_string(t) + " of " + std::to_string(plan.size()));
  PointCloud out;
  SSPC_RETURN_IF_ERROR(each_point(t, [](const Vec3f&) { return true; }, out));
  if (reach < 0) return out;
  const Box3f grown(plan.boxes[t].min() - Vec3f::Constant(reach), plan.boxes[t].max() + Vec3f::Constant(reach));
  for (std::size_t u = 0; u < plan.size(); ++u) {
    if (u == t || !grown.intersects(plan.boxes[u])) continue;
    SSPC_RETURN_IF_ERROR(each_point(u, [&grown](const Vec3f& p) { return grown.contains(p); }, out));
  }
  return out;
}

class MemoryStore final : public TileStore {
 public:
  MemoryStore(PointCloud cloud, std::uint64_t tile_points, std::uint8_t channels) : cloud_(std::move(cloud)) {
    plan_ = plan_tiles(cloud_.positions, tile_points);
    members_.resize(plan_.size());
    for (std::size_t i = 0; i < cloud_.size(); ++i) {
      members_[plan_.tile_of(cloud_.positions[i])].push_back(static_cast<std::uint32_t>(i));
    }
    input_.points = cloud_.size();
    input_.bounds = plan_.bounds;
    input_.has_normals = cloud_.has_normals();
    input_.channels = static_cast<std::uint8_t>(channels_present(cloud_) & channels);
    input_.origin = cloud_.origin;
    input_.metadata = cloud_.metadata;
    columns_ = {input_.has_normals, input_.channels};
  }

  StatusOr<PointCloud> load(std::size_t t, float reach) const override {
    return load_with_margin(plan_, t, reach, [this](std::size_t u, const auto& keep, PointCloud& out) {
      columns_.reserve(out, out.size() + members_[u].size());
      for (std::uint32_t i : members_[u]) {
        if (keep(cloud_.positions[i])) columns_.copy(out, cloud_, i);
      }
      return Status();
    });
  }

 private:
  PointCloud cloud_;
  std::vector<std::vector<std::uint32_t>> members_;
  Columns columns_;
};

class SpillStore final : public TileStore {
 public:
  Status build(std::span<const std::filesystem::path> inputs, const ReadOptions& read, TileSize size,
               std::uint8_t channels, const std::filesystem::path& work_dir, std::size_t chunk_points) {
    // Pass 1: the bounds, the count and what every point carries, file by file; then the set's
    // origin (FileSetOrigin), about which every later pass moves each file's chunks.
    std::vector<std::string> dropped;
    FileSetOrigin set;
    std::vector<Vec3d> origins;
    std::vector<Box3f> local_bounds;
    for (const std::filesystem::path& input : inputs) {
      bool first = true;
      Box3f bounds;
      CloudMetadata metadata;
      const auto learn = [&](PointCloud&& chunk) -> Status {
        SSPC_RETURN_IF_ERROR(chunk.validate());
        if (first) {
          const auto present = static_cast<std::uint8_t>(channels_present(chunk) & channels);
          if (origins.empty()) {
            input_.has_normals = chunk.has_normals();
            input_.channels = present;
            input_.metadata = chunk.metadata;
          }
          // The arrays every file has (read_point_clouds keeps the same).
          input_.has_normals = input_.has_normals && chunk.has_normals();
          input_.channels = static_cast<std::uint8_t>(input_.channels & present);
          origins.push_back(chunk.origin);
          metadata = chunk.metadata;
          first = false;
        }
        input_.points += chunk.size();
        for (const Vec3f& p : chunk.positions) bounds.extend(p);
        // Each name once, in the order first seen.
        const std::string names = drop_unkept_attributes(chunk, channels);
        for (std::size_t at = 0; at < names.size();) {
          const std::size_t end = std::min(names.find(", ", at), names.size());
          std::string field = names.substr(at, end - at);
          if (std::find(dropped.begin(), dropped.end(), field) == dropped.end()) dropped.push_back(std::move(field));
          at = end + 2;
        }
        return Status();
      };
      SSPC_RETURN_IF_ERROR(read_point_cloud_chunks(input, chunk_points, learn, read));
      if (first) return invalid_argument(input.string() + ": no points");
      set.add(input, origins.back(), bounds, metadata);
      local_bounds.push_back(bounds);
    }
    SSPC_ASSIGN_OR_RETURN(input_.origin, set.origin());
    // Moving to another origin is monotonic per axis, so each file's moved bounds are its
    // bounds' corners moved.
    for (std::size_t f = 0; f < inputs.size(); ++f) {
      PointCloud corners;
      corners.origin = origins[f];
      corners.positions = {local_bounds[f].min(), local_bounds[f].max()};
      move_to_origin(corners, input_.origin);
      input_.bounds.extend(corners.positions[0]);
      input_.bounds.extend(corners.positions[1]);
    }
    const auto each_chunk = [&](const std::function<Status(PointCloud&&, const std::string&)>& sink) -> Status {
      for (const std::filesystem::path& input : inputs) {
        const std::string name = input.string();
        SSPC_RETURN_IF_ERROR(read_point_cloud_chunks(input, chunk_points, [&](PointCloud&& chunk) {
          move_to_origin(chunk, input_.origin);
          return sink(std::move(chunk), name);
        }, read));
      }
      return Status();
    };
    for (const std::string& field : dropped) input_.dropped += (input_.dropped.empty() ? "" : ", ") + field;
    std::uint64_t tile_points = size.points;
    if (tile_points == 0) {
      auto allowed = tile_points_for_memory(size.memory_limit, input_.points);
      if (!allowed.ok()) return allowed.status();
      tile_points = *allowed;
    }
    // Pass 2: the counts, then the plan.
    TilePlanner planner(input_.bounds);
    SSPC_RETURN_IF_ERROR(each_chunk([&](PointCloud&& chunk, const std::string&) -> Status {
      planner.add(chunk.positions);
      return Status();
    }));
    plan_ = planner.plan(tile_points);
    // Pass 3: each point to its tile's file, through a buffer per tile.
    columns_ = {input_.has_normals, input_.channels};
    stride_ = columns_.record_bytes();
    SSPC_RETURN_IF_ERROR(dir_.open(work_dir));
    files_.resize(plan_.size());
    std::vector<std::FILE*> handles(plan_.size(), nullptr);
    std::vector<std::string> buffers(plan_.size());
    std::vector<std::uint64_t> written(plan_.size(), 0);
    // 256 KB a tile, less under a limit that 1B points' 344 tiles (86 MB) would crowd: the
    // buffers share a sixteenth of it (they are gone before any tile is encoded).
    constexpr std::uint64_t kMostBuffer = 256 << 10, kLeastBuffer = 16 << 10;
    const std::uint64_t share = size.memory_limit / 16 / std::max<std::size_t>(plan_.size(), 1);
    const auto buffer_bytes = static_cast<std::size_t>(
        size.memory_limit == 0 ? kMostBuffer : std::clamp(share, kLeastBuffer, kMostBuffer));
    auto close_all = [&handles] {
      for (std::FILE*& f : handles) {
        if (f != nullptr) std::fclose(f);
        f = nullptr;
      }
    };
    auto flush = [&](std::size_t t) -> Status {
      if (buffers[t].empty()) return Status();
      if (handles[t] == nullptr) {
        files_[t] = dir_.stage("tile-" + std::to_string(t));
        handles[t] = std::fopen(files_[t].c_str(), "wb");
        if (handles[t] == nullptr) return io_error(files_[t].string() + ": cannot create: " + std::strerror(errno));
      }
      if (std::fwrite(buffers[t].data(), 1, buffers[t].size(), handles[t]) != buffers[t].size()) {
        return io_error(files_[t].string() + ": write failed: " + std::strerror(errno));
      }
      buffers[t].clear();
      return Status();
    };
    const auto spill = [&](PointCloud&& chunk, const std::string& name) -> Status {
      for (std::size_t i = 0; i < chunk.size(); ++i) {
        const std::uint32_t t = plan_.tile_of(chunk.positions[i]);
        if (t == kNoTile || (input_.has_normals && !chunk.has_normals()) ||
            (channels_present(chunk) & input_.channels) != input_.channels) {
          return corrupt(name + ": the file changed while it was read (its passes disagree)");
        }
        std::string& b = buffers[t];
        b.resize(b.size() + stride_);
        columns_.write(b.data() + b.size() - stride_, chunk, i);
        ++written[t];
        if (b.size() >= buffer_bytes) SSPC_RETURN_IF_ERROR(flush(t));
      }
      return Status();
    };
    Status spilled = each_chunk(spill);
    for (std::size_t t = 0; t < plan_.size() && spilled.ok(); ++t) spilled = flush(t);
    for (std::size_t t = 0; t < plan_.size() && spilled.ok(); ++t) {
      if (handles[t] != nullptr && std::fclose(handles[t]) != 0) {
        spilled = io_error(files_[t].string() + ": write failed: " + std::strerror(errno));
      }
      handles[t] = nullptr;
      if (spilled.ok() && written[t] != plan_.points[t]) {
        spilled = corrupt(inputs.front().string() + (inputs.size() > 1 ? " and the files after it" : "") +
                          ": changed while read (the passes disagree)");
      }
    }
    close_all();
    return spilled;
  }

  StatusOr<PointCloud> load(std::size_t t, float reach) const override {
    return load_with_margin(plan_, t, reach, [this](std::size_t u, const auto& keep, PointCloud& out) -> Status {
      std::FILE* f = std::fopen(files_[u].c_str(), "rb");
      if (f == nullptr) return io_error(files_[u].string() + ": cannot open: " + std::strerror(errno));
      std::vector<char> buffer(stride_ << 14);
      std::uint64_t left = plan_.points[u];
      Status status;
      while (left > 0) {
        const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(left, 1u << 14));
        if (std::fread(buffer.data(), stride_, n, f) != n) {
          status = io_error(files_[u].string() + ": shorter than it was written");
          break;
        }
        for (std::size_t i = 0; i < n; ++i) {
          const char* record = buffer.data() + i * stride_;
          if (keep(Columns::position(record))) columns_.read(record, out);
        }
        left -= n;
      }
      std::fclose(f);
      return status;
    });
  }

 private:
  StagingDirectory dir_;  // removed with the store
  std::vector<std::filesystem::path> files_;
  Columns columns_;
  std::size_t stride_ = 0;
};

}  // namespace

std::unique_ptr<TileStore> TileStore::in_memory(PointCloud cloud, std::uint64_t tile_points, std::uint8_t channels) {
  return std::make_unique<MemoryStore>(std::move(cloud), tile_points, channels);
}

StatusOr<std::unique_ptr<TileStore>> TileStore::spilled(std::span<const std::filesystem::path> inputs,
                                                        const ReadOptions& read, TileSize size, std::uint8_t channels,
                                                        const std::filesystem::path& work_dir,
                                                        std::size_t chunk_points) {
  if (inputs.empty()) return invalid_argument("no input file");
  auto store = std::make_unique<SpillStore>();
  SSPC_RETURN_IF_ERROR(store->build(inputs, read, size, channels, work_dir, std::max<std::size_t>(chunk_points, 1)));
  return std::unique_ptr<TileStore>(std::move(store));
}

}  // namespace sspc::codec
