// sspc::move_to_common_origin: the clouds sspc eval compares, re-expressed about one origin
// computed in double (docs/METRICS.md, "Coordinates far from the origin").
#include <string>

#include "sspc/metrics.hpp"

namespace sspc {

namespace {

Status check_stored(const PointCloud& cloud, std::span<const Vec3d> stored, const char* name) {
  if (stored.size() == cloud.size()) return Status();
  return invalid_argument(std::string(name) + " has " + std::to_string(cloud.size()) +
                          " points but " + std::to_string(stored.size()) + " stored positions");
}

void move(PointCloud& cloud, std::span<const Vec3d> stored, const Vec3d& origin) {
  for (std::size_t i = 0; i < stored.size(); ++i) {
    cloud.positions[i] = (stored[i] - origin).cast<float>();
  }
  cloud.origin = origin;  // the positions are local to it now, whatever the reader chose
}

}  // namespace

StatusOr<Vec3d> move_to_common_origin(PointCloud& ref, std::span<const Vec3d> ref_stored,
                                      PointCloud& test, std::span<const Vec3d> test_stored) {
  SSPC_RETURN_IF_ERROR(check_stored(ref, ref_stored, "REF"));
  SSPC_RETURN_IF_ERROR(check_stored(test, test_stored, "TEST"));
  if (ref_stored.empty()) return Vec3d(Vec3d::Zero());
  Eigen::AlignedBox3d box;
  for (const Vec3d& p : ref_stored) box.extend(p);
  const Vec3d origin = box.center();
  move(ref, ref_stored, origin);
  move(test, test_stored, origin);
  return origin;
}

}  // namespace sspc
