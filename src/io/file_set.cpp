// Several files as one cloud (sspc/io.hpp: input_files, FileSetOrigin, read_point_clouds): a
// survey arrives as thousands of tiles in one CRS, and each file's reader chooses an origin of
// its own (wide_positions.hpp); the set takes one for all.
#include <glob.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <system_error>
#include <vector>

#include "io/wide_positions.hpp"
#include "sspc/io.hpp"

namespace sspc {
namespace {

bool is_cloud_file(const std::filesystem::path& path) {
  const PointCloudFormat format = format_from_extension(path);
  return format != PointCloudFormat::kAuto;
}

// A folder's point-cloud files (by extension), sorted by name.
StatusOr<std::vector<std::filesystem::path>> folder_files(const std::filesystem::path& dir) {
  std::vector<std::filesystem::path> files;
  std::error_code ec;
  for (std::filesystem::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    if (it->is_regular_file(ec) && is_cloud_file(it->path())) files.push_back(it->path());
  }
  if (ec) return io_error(dir.string() + ": cannot list the folder: " + ec.message());
  if (files.empty()) return invalid_argument(dir.string() + ": the folder holds no point-cloud files");
  std::sort(files.begin(), files.end());
  return files;
}

StatusOr<std::vector<std::filesystem::path>> glob_files(const std::string& pattern) {
  glob_t found{};
  const int rc = ::glob(pattern.c_str(), GLOB_ERR, nullptr, &found);
  std::vector<std::filesystem::path> files;
  for (std::size_t i = 0; rc == 0 && i < found.gl_pathc; ++i) files.emplace_back(found.gl_pathv[i]);
  globfree(&found);
  if (rc == GLOB_NOSPACE) return resource_exhausted(pattern + ": out of memory expanding the pattern");
  if (rc != 0 || files.empty()) return invalid_argument(pattern + ": no file matches");
  return files;  // glob(3) sorts
}

// Every per-point array that one of `parts` lacks is dropped from all: the set carries what each
// of its files carries.
void keep_common_arrays(std::vector<PointCloud>& parts) {
  auto each = [&parts](auto member) {
    const bool everywhere = std::all_of(parts.begin(), parts.end(), [&](const PointCloud& p) {
      return !(p.*member).empty() || p.empty();
    });
    if (!everywhere) {
      for (PointCloud& p : parts) (p.*member).clear();
    }
  };
  each(&PointCloud::normals);
  each(&PointCloud::colours);
  auto las = [&parts](auto member) {
    const bool everywhere = std::all_of(parts.begin(), parts.end(), [&](const PointCloud& p) {
      return !(p.las.*member).empty() || p.empty();
    });
    if (!everywhere) {
      for (PointCloud& p : parts) (p.las.*member).clear();
    }
  };
  using A = LasPointAttributes;
  las(&A::intensity);
  las(&A::return_number);
  las(&A::number_of_returns);
  las(&A::classification);
  las(&A::classification_flags);
  las(&A::scan_angle);
  las(&A::scan_flags);
  las(&A::user_data);
  las(&A::point_source_id);
  las(&A::gps_time);
  las(&A::rgb);
  las(&A::nir);
  const std::size_t extra = parts[0].las.extra_bytes_per_point;
  if (!std::all_of(parts.begin(), parts.end(), [&](const PointCloud& p) { return p.las.extra_bytes_per_point == extra; })) {
    for (PointCloud& p : parts) {
      p.las.extra_bytes.clear();
      p.las.extra_bytes_per_point = 0;
    }
  }
}

}  // namespace

StatusOr<std::vector<std::filesystem::path>> input_files(std::span<const std::string> args) {
  std::vector<std::filesystem::path> files;
  for (const std::string& arg : args) {
    std::error_code ec;
    std::vector<std::filesystem::path> part;
    if (std::filesystem::is_directory(arg, ec)) {
      SSPC_ASSIGN_OR_RETURN(part, folder_files(arg));
    } else if (!std::filesystem::exists(arg, ec) && arg.find_first_of("*?[") != std::string::npos) {
      SSPC_ASSIGN_OR_RETURN(part, glob_files(arg));
    } else {
      part.emplace_back(arg);
    }
    files.insert(files.end(), part.begin(), part.end());
  }
  for (std::size_t i = 0; i < files.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      std::error_code a, b;
      if (std::filesystem::weakly_canonical(files[i], a) == std::filesystem::weakly_canonical(files[j], b)) {
        return invalid_argument(files[i].string() + ": given twice as an input");
      }
    }
  }
  return files;
}

void FileSetOrigin::add(const std::filesystem::path& file, const Vec3d& origin, const Box3f& local,
                        const CloudMetadata& metadata) {
  if (files_ == 0) {
    first_origin_ = origin;
    first_file_ = file.string();
    crs_wkt_ = metadata.crs_wkt;
    crs_records_ = metadata.crs_records;
  } else if (metadata.crs_wkt != crs_wkt_ || metadata.crs_records != crs_records_) {
    crs_differs_ = file.string();
  }
  ++files_;
  same_origin_ = same_origin_ && origin == first_origin_;
  if (local.isEmpty()) return;
  world_min_ = world_min_.cwiseMin(origin + local.min().cast<double>());
  world_max_ = world_max_.cwiseMax(origin + local.max().cast<double>());
}

StatusOr<Vec3d> FileSetOrigin::origin() const {
  if (!crs_differs_.empty()) {
    return invalid_argument(crs_differs_ + ": its coordinate reference system differs from " + first_file_ +
                            "'s; the files of one cloud must share one");
  }
  if (same_origin_ || !world_min_.allFinite()) return first_origin_;
  io::CoordinateStats stats;
  stats.min = world_min_;
  stats.max = world_max_;
  return io::round_origin(stats);
}

void move_to_origin(PointCloud& cloud, const Vec3d& origin) {
  if (cloud.origin == origin) return;
  const Vec3d shift = cloud.origin - origin;
  for (Vec3f& p : cloud.positions) p = (shift + p.cast<double>()).cast<float>();
  cloud.origin = origin;
}

StatusOr<PointCloud> read_point_clouds(std::span<const std::filesystem::path> paths, const ReadOptions& options) {
  if (paths.empty()) return invalid_argument("no input file");
  if (paths.size() == 1) return read_point_cloud(paths[0], options);
  std::vector<PointCloud> parts;
  FileSetOrigin origin;
  for (const std::filesystem::path& path : paths) {
    SSPC_ASSIGN_OR_RETURN(PointCloud part, read_point_cloud(path, options));
    origin.add(path, part.origin, part.bounding_box(), part.metadata);
    parts.push_back(std::move(part));
  }
  SSPC_ASSIGN_OR_RETURN(const Vec3d shared, origin.origin());
  for (PointCloud& part : parts) move_to_origin(part, shared);
  keep_common_arrays(parts);
  PointCloud cloud = PointCloud::concatenate(std::move(parts));
  cloud.origin = shared;
  return cloud;
}

}  // namespace sspc
