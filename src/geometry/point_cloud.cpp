#include "sspc/point_cloud.hpp"

#include <cmath>
#include <string>

namespace sspc {

void PointCloud::reserve(std::size_t n, bool with_normals, bool with_colors) {
  positions.reserve(n);
  if (with_normals) normals.reserve(n);
  if (with_colors) colors.reserve(n);
}

Box3f PointCloud::bounding_box() const {
  Box3f box;  // Eigen's default box is empty
  for (const Vec3f& p : positions) box.extend(p);
  return box;
}

Status PointCloud::validate() const {
  if (!normals.empty() && normals.size() != positions.size()) {
    return invalid_argument("point cloud has " + std::to_string(positions.size()) +
                            " positions but " + std::to_string(normals.size()) + " normals");
  }
  if (!colors.empty() && colors.size() != positions.size()) {
    return invalid_argument("point cloud has " + std::to_string(positions.size()) +
                            " positions but " + std::to_string(colors.size()) + " colours");
  }
  for (std::size_t i = 0; i < positions.size(); ++i) {
    if (!positions[i].allFinite()) {
      return invalid_argument("point " + std::to_string(i) + " has a non-finite coordinate");
    }
  }
  for (std::size_t i = 0; i < normals.size(); ++i) {
    if (!normals[i].allFinite()) {
      return invalid_argument("normal " + std::to_string(i) + " has a non-finite component");
    }
  }
  return Status();
}

double bounding_box_diagonal(const PointCloud& cloud) {
  if (cloud.empty()) return 0.0;
  const Box3f box = cloud.bounding_box();
  return (box.max().cast<double>() - box.min().cast<double>()).norm();
}

}  // namespace sspc
