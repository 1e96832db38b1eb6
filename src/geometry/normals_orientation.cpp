// Consistent normal orientation (Hoppe, DeRose, Duchamp, McDonald, Stuetzle: "Surface
// reconstruction from unorganized points", SIGGRAPH 1992, section 3.3).
//
// PCA leaves each normal's sign arbitrary. Hoppe propagates a sign along a minimum spanning tree
// of the neighbour graph weighted by 1 − |n_i·n_j|: the tree prefers edges between nearly
// parallel planes, so a flip decision is only taken where it is unambiguous, and a child is
// flipped when n_parent·n_child < 0. Differences from the paper, on purpose:
//  - the graph is the symmetrised k-NN graph (the paper's Riemannian graph adds the Euclidean
//    MST's edges); with k = 16 it connects a surface sampled well enough for the PCA itself;
//  - the paper seeds at the highest point and forces its normal to +z. The relative orientation
//    along a given tree does not depend on where propagation starts, so Prim starts at the
//    component's lowest index, and the whole component is flipped at the end if its highest
//    point (max z, ties: lower index) faces down: the paper's rule without sorting the points
//    by height. (Only where edge costs tie exactly can Prim from another root pick another,
//    equally minimal, tree.)
//
// Prim's algorithm over the table's rows plus reverse edges, with a 4-ary indexed heap
// (normals_prim_heap.hpp) whose keys order by cost and then by point index. It runs sequentially;
// the pop order is fixed by those unique keys, not by the order in which a point's edges are
// relaxed, so the result depends neither on the thread count nor on the tree that produced the
// (canonical) k-NN table.
#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "core/parallel.hpp"
#include "geometry/normals_prim_heap.hpp"
#include "geometry/normals_steps.hpp"

namespace sspc::detail {

namespace {

constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

}  // namespace

// Counting sort of the table's edges by target, in parallel. The order of sources within a
// point's list depends on thread timing; Prim's result does not depend on it (see
// orient_normals_mst), so the orientation stays deterministic. Whether an edge is mutual is
// looked up once (a bit an edge) and used by the two passes that count and place the one-way
// edges: looking it up again in the placing pass, row j read for every edge (i, j), was half of
// this step's time. A row's flags are
// whole words of its own (4 bytes a point at k = 16), so that threads never share one.
//
// Whether row j names i is first settled by distance: row j holds the k points nearest to j
// (ties by index), so i is in it when it lies nearer to j than row j's last point, and not when
// it lies farther. Distances are recomputed here (the table keeps none), so each comparison
// allows a margin far above their rounding (a few units in the last place), and only an edge
// within it reads row j (ties, duplicates, a short row). Reading row j for every edge was 15%
// of the normals' CPU time on autzen (perf, `sspc normals`): 16 indices from a random row
// against one position and one distance.
ReverseEdges reverse_edges(std::span<const Vec3f> positions, const KnnTable& table, std::size_t points) {
  constexpr float kMargin = 1e-5f;
  // One array serves twice, so that the orientation's peak is what it was before the distances
  // (autzen's encode: 1.51 GB with an array of its own, 1.47 without): first each point's
  // squared distance to its row's last point (its bits; −1 where the row is short), then each
  // point's count of one-way edges into it.
  std::vector<std::uint32_t> degree(points);
  parallel_for(0, points, 4096, [&](std::size_t j) {
    const auto row = table.row(j);
    const float last =
        row.size() == table.k && !row.empty() ? (positions[row.back()] - positions[j]).squaredNorm() : -1.0f;
    degree[j] = std::bit_cast<std::uint32_t>(last);
  });
  const std::size_t words = (table.k + 31) / 32;
  std::vector<std::uint32_t> one_way(points * words, 0);  // bit e: edge (i, row(i)[e]) has no twin
  parallel_for_ranges(0, points, 4096, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const auto row = table.row(i);
      const Vec3f& here = positions[i];
      for (std::size_t e = 0; e < row.size(); ++e) {
        const std::uint32_t j = row[e];
        const float reach = std::bit_cast<float>(degree[j]), d = (positions[j] - here).squaredNorm();
        bool mutual = false;
        if (reach >= 0 && d < reach * (1 - kMargin)) {
          mutual = true;
        } else if (!(reach >= 0 && d > reach * (1 + kMargin))) {
          // A plain loop without an early exit: the compiler vectorises it.
          for (const std::uint32_t back : table.row(j)) mutual |= back == i;
        }
        if (!mutual) one_way[i * words + e / 32] |= std::uint32_t{1} << (e % 32);
      }
    }
  });
  // visit(i, j) for every one-way edge, in parallel.
  const auto for_each_one_way = [&](auto&& visit) {
    parallel_for_ranges(0, points, 4096, [&](std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i) {
        const auto row = table.row(i);
        for (std::size_t e = 0; e < row.size(); ++e) {
          if ((one_way[i * words + e / 32] >> (e % 32) & 1u) != 0) visit(i, row[e]);
        }
      }
    });
  };
  std::fill(degree.begin(), degree.end(), 0u);
  for_each_one_way([&](std::size_t, std::uint32_t j) {
    std::atomic_ref<std::uint32_t>(degree[j]).fetch_add(1, std::memory_order_relaxed);
  });
  ReverseEdges reverse;
  reverse.offsets.resize(points + 1);
  reverse.offsets[0] = 0;
  for (std::size_t i = 0; i < points; ++i) reverse.offsets[i + 1] = reverse.offsets[i] + degree[i];
  reverse.sources.resize(reverse.offsets[points]);
  std::vector<std::uint64_t> cursor(reverse.offsets.begin(), reverse.offsets.end() - 1);
  for_each_one_way([&](std::size_t i, std::uint32_t j) {
    const std::uint64_t at = std::atomic_ref<std::uint64_t>(cursor[j]).fetch_add(1, std::memory_order_relaxed);
    reverse.sources[at] = static_cast<std::uint32_t>(i);
  });
  return reverse;
}

namespace {

bool higher(const Vec3f& a, std::uint32_t ia, const Vec3f& b, std::uint32_t ib) {
  return a.z() > b.z() || (a.z() == b.z() && ia < ib);
}

}  // namespace

void orient_normals_mst(std::span<const Vec3f> positions, const KnnTable& neighbours,
                        std::span<Vec3f> normals, Progress* progress) {
  const std::size_t n = normals.size();
  const ReverseEdges reverse = reverse_edges(positions, neighbours, n);

  PrimHeap heap(n);
  std::vector<std::uint32_t> parent(n, kNone);
  std::vector<std::uint32_t> component;  // the current component's points, in visit order
  std::size_t visited = 0;

  for (std::size_t start = 0; start < n; ++start) {
    if (heap.done(static_cast<std::uint32_t>(start))) continue;
    component.clear();
    auto top = static_cast<std::uint32_t>(start);
    heap.push_or_decrease(0.0f, top);
    while (!heap.empty()) {
      const std::uint32_t v = heap.pop();
      component.push_back(v);
      if (parent[v] != kNone && normals[parent[v]].dot(normals[v]) < 0.0f) normals[v] = -normals[v];
      if (higher(positions[v], v, positions[top], top)) top = v;

      const Vec3f nv = normals[v];
      auto relax = [&](std::uint32_t w) {
        if (heap.done(w)) return;
        // max(): |n·n| of two unit floats can exceed 1 by an ulp, and a negative cost's bits
        // would sort after every positive one (the max also turns -0 into +0).
        const float cost = std::max(0.0f, 1.0f - std::abs(nv.dot(normals[w])));
        if (heap.push_or_decrease(cost, w)) parent[w] = v;
      };
      // The neighbours' heap slots and normals are scattered through memory: ask for all of
      // them before touching the first, so that the cache misses overlap.
      const auto forward = neighbours.row(v);
      const auto backward = reverse.of(v);
      for (const std::uint32_t w : forward) heap.prefetch(w, normals.data() + w);
      for (const std::uint32_t w : backward) heap.prefetch(w, normals.data() + w);
      for (const std::uint32_t w : forward) relax(w);
      for (const std::uint32_t w : backward) relax(w);

      if ((++visited & 0xFFFFu) == 0) progress_advance(progress, 0x10000u);
    }
    // The seed rule: the component's highest point faces +z.
    if (normals[top].z() < 0.0f) {
      for (const std::uint32_t v : component) normals[v] = -normals[v];
    }
  }
  progress_advance(progress, visited & 0xFFFFu);
}

void orient_normals_towards(std::span<const Vec3f> positions, const Vec3f& viewpoint,
                            std::span<Vec3f> normals) {
  parallel_for(0, normals.size(), 4096, [&](std::size_t i) {
    if (normals[i].dot(viewpoint - positions[i]) < 0.0f) normals[i] = -normals[i];
  });
}

}  // namespace sspc::detail
