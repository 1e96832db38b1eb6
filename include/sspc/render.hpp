// Ray tracing point clouds through their MLS surface (Hubo et al. 2007, §5).
// The same MLS surface and camera render an uncompressed cloud and a compressed model, so their
// images and timings compare one to one.
#pragma once

#include <cstdint>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <vector>

#include "sspc/compressed_model.hpp"
#include "sspc/point_cloud.hpp"
#include "sspc/progress.hpp"
#include "sspc/status.hpp"

namespace sspc {

// kCodeword colours each pixel by the code word of the patch that contributed most to it (the
// paper's Figure 6); an uncompressed cloud is one colour.
enum class Shade { kLambert, kNormal, kDepth, kCodeword };

struct Camera {
  Vec3f eye = Vec3f(0, 0, 1);
  Vec3f target = Vec3f::Zero();
  Vec3f up = Vec3f::UnitY();
  float fov_degrees = 40;  // vertical field of view
};

// A camera that frames `bounds` from the +Z side (the usual "front" of a scan), or null bounds.
Camera frame_bounds(const Box3f& bounds, float fov_degrees = 40);

// What a compressed scene holds of decoded bricks unless told otherwise: 512 MiB.
inline constexpr std::uint64_t kDefaultMemoryBudget = std::uint64_t{512} << 20;

// How a scene is built, fixed for its life (RenderScene's factories).
struct SceneOptions {
  // The MLS bandwidth h in point spacings (the cloud's median nearest-neighbour distance).
  float bandwidth = 1.5f;
  // What a compressed scene may hold of decoded bricks, and a paged one of bricks read back; an
  // in-memory point-cloud scene holds its whole cloud and has no use for it.
  std::uint64_t memory_budget_bytes = kDefaultMemoryBudget;
  Progress* progress = nullptr;  // the build's stages
};

// One frame of a built scene (RenderScene::render): what any camera may change between frames.
struct FrameOptions {
  int width = 1024;
  int height = 1024;
  Camera camera;
  Shade shade = Shade::kLambert;
  // Level of detail: 0 intersects every point's surface; p > 0 lets a compressed scene
  // intersect the surface, where its points lie more densely than the pixels, from a coarser
  // form whose samples are 2, 4 or 8 spacings apart, wherever those project to at most p pixels
  // (docs/ARCHITECTURE.md, "Level of detail"). Other scenes ignore it.
  float level_of_detail = 0;
  Progress* progress = nullptr;  // the frame's rows
};

struct Image {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgb;  // row-major from the top, 3 bytes a pixel
  std::vector<float> depth;       // ray parameter t of the hit, +inf where the ray missed
};

struct RenderStats {
  double build_seconds = 0;
  double render_seconds = 0;
  std::uint64_t rays = 0;
  std::uint64_t hits = 0;
  std::uint64_t evaluations = 0;  // MLS evaluations, all rays
  std::uint64_t scene_bytes = 0;  // points and normals held, plus the acceleration structure
  std::uint64_t frame_bytes = 0;  // the frame's own buffers: each pixel's hit, and the image
  std::uint64_t bytes_read = 0;   // a paged scene: what this frame read from its page file
  std::uint64_t pages_read = 0;   // ... in how many bricks
};

// A ray's first hit on a scene's surface (RenderScene::intersect).
struct RayHit {
  float t = 0;         // along the ray, in the units of its direction
  Vec3f normal;        // unit, facing the ray's origin
  std::uint32_t id = 0;  // a compressed scene: the code word of the nearest decoded point
};

// What a renderer traces: built once (surfaces, acceleration structures), then rendered from any
// number of cameras. Rendering is deterministic: an image does not depend on the thread count.
class RenderScene {
 public:
  virtual ~RenderScene() = default;

  // One MLS surface over all of `cloud`'s points; the cloud must have unit normals (see
  // ensure_normals). The memory budget is not used: the scene holds the whole cloud.
  static StatusOr<std::unique_ptr<RenderScene>> from_point_cloud(const PointCloud& cloud,
                                                                 const SceneOptions& options = {});
  // The same surface within a memory budget, for clouds too large to hold: the points are split
  // into bricks written to a page file in `page_dir` (removed with the scene), each with the
  // points within the support radius of its box, and read back as rays reach them through a
  // cache of at most options.memory_budget_bytes of surfaces, the least recently used evicted.
  // Frames report the bytes they read; images are from_point_cloud's (a ray samples the surface
  // where the whole cloud's march does, whatever the bricks).
  static StatusOr<std::unique_ptr<RenderScene>> from_point_cloud_paged(const PointCloud& cloud,
                                                                       const std::filesystem::path& page_dir,
                                                                       const SceneOptions& options = {});
  // A compressed model, rendered directly: the MLS surface of its decoded points, seamless
  // across instances, built brick by brick as rays reach them from what the model's random-access
  // API decodes there (with PCA normals, k = 16, when the model stores none, as a decoded cloud
  // gets them), and kept in a cache, the least recently used evicted. options.memory_budget_bytes
  // bounds the two caches together: an eighth goes to the model's own cache of decoded blocks
  // (the scene sets CompressedModel::set_cache_budget), the rest to the bricks; a frame's
  // scene_bytes counts both at their peaks. The image is that of the decoded model's render (up
  // to normals estimated in bricks rather than over the whole decode), whatever the budget. The
  // scene shares the model, which must not change while it lives.
  static StatusOr<std::unique_ptr<RenderScene>> from_compressed(std::shared_ptr<const CompressedModel> model,
                                                                const SceneOptions& options = {});

  // Renders one frame. Fills `stats` when given, including the scene's build time and memory.
  virtual StatusOr<Image> render(const FrameOptions& options, RenderStats* stats = nullptr) const = 0;

  // One ray against the scene's surface, for a host ray tracer (an Embree user geometry, a
  // path tracer's secondary rays): the first hit along origin + t·direction for t in [t_min,
  // t_max], or none. `direction` need not be unit length; t is in its units. Thread-safe; a
  // compressed scene builds and caches the bricks the ray reaches, as render() does, and fails
  // only when the model's data does.
  virtual StatusOr<std::optional<RayHit>> intersect(const Vec3f& origin, const Vec3f& direction, float t_min = 0,
                                                    float t_max = std::numeric_limits<float>::infinity()) const = 0;

  // The box of the scene's points (a compressed model's: of its source's), which frame_bounds()
  // frames.
  virtual Box3f bounds() const = 0;
  // A box holding every hit intersect() can return, for a host ray tracer's bounding box of the
  // scene (an Embree user geometry's bounds callback): the MLS surface reaches up to its support
  // radius beyond the points, and a compressed model's decoded points beyond its source's
  // bounds by up to the codec's error, so bounds() is not enough: a ray that meets the surface
  // only there never enters it. Contains bounds().
  virtual Box3f surface_bounds() const = 0;
  double build_seconds() const { return build_seconds_; }
  // Bytes the scene holds after building it (a brick scene's cache comes on top, up to its
  // budget: RenderStats::scene_bytes reports its peak).
  std::uint64_t memory_bytes() const { return memory_bytes_; }

 protected:
  double build_seconds_ = 0;
  std::uint64_t memory_bytes_ = 0;
};

// One frame in one call: builds the scene, then renders it.
StatusOr<Image> render_point_cloud(const PointCloud& cloud, const FrameOptions& frame, const SceneOptions& scene = {},
                                   RenderStats* stats = nullptr);
StatusOr<Image> render_compressed(const CompressedModel& model, const FrameOptions& frame,
                                  const SceneOptions& scene = {}, RenderStats* stats = nullptr);

// Writes an 8-bit RGB PNG atomically.
Status write_png(const Image& image, const std::filesystem::path& path);
// Reads a PNG (any bit depth and colour type, converted to 8-bit RGB; alpha dropped). The image
// has no depth.
StatusOr<Image> read_png(const std::filesystem::path& path);

// Two renders of one scene compared (docs/METRICS.md, "Images"): a pixel is hit when it is not
// black, the background every shading mode leaves where a ray misses and never paints a hit.
struct ImageComparison {
  std::uint64_t pixels = 0;
  std::uint64_t hit_both = 0;
  std::uint64_t hit_first_only = 0;
  std::uint64_t hit_second_only = 0;
  // Image PSNR over the channels of the pixels both hit, peak 255; +inf when they are equal
  // there, 0 when no pixel is hit by both.
  double psnr_hit = 0;
  // Pixels hit by one image only, as a fraction of those hit by either.
  double one_only_fraction() const {
    const std::uint64_t either = hit_both + hit_first_only + hit_second_only;
    return either == 0 ? 0.0 : static_cast<double>(hit_first_only + hit_second_only) / static_cast<double>(either);
  }
};
// A second image k times the first's size each way (k ≥ 2 a whole number) is a supersampled
// reference: each block of k × k pixels is averaged, misses as black, before the comparison (a
// pixel partly covered is hit, and darker). Other sizes are an error.
StatusOr<ImageComparison> compare_images(const Image& first, const Image& second);

}  // namespace sspc
