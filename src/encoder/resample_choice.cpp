#include "encoder/resample_choice.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "core/parallel.hpp"
#include "sspc/neighbours.hpp"

namespace sspc::codec {

ResampleMeter::ResampleMeter(const CompressedModel& geometry, float radius, int max_m)
    : geometry_(geometry), radius_(radius), candidates_(static_cast<std::size_t>(std::max(max_m, 0)) + 1),
      totals_(candidates_) {}

Status ResampleMeter::add(const PointCloud& source, std::span<const Vec3f> centres) {
  if (source.empty() || centres.empty()) return Status();
  // The decode reaches past the sphere by half its radius, so that a source point at its
  // border finds the decoded points beyond it.
  const Vec3f reach = Vec3f::Constant(1.5f * radius_);
  const float r2 = radius_ * radius_;
  const std::size_t candidates = candidates_;
  // Each centre's source points within its decode's box, gathered in one pass over the source
  // in index order (a k-d tree of a whole tile, 10M points, would cost seconds and 100 MB):
  // the centres sorted by x, each point tested against those within reach in x.
  std::vector<std::uint32_t> by_x(centres.size());
  for (std::size_t s = 0; s < centres.size(); ++s) by_x[s] = static_cast<std::uint32_t>(s);
  std::sort(by_x.begin(), by_x.end(), [&](std::uint32_t a, std::uint32_t b) {
    return std::pair(centres[a].x(), a) < std::pair(centres[b].x(), b);
  });
  std::vector<float> xs(centres.size());
  for (std::size_t i = 0; i < centres.size(); ++i) xs[i] = centres[by_x[i]].x();
  std::vector<std::vector<Vec3f>> local(centres.size());
  for (const Vec3f& p : source.positions) {
    const auto from = std::lower_bound(xs.begin(), xs.end(), p.x() - reach.x());
    for (auto it = from; it != xs.end() && *it <= p.x() + reach.x(); ++it) {
      const std::uint32_t s = by_x[static_cast<std::size_t>(it - xs.begin())];
      if (((p - centres[s]).cwiseAbs().array() <= reach.array()).all()) local[s].push_back(p);
    }
  }
  // Per centre and candidate, summed in order afterwards: the same on every thread count.
  std::vector<Sums> sums(centres.size() * candidates);
  std::vector<Status> status(centres.size());
  parallel_for(0, centres.size(), 1, [&](std::size_t s) {
    const Vec3f c = centres[s];
    if (local[s].empty()) return;
    const KdTree3 near(local[s]);
    for (std::size_t m = 0; m < candidates; ++m) {
      DecodeOptions options;
      options.resample = static_cast<int>(m);
      StatusOr<PointCloud> decoded = geometry_.decode_box(Box3f(c - reach, c + reach), options);
      if (!decoded.ok()) {
        status[s] = decoded.status();
        return;
      }
      if (decoded->empty()) return;  // a centre whose patch decodes to nothing here: skipped
      const KdTree3 tree(decoded->positions);
      Sums& sum = sums[s * candidates + m];
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
        near.nearest(p, &d2);
        sum.to_source += static_cast<double>(d2);
        ++sum.decoded_points;
      }
    }
  });
  for (const Status& s : status) SSPC_RETURN_IF_ERROR(s);
  for (std::size_t s = 0; s < centres.size(); ++s) {
    // A sphere counts only where every candidate measured it, so that all compare the same points.
    bool complete = true;
    for (std::size_t m = 0; m < candidates; ++m) complete = complete && sums[s * candidates + m].source_points > 0;
    if (!complete) continue;
    for (std::size_t m = 0; m < candidates; ++m) {
      const Sums& a = sums[s * candidates + m];
      totals_[m].to_decoded += a.to_decoded;
      totals_[m].to_source += a.to_source;
      totals_[m].source_points += a.source_points;
      totals_[m].decoded_points += a.decoded_points;
    }
  }
  return Status();
}

std::vector<double> ResampleMeter::errors() const {
  std::vector<double> error(candidates_, std::numeric_limits<double>::infinity());
  for (std::size_t m = 0; m < candidates_; ++m) {
    const Sums& t = totals_[m];
    if (t.source_points == 0 || t.decoded_points == 0) continue;
    error[m] = std::max(t.to_decoded / static_cast<double>(t.source_points),
                        t.to_source / static_cast<double>(t.decoded_points));
  }
  return error;
}

int ResampleMeter::chosen() const {
  const std::vector<double> error = errors();
  std::size_t best = 0;
  for (std::size_t m = 1; m < error.size(); ++m) {
    if (error[m] < error[best]) best = m;
  }
  return best > 0 && error[best] < 0.98 * error[0] ? static_cast<int>(best) : 0;
}

}  // namespace sspc::codec
