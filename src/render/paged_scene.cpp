// The uncompressed renderer within a memory budget (the paper's Figure 5: a model that does not
// fit in memory against its compressed version, which does). The cloud's points are split into
// the bricks of a BrickScene (render/brick_scene.hpp), each written to a page file with a halo of
// the points within the support radius of its box; a brick's surface is read back when a ray
// first needs it. The page file is kept out of the OS's page cache, so reads go to the disk.
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

#include "render/brick_scene.hpp"
#include "render/shading.hpp"
#include "sspc/neighbours.hpp"
#include "sspc/render.hpp"

namespace sspc {

namespace {

// Points per brick the grid aims at: large enough that the halo (points within r of a brick,
// stored twice) is a small share, small enough that a budget holds many bricks.
constexpr double kPointsPerPagedBrick = 8192;

class PagedScene final : public render::BrickScene {
 public:
  ~PagedScene() override {
    if (fd_ >= 0) ::close(fd_);
    std::error_code ec;
    if (!page_path_.empty()) std::filesystem::remove(page_path_, ec);
  }

  Status build(const PointCloud& cloud, float bandwidth, std::uint64_t budget, const std::filesystem::path& dir,
               Progress* progress);

 private:
  struct Brick {
    std::uint64_t offset = 0;  // in the page file
    std::uint32_t count = 0;   // points, halo included
  };

  StatusOr<SurfacePtr> load(int level, std::size_t b) const override;
  std::uint64_t bytes_loaded() const override { return bytes_read_; }

  float h_ = 0;
  std::vector<Brick> bricks_;
  std::filesystem::path page_path_;
  int fd_ = -1;
  mutable std::atomic<std::uint64_t> bytes_read_{0};
};

Status PagedScene::build(const PointCloud& cloud, float bandwidth, std::uint64_t budget,
                         const std::filesystem::path& dir, Progress* progress) {
  const auto start = std::chrono::steady_clock::now();
  SSPC_ASSIGN_OR_RETURN(const double spacing, render::surface_spacing(cloud));
  h_ = static_cast<float>(static_cast<double>(bandwidth) * spacing);
  const float r = render::MlsSurface(std::span<const Vec3f>(), std::span<const Vec3f>(), h_).support_radius();

  // A brick edge that gives about kPointsPerPagedBrick points a brick on a surface (points per
  // brick grow with its area), at least 8 support radii.
  const Box3f bounds = cloud.bounding_box();
  const Vec3f extent = bounds.max() - bounds.min();
  const float area = std::max({extent.x() * extent.y(), extent.y() * extent.z(), extent.x() * extent.z(), 1e-30f});
  const float edge =
      std::max(8 * r, std::sqrt(area * static_cast<float>(kPointsPerPagedBrick / static_cast<double>(cloud.size()))));
  // The surface reaches r beyond the points: so does the grid, or rays would stop short of it.
  bounds_ = bounds;
  SSPC_RETURN_IF_ERROR(
      layout(Box3f(bounds.min() - Vec3f::Constant(r), bounds.max() + Vec3f::Constant(r)), edge, h_, budget));
  bricks_.assign(brick_count(), Brick{});

  // Each point goes to its brick and, within r of another brick's box, to that one's halo; a
  // brick with only a halo holds surface too (within r of a neighbour's point).
  std::vector<std::vector<std::uint32_t>> members(bricks_.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Vec3f& p = cloud.positions[i];
    int lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      lo[a] = brick_coordinate(p[a] - r, a);
      hi[a] = brick_coordinate(p[a] + r, a);
    }
    for (int z = lo[2]; z <= hi[2]; ++z) {
      for (int y = lo[1]; y <= hi[1]; ++y) {
        for (int x = lo[0]; x <= hi[0]; ++x) {
          members[brick_index(x, y, z)].push_back(static_cast<std::uint32_t>(i));
          set_occupied(brick_index(x, y, z));
        }
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

// One level only: add_levels() is not called.
StatusOr<PagedScene::SurfacePtr> PagedScene::load(int /*level*/, std::size_t b) const {
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
  const std::span<const Vec3f> all(data);
  return SurfacePtr(std::make_shared<const render::MlsSurface>(all.first(brick.count), all.last(brick.count), h_));
}

}  // namespace

StatusOr<std::unique_ptr<RenderScene>> RenderScene::from_point_cloud_paged(const PointCloud& cloud,
                                                                           const std::filesystem::path& page_dir,
                                                                           const SceneOptions& options) {
  SSPC_RETURN_IF_ERROR(render::check_renderable(cloud, options));
  auto scene = std::make_unique<PagedScene>();
  SSPC_RETURN_IF_ERROR(
      scene->build(cloud, options.bandwidth, options.memory_budget_bytes, page_dir, options.progress));
  return std::unique_ptr<RenderScene>(std::move(scene));
}

}  // namespace sspc
