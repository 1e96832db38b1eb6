// The point cloud model: float32 positions relative to a double-precision origin, optional unit
// normals, optional 8-bit RGB colours, the per-point attributes of a LAS file when it came from
// one, and what a file says about the cloud as a whole (comments, coordinate reference system).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "sspc/status.hpp"

namespace sspc {

using Vec3f = Eigen::Vector3f;
using Vec3d = Eigen::Vector3d;
using Box3f = Eigen::AlignedBox3f;
using Box3d = Eigen::AlignedBox3d;

struct Rgb8 {
  std::uint8_t r = 0, g = 0, b = 0;
  friend bool operator==(const Rgb8&, const Rgb8&) = default;
};

// A LAS variable-length record kept byte for byte (ASPRS LAS specification R15, §2.5): the
// coordinate reference system's GeoTIFF keys and the extra-bytes description travel this way.
struct LasRecord {
  std::string user_id;      // at most 16 bytes
  std::uint16_t record_id = 0;
  std::string description;  // at most 32 bytes
  std::string data;
  friend bool operator==(const LasRecord&, const LasRecord&) = default;
};

// The per-point fields of a LAS point record that sspc keeps (ASPRS LAS specification R15, §2.6
// to §2.16). Each array is empty (the file did not have the field) or as long as the positions.
struct LasPointAttributes {
  std::vector<std::uint16_t> intensity;
  std::vector<std::uint8_t> return_number;      // 1..15 (1..7 in formats 0-5)
  std::vector<std::uint8_t> number_of_returns;  // 1..15 (1..7 in formats 0-5)
  std::vector<std::uint8_t> classification;     // 0..255 (0..31 in formats 0-5)
  // Bit 0 synthetic, 1 key-point, 2 withheld, 3 overlap (formats 6-10; formats 0-5 have the
  // first three in the classification byte's top bits and no overlap bit).
  std::vector<std::uint8_t> classification_flags;
  // Scan angle in degrees: formats 0-5 store whole degrees, formats 6-10 steps of 0.006°.
  std::vector<float> scan_angle;
  // Bit 0 scan direction, bit 1 edge of flight line, bits 2-3 scanner channel (formats 6-10).
  std::vector<std::uint8_t> scan_flags;
  std::vector<std::uint8_t> user_data;
  std::vector<std::uint16_t> point_source_id;
  std::vector<double> gps_time;
  std::vector<std::array<std::uint16_t, 3>> rgb;  // 16 bits per channel, as LAS stores them
  std::vector<std::uint16_t> nir;
  // Bytes of each record past its format's fields (described by the extra-bytes record),
  // `extra_bytes_per_point` per point, points one after the other.
  std::vector<std::uint8_t> extra_bytes;
  std::size_t extra_bytes_per_point = 0;

  bool empty() const;
  // The names of the fields present, for messages ("intensity, classification, GPS time").
  std::string names() const;
  void clear() { *this = LasPointAttributes(); }
};

// Where a cloud read from a LAS file came from: the header fields that a LAS writer needs to
// give back the same integers, and what `sspc info` shows.
struct LasSource {
  std::uint8_t version_major = 1, version_minor = 4;
  std::uint8_t point_format = 0;
  std::uint16_t file_source_id = 0;
  std::uint16_t global_encoding = 0;  // bit 0: GPS time is adjusted standard time
  std::uint16_t creation_day = 0, creation_year = 0;
  Vec3d scale = Vec3d::Ones();  // world = offset + scale · stored integer
  Vec3d offset = Vec3d::Zero();
  std::string system_identifier, generating_software;
  friend bool operator==(const LasSource&, const LasSource&) = default;
};

// What a file says about the cloud as a whole, kept from input to output.
struct CloudMetadata {
  std::vector<std::string> comments;  // PLY comment lines, one each
  std::string crs_wkt;                // OGC WKT of the coordinate reference system, if known
  std::vector<LasRecord> crs_records; // LAS GeoTIFF keys (LASF_Projection 34735-34737)
  std::vector<LasRecord> extra_bytes_records;  // LAS extra-bytes description (LASF_Spec 4)
  std::optional<LasSource> las;       // set by the LAS reader

  bool has_crs() const { return !crs_wkt.empty() || !crs_records.empty(); }
  friend bool operator==(const CloudMetadata&, const CloudMetadata&) = default;
};

// Structure of arrays: `normals`, `colours` and every array of `las` are either empty or exactly
// as long as `positions`.
//
// Positions are local: a point's place in the world is origin + position, in double. float32
// keeps 24 significant bits, so georeferenced coordinates (UTM northings of millions of metres)
// cannot be held to the millimetre without an origin; readers choose one when they must
// (io/wide_positions.hpp), and the codec works on the local values.
struct PointCloud {
  std::vector<Vec3f> positions;
  std::vector<Vec3f> normals;
  std::vector<Rgb8> colours;
  Vec3d origin = Vec3d::Zero();
  LasPointAttributes las;
  CloudMetadata metadata;

  // Point i in the world, in double.
  Vec3d world(std::size_t i) const { return origin + positions[i].cast<double>(); }

  std::size_t size() const { return positions.size(); }
  bool empty() const { return positions.empty(); }
  bool has_normals() const { return !normals.empty(); }
  bool has_colours() const { return !colours.empty(); }

  void reserve(std::size_t n, bool with_normals, bool with_colours);

  // Appends `other`'s points with every per-point array (normals, colours, the LAS fields). The
  // two clouds must carry the same arrays (this one may be empty); origin and metadata stay.
  void append(const PointCloud& other);
  // The points of `parts`, one after the other, with every per-point array (parts with points
  // must carry the same arrays; origin and metadata from the first), copied in parallel into one
  // allocation; each part is freed once copied.
  static PointCloud concatenate(std::vector<PointCloud> parts);
  // Points [begin, end) with every per-point array, the origin and the metadata.
  PointCloud slice(std::size_t begin, std::size_t end) const;
  // The points at `indices` (each below size()), in that order, with every per-point array, the
  // origin and the metadata: a subset, a copy of some points, or a reordering.
  PointCloud select(std::span<const std::uint32_t> indices) const;

  // Axis-aligned bounds of the positions; an empty box for an empty cloud.
  Box3f bounding_box() const;

  // Checks the invariants every consumer relies on: attribute arrays sized like the positions,
  // every coordinate and the origin finite. Readers call it before returning a cloud.
  Status validate() const;
};

// Length of the bounding-box diagonal (the paper's d_B); 0 for fewer than two distinct points.
double bounding_box_diagonal(const PointCloud& cloud);

}  // namespace sspc
