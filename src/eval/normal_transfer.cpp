// REF→TEST normal transfer for MPEG D2 (mpeg-pcc-dmetric source/pcc_distortion.cpp,
// scaleNormals; docs/METRICS.md, "D2").
#include "eval/normal_transfer.hpp"

#include <cstdint>

#include "core/parallel.hpp"

namespace sspc::eval {

std::vector<Vec3d> transfer_normals(std::span<const Vec3f> ref_normals,
                                    const NearestGroups& ref_to_test,
                                    const NearestGroups& test_to_ref) {
  const std::size_t test_size = test_to_ref.size();
  std::vector<Vec3d> normals(test_size, Vec3d::Zero());
  std::vector<std::uint32_t> count(test_size, 0);

  // A serial scatter in REF order: each TEST point's sum then has one fixed order of additions,
  // so the result is bit-identical on any number of threads. It is a few hundred milliseconds
  // for ten million points, small beside the neighbour searches.
  for (std::size_t r = 0; r < ref_to_test.size(); ++r) {
    const Vec3d n = ref_normals[r].cast<double>();
    ref_to_test.for_each_member(r, [&](std::uint32_t t) {
      normals[t] += n;
      ++count[t];
    });
  }

  parallel_for(0, test_size, 4096, [&](std::size_t t) {
    if (count[t] > 0) {
      normals[t] /= static_cast<double>(count[t]);
      return;
    }
    // No REF point chose this TEST point (TEST denser than REF there, or an outlier).
    Vec3d sum = Vec3d::Zero();
    std::size_t members = 0;
    test_to_ref.for_each_member(t, [&](std::uint32_t r) {
      sum += ref_normals[r].cast<double>();
      ++members;
    });
    normals[t] = sum / static_cast<double>(members);
  });
  return normals;
}

}  // namespace sspc::eval
