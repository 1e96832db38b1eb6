// The uncompressed renderer within a memory budget (the paper's Figure 5: a model that does not
// fit in memory against its compressed version, which does). The cloud's points are split into
// bricks of a uniform grid, each written to a page file with a halo of the points within the
// support radius of its box, so that the MLS surface inside a brick needs no other brick. Rays
// walk the bricks front to back (3D DDA); a brick's surface is read back and built when a ray
// first needs it and kept in a cache of at most the budget's bytes, the least recently used
// evicted; the page file is kept out of the OS's page cache, so reads go to the disk. The image
// is the same whatever the cache holds: a brick's surface is built from the
// same bytes every time.
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <list>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>

#include "render/camera.hpp"
#include "render/mls_surface.hpp"
#include "render/shading.hpp"
#include "sspc/neighbors.hpp"
#include "sspc/render.hpp"

namespace sspc {

namespace {

// Points per brick the grid aims at: large enough that the halo (points within r of a brick,
// stored twice) is a small share, small enough that a budget holds many bricks.
constexpr double kPointsPerBrick = 8192;

class PagedScene final : public RenderScene {
 public:
  ~PagedScene() override {
    if (fd_ >= 0) ::close(fd_);
    std::error_code ec;
    if (!page_path_.empty()) std::filesystem::remove(page_path_, ec);
  }

  Status build(const PointCloud& cloud, float bandwidth, std::uint64_t budget, const std::filesystem::path& dir,
               Progress* progress);
  StatusOr<Image> render(const RenderOptions& o, RenderStats* stats) const override;
  Box3f bounds() const override { return bounds_; }

 private:
  struct Brick {
    std::uint64_t offset = 0;  // in the page file
    std::uint32_t count = 0;   // points, halo included
    std::uint32_t own = 0;     // points inside the brick's box
  };
  using SurfacePtr = std::shared_ptr<const render::MlsSurface>;

  std::size_t brick_index(int x, int y, int z) const {
    return static_cast<std::size_t>(x) +
           static_cast<std::size_t>(dims_[0]) * (static_cast<std::size_t>(y) + static_cast<std::size_t>(dims_[1]) *
                                                                                   static_cast<std::size_t>(z));
  }
  int brick_coordinate(float v, int axis) const {
    const float c = std::floor((v - origin_[axis]) / edge_);
    if (!(c > 0)) return 0;
    if (c >= static_cast<float>(dims_[axis] - 1)) return dims_[axis] - 1;
    return static_cast<int>(c);
  }
  // The brick's surface, from the cache or read from the page file.
  StatusOr<SurfacePtr> surface(std::size_t b) const;

  float h_ = 0;
  float edge_ = 0;  // brick edge
  Vec3f origin_;
  int dims_[3] = {1, 1, 1};
  Box3f bounds_;
  std::vector<Brick> bricks_;
  std::filesystem::path page_path_;
  int fd_ = -1;
  std::uint64_t budget_ = 0;

  // The cache: bricks' surfaces by brick, the most recently used at the front of `lru_`.
  mutable std::mutex mutex_;
  mutable std::list<std::size_t> lru_;
  mutable std::unordered_map<std::size_t, std::pair<SurfacePtr, std::list<std::size_t>::iterator>> cache_;
  mutable std::uint64_t cached_bytes_ = 0;
  mutable std::uint64_t peak_cached_bytes_ = 0;
  mutable std::atomic<std::uint64_t> bytes_read_{0}, loads_{0};
};

Status PagedScene::build(const PointCloud& cloud, float bandwidth, std::uint64_t budget,
                         const std::filesystem::path& dir, Progress* progress) {
  const auto start = std::chrono::steady_clock::now();
  budget_ = budget;
  bounds_ = cloud.bounding_box();
  SSPC_ASSIGN_OR_RETURN(const double spacing, render::surface_spacing(cloud));
  h_ = static_cast<float>(static_cast<double>(bandwidth) * spacing);
  const float r = render::MlsSurface(std::span<const Vec3f>(), std::span<const Vec3f>(), h_).support_radius();

  // A brick edge that gives about kPointsPerBrick points a brick on a surface (points per brick
  // grow with its area), at least 8 support radii.
  const Vec3f extent = bounds_.max() - bounds_.min();
  const float area = std::max({extent.x() * extent.y(), extent.y() * extent.z(), extent.x() * extent.z(), 1e-30f});
  edge_ = std::max(8 * r, std::sqrt(area * static_cast<float>(kPointsPerBrick / static_cast<double>(cloud.size()))));
  origin_ = bounds_.min();
  double total = 1;
  for (int a = 0; a < 3; ++a) {
    dims_[a] = std::max(1, static_cast<int>(std::ceil(extent[a] / edge_ + 1e-6f)));
    total *= dims_[a];
  }
  if (total > 1e7) return invalid_argument("the cloud spans too many bricks for paging");
  bricks_.assign(static_cast<std::size_t>(total), Brick{});

  // Each point goes to its brick and, within r of another brick's box, to that one's halo.
  std::vector<std::vector<std::uint32_t>> members(bricks_.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Vec3f& p = cloud.positions[i];
    int lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      lo[a] = brick_coordinate(p[a] - r, a);
      hi[a] = brick_coordinate(p[a] + r, a);
    }
    const std::size_t home = brick_index(brick_coordinate(p.x(), 0), brick_coordinate(p.y(), 1), brick_coordinate(p.z(), 2));
    ++bricks_[home].own;
    for (int z = lo[2]; z <= hi[2]; ++z) {
      for (int y = lo[1]; y <= hi[1]; ++y) {
        for (int x = lo[0]; x <= hi[0]; ++x) members[brick_index(x, y, z)].push_back(static_cast<std::uint32_t>(i));
      }
    }
  }

  // The page file: per brick, its positions then its normals, as floats.
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  char name[64];
  std::snprintf(name, sizeof name, "sspc-pages-%d-%p.bin", static_cast<int>(::getpid()), static_cast<void*>(this));
  page_path_ = dir / name;
  std::FILE* out = std::fopen(page_path_.c_str(), "wb");
  if (out == nullptr) return io_error(page_path_.string() + ": cannot create the page file");
  progress_begin(progress, "pages", bricks_.size(), "bricks");
  std::uint64_t offset = 0;
  std::vector<Vec3f> buffer;
  bool written = true;
  for (std::size_t b = 0; b < bricks_.size(); ++b) {
    bricks_[b].offset = offset;
    bricks_[b].count = static_cast<std::uint32_t>(members[b].size());
    buffer.clear();
    for (std::uint32_t i : members[b]) buffer.push_back(cloud.positions[i]);
    for (std::uint32_t i : members[b]) buffer.push_back(cloud.normals[i]);
    if (!buffer.empty()) written = written && std::fwrite(buffer.data(), sizeof(Vec3f), buffer.size(), out) == buffer.size();
    offset += buffer.size() * sizeof(Vec3f);
    std::vector<std::uint32_t>().swap(members[b]);
    progress_advance(progress, 1);
  }
  progress_end(progress);
  written = std::fflush(out) == 0 && ::fdatasync(::fileno(out)) == 0 && written;
  written = std::fclose(out) == 0 && written;
  if (!written) return io_error(page_path_.string() + ": cannot write the page file (disk full?)");
  fd_ = ::open(page_path_.c_str(), O_RDONLY);
  if (fd_ < 0) return io_error(page_path_.string() + ": cannot open the page file");
  ::posix_fadvise(fd_, 0, 0, POSIX_FADV_DONTNEED);  // written, synced: start with nothing cached
  build_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  memory_bytes_ = bricks_.size() * sizeof(Brick);  // what stays; the cache is counted per frame
  return Status();
}

StatusOr<PagedScene::SurfacePtr> PagedScene::surface(std::size_t b) const {
  {
    std::lock_guard lock(mutex_);
    if (auto it = cache_.find(b); it != cache_.end()) {
      lru_.splice(lru_.begin(), lru_, it->second.second);
      return it->second.first;
    }
  }
  // Read and build outside the lock: two threads may both build one brick; they build the same.
  const Brick& brick = bricks_[b];
  std::vector<Vec3f> data(2 * static_cast<std::size_t>(brick.count));
  const std::size_t bytes = data.size() * sizeof(Vec3f);
  std::size_t done = 0;
  while (done < bytes) {
    const ssize_t got = ::pread(fd_, reinterpret_cast<char*>(data.data()) + done, bytes - done,
                                static_cast<off_t>(brick.offset + done));
    if (got <= 0) return io_error(page_path_.string() + ": cannot read a page");
    done += static_cast<std::size_t>(got);
  }
  // Out of the OS's page cache again: a scene that does not fit in memory does not fit in the
  // page cache either, and on a machine with RAM to spare the cache would otherwise make every
  // read after the first a memory copy.
  ::posix_fadvise(fd_, static_cast<off_t>(brick.offset), static_cast<off_t>(bytes), POSIX_FADV_DONTNEED);
  bytes_read_ += bytes;
  ++loads_;
  const std::span<const Vec3f> all(data);
  auto built = std::make_shared<const render::MlsSurface>(all.first(brick.count), all.last(brick.count), h_);
  std::lock_guard lock(mutex_);
  if (auto it = cache_.find(b); it != cache_.end()) return it->second.first;
  lru_.push_front(b);
  cache_.emplace(b, std::make_pair(SurfacePtr(built), lru_.begin()));
  cached_bytes_ += built->memory_bytes();
  // Evict the least recently used until within the budget (the brick just read always stays).
  while (cached_bytes_ > budget_ && lru_.size() > 1) {
    const std::size_t victim = lru_.back();
    lru_.pop_back();
    auto it = cache_.find(victim);
    cached_bytes_ -= it->second.first->memory_bytes();
    cache_.erase(it);
  }
  peak_cached_bytes_ = std::max(peak_cached_bytes_, cached_bytes_);
  return SurfacePtr(built);
}

StatusOr<Image> PagedScene::render(const RenderOptions& o, RenderStats* stats) const {
  SSPC_RETURN_IF_ERROR(render::check_options(o));
  const render::PinholeCamera camera(o.camera, o.width, o.height);
  const std::uint64_t read_before = bytes_read_, loads_before = loads_;
  std::atomic<bool> failed{false};
  Image image = render::trace_image(
      o, camera,
      [&](int px, int py, render::Frame& frame, std::uint64_t& evaluations) {
        const Vec3f& eye = camera.eye();
        const Vec3f d = camera.direction(px, py);
        // The ray's interval in the grid of bricks.
        float t0 = 0, t1 = std::numeric_limits<float>::infinity();
        for (int a = 0; a < 3; ++a) {
          const float lo = origin_[a], hi = origin_[a] + static_cast<float>(dims_[a]) * edge_;
          if (d[a] == 0) {
            if (eye[a] < lo || eye[a] > hi) return false;
            continue;
          }
          float near = (lo - eye[a]) / d[a], far = (hi - eye[a]) / d[a];
          if (near > far) std::swap(near, far);
          t0 = std::max(t0, near);
          t1 = std::min(t1, far);
        }
        if (!(t0 <= t1)) return false;
        // 3D DDA over the bricks, front to back: the first brick with a hit has the first hit.
        const Vec3f start = eye + t0 * d;
        int c[3], step[3];
        float next[3], delta[3];
        for (int a = 0; a < 3; ++a) {
          c[a] = brick_coordinate(start[a], a);
          step[a] = d[a] > 0 ? 1 : -1;
          const float boundary = origin_[a] + static_cast<float>(c[a] + (d[a] > 0 ? 1 : 0)) * edge_;
          next[a] = d[a] != 0 ? (boundary - eye[a]) / d[a] : std::numeric_limits<float>::infinity();
          delta[a] = d[a] != 0 ? edge_ / std::abs(d[a]) : std::numeric_limits<float>::infinity();
        }
        float t = t0;
        while (t <= t1) {
          const int axis = next[0] < next[1] ? (next[0] < next[2] ? 0 : 2) : (next[1] < next[2] ? 1 : 2);
          const float exit = std::min(next[axis], t1);
          const std::size_t b = brick_index(c[0], c[1], c[2]);
          if (bricks_[b].own > 0) {
            auto s = surface(b);
            if (!s.ok()) {
              failed = true;
              return false;
            }
            const auto hit = (*s)->intersect(eye, d, t, exit);
            if (hit) {
              evaluations += static_cast<std::uint64_t>(hit->evaluations);
              frame.set(px, py, hit->t, hit->normal, 0);
              return true;
            }
          }
          t = next[axis];
          next[axis] += delta[axis];
          c[axis] += step[axis];
          if (c[axis] < 0 || c[axis] >= dims_[axis]) break;
        }
        return false;
      },
      stats);
  if (failed) return io_error(page_path_.string() + ": reading a page failed");
  if (stats != nullptr) {
    stats->build_seconds = build_seconds_;
    std::lock_guard lock(mutex_);
    stats->scene_bytes = memory_bytes_ + peak_cached_bytes_;
    stats->bytes_read = bytes_read_ - read_before;
    stats->pages_read = loads_ - loads_before;
  }
  return image;
}

}  // namespace

StatusOr<std::unique_ptr<RenderScene>> RenderScene::from_point_cloud_paged(const PointCloud& cloud, float bandwidth,
                                                                           std::uint64_t budget_bytes,
                                                                           const std::filesystem::path& page_dir,
                                                                           Progress* progress) {
  SSPC_RETURN_IF_ERROR(cloud.validate());
  if (cloud.empty()) return invalid_argument("the cloud is empty");
  if (!cloud.has_normals()) return invalid_argument("rendering needs normals (estimate them first)");
  if (!(bandwidth > 0.1f && bandwidth < 100.0f)) return invalid_argument("bandwidth must be in (0.1, 100) spacings");
  if (budget_bytes == 0) return invalid_argument("the memory budget must be positive");
  auto scene = std::make_unique<PagedScene>();
  SSPC_RETURN_IF_ERROR(scene->build(cloud, bandwidth, budget_bytes, page_dir, progress));
  return std::unique_ptr<RenderScene>(std::move(scene));
}

}  // namespace sspc
