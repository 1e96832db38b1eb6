#include "sspc/point_cloud.hpp"

#include "sspc/neighbours.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/parallel.hpp"

namespace sspc {

void PointCloud::reserve(std::size_t n, bool with_normals, bool with_colours) {
  positions.reserve(n);
  if (with_normals) normals.reserve(n);
  if (with_colours) colours.reserve(n);
}

namespace {

// Calls f(to_array, from_array, values_per_point) for every per-point array of the two clouds,
// so that the list of arrays is written once.
template <typename F>
void for_each_array(PointCloud& to, const PointCloud& from, F f) {
  f(to.positions, from.positions, std::size_t{1});
  f(to.normals, from.normals, std::size_t{1});
  f(to.colours, from.colours, std::size_t{1});
  LasPointAttributes& a = to.las;
  const LasPointAttributes& b = from.las;
  f(a.intensity, b.intensity, std::size_t{1});
  f(a.return_number, b.return_number, std::size_t{1});
  f(a.number_of_returns, b.number_of_returns, std::size_t{1});
  f(a.classification, b.classification, std::size_t{1});
  f(a.classification_flags, b.classification_flags, std::size_t{1});
  f(a.scan_angle, b.scan_angle, std::size_t{1});
  f(a.scan_flags, b.scan_flags, std::size_t{1});
  f(a.user_data, b.user_data, std::size_t{1});
  f(a.point_source_id, b.point_source_id, std::size_t{1});
  f(a.gps_time, b.gps_time, std::size_t{1});
  f(a.rgb, b.rgb, std::size_t{1});
  f(a.nir, b.nir, std::size_t{1});
  f(a.extra_bytes, b.extra_bytes, b.extra_bytes_per_point);
}

}  // namespace

void PointCloud::append(const PointCloud& other) {
  for_each_array(*this, other, [](auto& to, const auto& from, std::size_t) { to.insert(to.end(), from.begin(), from.end()); });
  if (las.extra_bytes_per_point == 0) las.extra_bytes_per_point = other.las.extra_bytes_per_point;
}

PointCloud PointCloud::concatenate(std::vector<PointCloud> parts) {
  PointCloud out;
  if (parts.empty()) return out;
  std::vector<std::size_t> first(parts.size() + 1, 0);
  for (std::size_t p = 0; p < parts.size(); ++p) first[p + 1] = first[p] + parts[p].size();
  out.origin = parts.front().origin;
  out.metadata = parts.front().metadata;
  out.las.extra_bytes_per_point = parts.front().las.extra_bytes_per_point;
  // Every array sized once, each part's share copied by its own task: one thread appending
  // part after part was 7% of a 2-thread decode_all of dragon_scans, and growing the arrays
  // faulted their pages in twice.
  for (const PointCloud& part : parts) {  // an empty part carries no arrays: each is sized by the first that has it
    for_each_array(out, part, [&](auto& to, const auto& from, std::size_t per_point) {
      if (to.empty() && !from.empty()) to.resize(first.back() * per_point);
    });
  }
  parallel_for(0, parts.size(), 1, [&](std::size_t p) {
    PointCloud& target = out;  // the arrays are sized: each task writes its own range
    for_each_array(target, parts[p], [&](auto& to, const auto& from, std::size_t per_point) {
      if (to.empty()) return;
      std::copy(from.begin(), from.end(), to.begin() + static_cast<std::ptrdiff_t>(first[p] * per_point));
    });
    parts[p] = PointCloud();
  });
  return out;
}

PointCloud PointCloud::slice(std::size_t begin, std::size_t end) const {
  PointCloud out;
  for_each_array(out, *this, [begin, end](auto& to, const auto& from, std::size_t per_point) {
    if (from.empty()) return;
    to.assign(from.begin() + static_cast<std::ptrdiff_t>(begin * per_point),
              from.begin() + static_cast<std::ptrdiff_t>(end * per_point));
  });
  out.las.extra_bytes_per_point = las.extra_bytes_per_point;
  out.origin = origin;
  out.metadata = metadata;
  return out;
}

PointCloud PointCloud::select(std::span<const std::uint32_t> indices) const {
  PointCloud out;
  for_each_array(out, *this, [&](auto& to, const auto& from, std::size_t per_point) {
    if (!from.empty()) to.resize(indices.size() * per_point);
  });
  // One parallel loop over the points, every array inside it: a loop per array instantiated TBB's
  // loop for each of the 16 element types, and this file took 13 s to compile instead of 5.
  parallel_for_ranges(0, indices.size(), 4096, [&](std::size_t begin, std::size_t end) {
    PointCloud& target = out;  // sized above: each range writes its own points
    for_each_array(target, *this, [&](auto& to, const auto& from, std::size_t per_point) {
      if (from.empty()) return;
      for (std::size_t i = begin; i < end; ++i) {
        std::copy_n(from.begin() + static_cast<std::ptrdiff_t>(indices[i] * per_point), per_point,
                    to.begin() + static_cast<std::ptrdiff_t>(i * per_point));
      }
    });
  });
  out.las.extra_bytes_per_point = las.extra_bytes_per_point;
  out.origin = origin;
  out.metadata = metadata;
  return out;
}

Box3f PointCloud::bounding_box() const {
  Box3f box;  // Eigen's default box is empty
  for (const Vec3f& p : positions) box.extend(p);
  return box;
}

namespace {

// "intensity" when `values` is neither empty nor as long as the positions.
template <typename T>
void check_size(const std::vector<T>& values, std::size_t n, const char* name,
                std::string& wrong) {
  if (!values.empty() && values.size() != n && wrong.empty()) wrong = name;
}

struct NamedField {
  const char* name;
  bool present;
};

}  // namespace

bool LasPointAttributes::empty() const { return names().empty(); }

std::string LasPointAttributes::names() const {
  const NamedField fields[] = {
      {"intensity", !intensity.empty()},
      {"return numbers", !return_number.empty() || !number_of_returns.empty()},
      {"classification", !classification.empty()},
      {"classification flags", !classification_flags.empty()},
      {"scan angle", !scan_angle.empty()},
      {"scan direction and channel", !scan_flags.empty()},
      {"user data", !user_data.empty()},
      {"point source id", !point_source_id.empty()},
      {"GPS time", !gps_time.empty()},
      {"16-bit RGB", !rgb.empty()},
      {"NIR", !nir.empty()},
      {"extra bytes", !extra_bytes.empty()},
  };
  std::string out;
  for (const NamedField& f : fields) {
    if (!f.present) continue;
    if (!out.empty()) out += ", ";
    out += f.name;
  }
  return out;
}

Status PointCloud::validate() const {
  if (!origin.allFinite() || (origin.array().abs() > kMaxCoordinate).any()) {
    return invalid_argument("point cloud has an origin that is not finite or beyond +-1e18");
  }
  std::string wrong;
  const std::size_t n = positions.size();
  check_size(las.intensity, n, "intensity", wrong);
  check_size(las.return_number, n, "return number", wrong);
  check_size(las.number_of_returns, n, "number of returns", wrong);
  check_size(las.classification, n, "classification", wrong);
  check_size(las.classification_flags, n, "classification flags", wrong);
  check_size(las.scan_angle, n, "scan angle", wrong);
  check_size(las.scan_flags, n, "scan flags", wrong);
  check_size(las.user_data, n, "user data", wrong);
  check_size(las.point_source_id, n, "point source id", wrong);
  check_size(las.gps_time, n, "GPS time", wrong);
  check_size(las.rgb, n, "16-bit RGB", wrong);
  check_size(las.nir, n, "NIR", wrong);
  if (!las.extra_bytes.empty() && las.extra_bytes.size() != n * las.extra_bytes_per_point &&
      wrong.empty()) {
    wrong = "extra bytes";
  }
  if (!wrong.empty()) {
    return invalid_argument("point cloud has " + std::to_string(n) + " positions and a " + wrong +
                            " array of another length");
  }
  if (!normals.empty() && normals.size() != positions.size()) {
    return invalid_argument("point cloud has " + std::to_string(positions.size()) +
                            " positions but " + std::to_string(normals.size()) + " normals");
  }
  if (!colours.empty() && colours.size() != positions.size()) {
    return invalid_argument("point cloud has " + std::to_string(positions.size()) +
                            " positions but " + std::to_string(colours.size()) + " colours");
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
