// The LAS writer (ASPRS LAS specification R15): the header, the records that carry the CRS and
// the extra-bytes description, and the point records, produced in chunks so that write_las can
// stream a large cloud to disk.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "sspc/io.hpp"
#include "sspc/point_cloud.hpp"

namespace sspc::io {

class LasEncoder {
 public:
  // Precondition: `cloud` passes validate(). Fails with kInvalidArgument when a coordinate
  // cannot be stored in LAS's 32-bit integers at the chosen scale.
  static StatusOr<LasEncoder> make(const PointCloud& cloud, const LasWriteOptions& options);

  std::string header() const;
  // Appends the point records [begin, end) to `out`.
  void append_points(std::size_t begin, std::size_t end, std::string& out) const;
  // What follows the points: the extended variable-length records (LAS 1.4, §2.7), for records
  // longer than a VLR's 65,535 bytes (a WKT2 CRS can be). Empty for most files.
  std::string trailer() const;

  int point_format() const { return format_; }
  int version_minor() const { return minor_; }

 private:
  explicit LasEncoder(const PointCloud& cloud) : cloud_(&cloud) {}
  void choose_format(const LasWriteOptions& options);
  Status choose_grid(const LasWriteOptions& options);
  void append_record(std::size_t i, std::byte* r) const;

  const PointCloud* cloud_;
  int format_ = 0;
  int minor_ = 2;
  std::size_t record_length_ = 0;
  std::size_t extra_ = 0;  // extra bytes per record
  Vec3d scale_ = Vec3d::Ones();
  Vec3d offset_ = Vec3d::Zero();
  Vec3d anchor_ = Vec3d::Zero();  // (origin − offset) / scale: local values add to it
  std::vector<std::array<std::int32_t, 3>> integers_;
  Vec3d world_min_ = Vec3d::Zero(), world_max_ = Vec3d::Zero();
  std::array<std::uint64_t, 15> by_return_{};
  std::vector<LasRecord> records_;
  std::vector<LasRecord> extended_;  // longer than 65,535 bytes: EVLRs
  bool wkt_ = false;
};

}  // namespace sspc::io
