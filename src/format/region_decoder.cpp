#include "format/region_decoder.hpp"

#include <algorithm>
#include <cmath>

namespace sspc::codec {
namespace {

// R q + c, spelled out so that its rounding is the same in every caller.
Vec3f transform_point(const Eigen::Matrix3f& r, const Vec3f& q, const Vec3f& c) {
  return {r(0, 0) * q.x() + r(0, 1) * q.y() + r(0, 2) * q.z() + c.x(),
          r(1, 0) * q.x() + r(1, 1) * q.y() + r(1, 2) * q.z() + c.y(),
          r(2, 0) * q.x() + r(2, 1) * q.y() + r(2, 2) * q.z() + c.z()};
}
Vec3f rotate(const Eigen::Matrix3f& r, const Vec3f& v) {
  return {r(0, 0) * v.x() + r(0, 1) * v.y() + r(0, 2) * v.z(),
          r(1, 0) * v.x() + r(1, 1) * v.y() + r(1, 2) * v.z(),
          r(2, 0) * v.x() + r(2, 1) * v.y() + r(2, 2) * v.z()};
}

// Room for `more` elements, growing geometrically: emit_patch is called patch after patch on
// one cloud, where an exact reserve would copy it every time; on a fresh cloud (one patch)
// the arrays are sized once instead of growing by doubling from empty.
template <typename T>
void reserve_more(std::vector<T>& v, std::size_t more) {
  if (v.capacity() - v.size() < more) v.reserve(std::max(2 * v.capacity(), v.size() + more));
}

}  // namespace

void RegionTest::reset(std::uint32_t k, const Eigen::Matrix3f& rotation, const Vec3f& centre,
                       std::span<const NeighbourInstance> neighbours) {
  k_ = k;
  frame_.clear();
  for (const NeighbourInstance& n : neighbours) {
    const float dx = n.centre.x() - centre.x(), dy = n.centre.y() - centre.y(),
                dz = n.centre.z() - centre.z();
    // Rᵀ d: column a of R dotted with d.
    FrameNeighbour f;
    f.x = rotation(0, 0) * dx + rotation(1, 0) * dy + rotation(2, 0) * dz;
    f.y = rotation(0, 1) * dx + rotation(1, 1) * dy + rotation(2, 1) * dz;
    f.z = rotation(0, 2) * dx + rotation(1, 2) * dy + rotation(2, 2) * dz;
    f.ee = f.x * f.x + f.y * f.y + f.z * f.z;
    f.index = n.index;
    frame_.push_back(f);
  }
  // Nearest first: most rejections happen on the first tests, and claims() can stop at the
  // first neighbour too far away to matter. The order does not change which points are kept.
  std::sort(frame_.begin(), frame_.end(), [](const FrameNeighbour& a, const FrameNeighbour& b) {
    return a.ee < b.ee || (a.ee == b.ee && a.index < b.index);
  });
}

void RegionTest::claims_all(const Vec3f* points, const float* norm2, std::size_t n,
                            std::vector<std::uint32_t>& keep) const {
  // The points' coordinates and reaches as separate arrays, which the loop below runs over
  // four or eight at a time.
  thread_local std::vector<float> xs, ys, zs, reach;
  xs.resize(n);
  ys.resize(n);
  zs.resize(n);
  reach.resize(n);
  float widest = 0.0f;
  for (std::size_t i = 0; i < n; ++i) {
    xs[i] = points[i].x();
    ys[i] = points[i].y();
    zs[i] = points[i].z();
    reach[i] = 4.001f * norm2[i];
    widest = std::max(widest, reach[i]);
  }
  keep.assign(n, ~0u);
  const float* __restrict x = xs.data();
  const float* __restrict y = ys.data();
  const float* __restrict z = zs.data();
  const float* __restrict r = reach.data();
  std::uint32_t* __restrict kept = keep.data();
  for (const FrameNeighbour& f : frame_) {
    // Sorted by |e_j|²: from here on no neighbour is within reach of any point.
    if (f.ee > widest) break;
    const float ee = f.ee, fx = f.x, fy = f.y, fz = f.z;
    const bool tie_kept = k_ < f.index;
    for (std::size_t i = 0; i < n; ++i) {
      const float s = ee - 2.0f * (x[i] * fx + y[i] * fy + z[i] * fz);
      const bool ok = (ee > r[i]) | (s > 0.0f) | ((s == 0.0f) & tie_kept);
      kept[i] &= ok ? ~0u : 0u;
    }
  }
}

void emit_patch(std::uint32_t k, const Eigen::Matrix3f& rotation, const Vec3f& centre,
                const CodewordView& cw, std::span<const NeighbourInstance> neighbours, bool overlap,
                const Box3f* clip, PointCloud& out, std::vector<std::uint32_t>* parents) {
  thread_local RegionTest region;
  if (parents != nullptr) parents->clear();
  if (!overlap) region.reset(k, rotation, centre, neighbours);
  const bool normals = cw.normals != nullptr;
  const bool colours = cw.colours != nullptr;
  // Written in place past the arrays' ends, then cut to what was kept.
  const std::size_t first = out.positions.size();
  reserve_more(out.positions, cw.size);
  out.positions.resize(first + cw.size);
  if (normals) {
    reserve_more(out.normals, cw.size);
    out.normals.resize(first + cw.size);
  }
  if (colours) {
    reserve_more(out.colours, cw.size);
    out.colours.resize(first + cw.size);
  }
  thread_local std::vector<std::uint32_t> claimed;
  if (!overlap) region.claims_all(cw.points, cw.norm2, cw.size, claimed);
  std::size_t kept = first;
  for (std::size_t i = 0; i < cw.size; ++i) {
    const Vec3f& q = cw.points[i];
    if (!overlap && claimed[i] == 0) continue;
    const Vec3f p = transform_point(rotation, q, centre);
    if (clip != nullptr && !clip->contains(p)) continue;
    out.positions[kept] = p;
    if (normals) out.normals[kept] = rotate(rotation, cw.normals[i]);
    if (colours) out.colours[kept] = cw.colours[i];
    if (parents != nullptr) parents->push_back(static_cast<std::uint32_t>(i));
    ++kept;
  }
  out.positions.resize(kept);
  if (normals) out.normals.resize(kept);
  if (colours) out.colours.resize(kept);
}

void emit_resampled(const Eigen::Matrix3f& rotation, const Vec3f& centre,
                    const CodewordFit& surface, int m, float step, const PointCloud& part,
                    std::span<const std::uint32_t> parents, const Box3f* clip, PointCloud& out) {
  thread_local std::vector<Vec3f> points, normals;
  const bool with_normals = !part.normals.empty();
  const bool with_colours = !part.colours.empty();
  const LasPointAttributes& las = part.las;
  LasPointAttributes& to = out.las;
  const std::size_t per = static_cast<std::size_t>(m) * static_cast<std::size_t>(m);
  if (clip == nullptr) reserve_more(out.positions, per * parents.size());
  // A new point lies within step · sqrt(1/2 + 1) < 1.25 steps of its parent (within its cell
  // across, at most a step off the tangent plane): a parent farther from the box has none in it.
  const float reach2 = (1.25f * step) * (1.25f * step);
  for (std::size_t j = 0; j < parents.size(); ++j) {
    if (clip != nullptr && clip->squaredExteriorDistance(part.positions[j]) > reach2) continue;
    points.clear();
    normals.clear();
    surface.resample(parents[j], m, step, points, with_normals ? &normals : nullptr);
    for (std::size_t s = 0; s < points.size(); ++s) {
      const Vec3f p = transform_point(rotation, points[s], centre);
      if (clip != nullptr && !clip->contains(p)) continue;
      out.positions.push_back(p);
      if (with_normals) {
        const Vec3f n = rotate(rotation, normals[s]);
        out.normals.push_back(n.dot(part.normals[j]) < 0 ? Vec3f(-n) : n);
      }
      if (with_colours) out.colours.push_back(part.colours[j]);
      if (!las.intensity.empty()) to.intensity.push_back(las.intensity[j]);
      if (!las.classification.empty()) to.classification.push_back(las.classification[j]);
      if (!las.return_number.empty()) to.return_number.push_back(las.return_number[j]);
      if (!las.number_of_returns.empty()) to.number_of_returns.push_back(las.number_of_returns[j]);
    }
  }
}

}  // namespace sspc::codec
