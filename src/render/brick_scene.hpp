// A scene whose MLS surface is held in bricks of a uniform grid, built when a ray first needs
// them and kept in a cache bounded by a memory budget (the least recently used evicted): what
// both the paged uncompressed scene and the compressed scene are (docs/ARCHITECTURE.md,
// "Rendering").
//
// Each brick's surface is built from the points within the support radius of its box, so the
// surface inside a brick needs no other brick and is the MLS surface of the whole cloud there.
// A ray is marched once along its whole length (render/mls_march.hpp), each sample evaluated
// in the brick that holds it, so it finds the hit the whole cloud's surface gives. A brick is
// built once however many threads ask for it at once (the others wait for it), always from the
// same points, so an image does not depend on what the cache held or on the thread count. The
// cache keeps at least 8 bricks whatever the budget, so that a budget smaller than a few rows'
// bricks costs rebuilding them row by row rather than ray by ray.
//
// A scene may have coarser levels of detail (add_levels), grids of larger bricks whose surfaces
// rest on fewer points; a frame with FrameOptions::level_of_detail marches each ray through
// level l from the distance where that level's points lie level_of_detail pixels apart, and
// level 0 before (docs/ARCHITECTURE.md, "Level of detail").
#pragma once

#include <atomic>
#include <cstdint>
#include <future>
#include <list>
#include <memory>
#include <mutex>
#include <span>
#include <unordered_map>
#include <vector>

#include "render/mls_surface.hpp"
#include "sspc/render.hpp"

namespace sspc::render {

class BrickScene : public RenderScene {
 public:
  using SurfacePtr = std::shared_ptr<const MlsSurface>;

  StatusOr<Image> render(const FrameOptions& o, RenderStats* stats) const override;
  StatusOr<std::optional<RayHit>> intersect(const Vec3f& origin, const Vec3f& direction, float t_min,
                                            float t_max) const override;
  Box3f bounds() const override { return bounds_; }
  // The grid of bricks, to which trace() clips every ray.
  Box3f surface_bounds() const override;

 protected:
  // Lays the grid over `bounds` (which become bounds() unless set before) with bricks of edge
  // `edge`, whose surfaces have the MLS bandwidth h = `bandwidth`. Returns an error when the
  // grid would have more than 10⁷ bricks.
  Status layout(const Box3f& bounds, float edge, float bandwidth, std::uint64_t budget_bytes);
  // Adds coarser levels of detail 1 … count − 1 over the same box, once level 0's bricks are
  // marked: level l's bricks are 2^l times level 0's edge; its surface is made by load(l, b)
  // from one point a cell of edge `cell`·2^(l−1), with bandwidth `bandwidth`·2^(l−1). A coarse
  // brick holds surface where one of level 0's within its support radius does.
  void add_levels(int count, float cell, float bandwidth);

  // Level l's cell and bandwidth (add_levels; level 0's cell is 0: its points are the points).
  float level_cell(int level) const { return grids_[static_cast<std::size_t>(level)].cell; }
  float level_bandwidth(int level) const { return grids_[static_cast<std::size_t>(level)].bandwidth; }

  // Level 0's grid, which layout() lays and the subclass marks.
  std::size_t brick_count() const { return grids_[0].occupied.size(); }
  std::size_t brick_index(int x, int y, int z) const { return grids_[0].index(x, y, z); }
  int brick_coordinate(float v, int axis) const { return grids_[0].coordinate(v, axis); }
  // The brick's box at a level (without the halo of the support radius).
  Box3f brick_box(std::size_t b, int level = 0) const { return grids_[static_cast<std::size_t>(level)].box(b); }
  // Marks brick b as holding surface; rays pass unoccupied bricks without building them.
  void set_occupied(std::size_t b) { grids_[0].occupied[b] = true; }

  // Builds brick b's surface at a level (0 unless add_levels() was called): called at most once
  // at a time per brick, from any thread.
  virtual StatusOr<SurfacePtr> load(int level, std::size_t b) const = 0;
  // What a frame reports as read for its bricks (a paged scene's file bytes); 0 by default.
  virtual std::uint64_t bytes_loaded() const { return 0; }
  // What its source holds now for load() besides the bricks (a compressed model's cache of
  // decoded blocks), counted in a frame's scene_bytes; 0 by default.
  virtual std::uint64_t source_bytes() const { return 0; }
  // Told, under the cache's lock, what the bricks hold after each one is built and the cache
  // evicted down to its budget: a compressed scene lends its model's cache what the bricks leave
  // of the budget. Nothing by default.
  virtual void bricks_resized(std::uint64_t /*brick_bytes*/) const {}

  Box3f bounds_;

 private:
  // One level of detail's bricks.
  struct Grid {
    Vec3f origin;
    float edge = 0;
    float bandwidth = 0;
    float cell = 0;  // a coarse level's: its points are one a cell of this edge
    int dims[3] = {1, 1, 1};
    std::size_t first_key = 0;  // its bricks' keys in the cache: first_key + b
    std::vector<bool> occupied;

    std::size_t index(int x, int y, int z) const {
      return static_cast<std::size_t>(x) +
             static_cast<std::size_t>(dims[0]) *
                 (static_cast<std::size_t>(y) + static_cast<std::size_t>(dims[1]) * static_cast<std::size_t>(z));
    }
    // The brick coordinate of v along an axis, clamped to the grid.
    int coordinate(float v, int axis) const;
    Box3f box(std::size_t b) const;
    // The grid's corner opposite its origin.
    Vec3f far_corner() const {
      return origin + edge * Vec3f(static_cast<float>(dims[0]), static_cast<float>(dims[1]), static_cast<float>(dims[2]));
    }
    // The brick holding x (floor of its grid coordinates), or false outside the grid.
    bool of(const Vec3f& x, int c[3]) const;
  };

  // The brick's surface at a level, from the cache or built by load().
  StatusOr<SurfacePtr> surface(int level, std::size_t b) const;
  class Field;  // one level's surface over bricks, as a ray's march asks for it
  using Fields = std::vector<std::unique_ptr<Field>>;  // one a level, made as a ray needs it

  // The first hit of o + t·d (|d| = 1) for t in [t_min, t_max], marched across the bricks of
  // `fields` (one thread's): at level l from starts[l] on (starts[0] = 0; a level whose start
  // is infinite is not used); `evaluations` gets the MLS evaluations; the id only when `want_id`.
  StatusOr<std::optional<RayHit>> trace(Fields& fields, std::span<const float> starts, const Vec3f& o, const Vec3f& d,
                                        float t_min, float t_max, bool want_id, std::uint64_t& evaluations) const;

  // Where a frame's rays start using each level (trace's `starts`): from FrameOptions'
  // level_of_detail, and {0} without it or without coarser levels.
  std::vector<float> level_starts(const FrameOptions& o) const;

  std::vector<Grid> grids_ = std::vector<Grid>(1);
  std::uint64_t budget_ = 0;

  // The cache: bricks being built or built, by brick, the most recently used at the front of
  // `lru_` (only built ones are in it).
  struct Entry {
    std::shared_future<StatusOr<SurfacePtr>> surface;
    std::list<std::size_t>::iterator lru;
    bool built = false;
  };
  mutable std::mutex mutex_;
  mutable std::list<std::size_t> lru_;
  mutable std::unordered_map<std::size_t, Entry> cache_;
  mutable std::uint64_t cached_bytes_ = 0;
  // The most the bricks and the source have held together, taken when a brick has been built
  // (the source's cache then holds what that brick's build decoded) and at a frame's end.
  mutable std::uint64_t peak_held_bytes_ = 0;
  mutable std::atomic<std::uint64_t> loads_{0};
};

}  // namespace sspc::render
