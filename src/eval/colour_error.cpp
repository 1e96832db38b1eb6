// Colour distortion of one direction (definition in docs/METRICS.md, "Colour").
#include "eval/colour_error.hpp"

#include <array>
#include <cstddef>
#include <cstdint>

#include "core/check.hpp"
#include "core/parallel.hpp"

namespace sspc::eval {

double colour_mse(std::span<const Rgb8> from, std::span<const Rgb8> to,
                  const NearestGroups& groups) {
  SSPC_DCHECK(groups.size() == from.size());
  if (from.empty()) return 0.0;
  // Per point, the squared differences summed over the three channels; the division by 3 and by
  // the point count waits for the total, so that a constant error of k levels sums exactly to k².
  const double sum = deterministic_sum<double>(0, from.size(), [&](std::size_t a) {
    // Integer channel sums are exact (a group holds at most kMaxGroup points), so the mean
    // colour does not depend on the order of the group's members.
    std::array<std::uint32_t, 3> channels{0, 0, 0};
    std::uint32_t members = 0;
    groups.for_each_member(a, [&](std::uint32_t b) {
      channels[0] += to[b].r;
      channels[1] += to[b].g;
      channels[2] += to[b].b;
      ++members;
    });
    const std::array<double, 3> own{static_cast<double>(from[a].r), static_cast<double>(from[a].g),
                                    static_cast<double>(from[a].b)};
    double e = 0;
    for (std::size_t c = 0; c < 3; ++c) {
      const double diff = own[c] - static_cast<double>(channels[c]) / static_cast<double>(members);
      e += diff * diff;
    }
    return e;
  });
  return sum / (3.0 * static_cast<double>(from.size()));
}

}  // namespace sspc::eval
