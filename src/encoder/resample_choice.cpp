#include "encoder/resample_choice.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "core/parallel.hpp"
#include "sspc/neighbours.hpp"

namespace sspc::codec {
namespace {

// One sphere's sums: squared distances from its source points to the nearest decoded point,
// and from its decoded points to the nearest source point, with their counts.
struct SphereSums {
  double to_decoded = 0, to_source = 0;
  std::uint64_t source_points = 0, decoded_points = 0;
};

}  // namespace

StatusOr<ResampleMeasurement> measure_resample(const CompressedModel& geometry,
                                               std::span<const DistortionSample> samples, float radius,
                                               int max_m) {
  const auto candidates = static_cast<std::size_t>(std::max(max_m, 0)) + 1;
  ResampleMeasurement out;
  out.error.assign(candidates, std::numeric_limits<double>::infinity());
  // The decode reaches past the sphere by half its radius, so that a source point at its
  // border finds the decoded points beyond it.
  const Vec3f reach = Vec3f::Constant(1.5f * radius);
  const float r2 = radius * radius;
  std::vector<SphereSums> totals(candidates);
  for (const DistortionSample& sample : samples) {
    if (sample.source == nullptr || sample.source->empty() || sample.centres.empty()) continue;
    // Each centre's source points within its decode's box, gathered in one pass over the
    // source in index order (a k-d tree of a whole tile, 10M points, would cost seconds and
    // 100 MB): the centres sorted by x, each point tested against those within reach in x.
    const std::size_t centres = sample.centres.size();
    std::vector<std::uint32_t> by_x(centres);
    for (std::size_t s = 0; s < centres; ++s) by_x[s] = static_cast<std::uint32_t>(s);
    std::sort(by_x.begin(), by_x.end(), [&](std::uint32_t a, std::uint32_t b) {
      return std::pair(sample.centres[a].x(), a) < std::pair(sample.centres[b].x(), b);
    });
    std::vector<float> xs(centres);
    for (std::size_t i = 0; i < centres; ++i) xs[i] = sample.centres[by_x[i]].x();
    std::vector<std::vector<Vec3f>> local(centres);
    for (const Vec3f& p : sample.source->positions) {
      const auto from = std::lower_bound(xs.begin(), xs.end(), p.x() - reach.x());
      for (auto it = from; it != xs.end() && *it <= p.x() + reach.x(); ++it) {
        const std::uint32_t s = by_x[static_cast<std::size_t>(it - xs.begin())];
        if (((p - sample.centres[s]).cwiseAbs().array() <= reach.array()).all()) local[s].push_back(p);
      }
    }
    // Per centre and candidate, summed in order afterwards: the same on every thread count.
    std::vector<SphereSums> sums(centres * candidates);
    std::vector<Status> status(centres);
    parallel_for(0, centres, 1, [&](std::size_t s) {
      const Vec3f c = sample.centres[s];
      if (local[s].empty()) return;
      const KdTree3 source(local[s]);
      for (std::size_t m = 0; m < candidates; ++m) {
        DecodeOptions options;
        options.resample = static_cast<int>(m);
        StatusOr<PointCloud> decoded = geometry.decode_box(Box3f(c - reach, c + reach), options);
        if (!decoded.ok()) {
          status[s] = decoded.status();
          return;
        }
        if (decoded->empty()) return;  // a centre whose patch decodes to nothing here: skipped
        const KdTree3 tree(decoded->positions);
        SphereSums& sum = sums[s * candidates + m];
        for (const Vec3f& q : local[s]) {
          if ((q - c).squaredNorm() > r2) continue;
          float d2 = 0;
          tree.nearest(q, &d2);
          sum.to_decoded += static_cast<double>(d2);
          ++sum.source_points;
        }
        for (const Vec3f& p : decoded->positions) {
          if ((p - c).squaredNorm() > r2) continue;
          float d2 = 0;
          source.nearest(p, &d2);
          sum.to_source += static_cast<double>(d2);
          ++sum.decoded_points;
        }
      }
    });
    for (const Status& s : status) SSPC_RETURN_IF_ERROR(s);
    for (std::size_t s = 0; s < centres; ++s) {
      // A sphere counts only where every candidate measured it, so that all compare the same points.
      bool complete = true;
      for (std::size_t m = 0; m < candidates; ++m) complete = complete && sums[s * candidates + m].source_points > 0;
      if (!complete) continue;
      for (std::size_t m = 0; m < candidates; ++m) {
        const SphereSums& a = sums[s * candidates + m];
        totals[m].to_decoded += a.to_decoded;
        totals[m].to_source += a.to_source;
        totals[m].source_points += a.source_points;
        totals[m].decoded_points += a.decoded_points;
      }
    }
  }
  for (std::size_t m = 0; m < candidates; ++m) {
    const SphereSums& t = totals[m];
    if (t.source_points == 0 || t.decoded_points == 0) continue;
    out.error[m] = std::max(t.to_decoded / static_cast<double>(t.source_points),
                            t.to_source / static_cast<double>(t.decoded_points));
  }
  std::size_t best = 0;
  for (std::size_t m = 1; m < candidates; ++m) {
    if (out.error[m] < out.error[best]) best = m;
  }
  out.chosen = best > 0 && out.error[best] < 0.98 * out.error[0] ? static_cast<int>(best) : 0;
  return out;
}

}  // namespace sspc::codec
