// Positions at the precision a file stores them in (double, integers, decimal text), read beside
// the float32 ones the point cloud holds, for two uses: giving the cloud an origin when float32
// would lose detail the file holds, and the double copy of ReadOptions::positions_f64 (what
// sspc eval computes from).
//
// The rule for the origin. float32 keeps 24 significant bits, so reading a coordinate c moves
// it by up to half of ulp(c) = 2^(floor(log2 |c|) - 23): the error grows with the distance from
// the origin, while the detail a cloud holds is set by its size. With D the cloud's extent (the
// largest of max - min over the three axes, from the file's values), a reader warns when
// narrowing to float32 moved some coordinate by more than D * 2^-16. A million-point scan has a
// spacing near D / 1000, about D * 2^-10, so the rule fires when rounding reaches about 1/64 of
// such a spacing, detail that a codec at 16 bits per axis or a distortion metric still sees. A
// cloud whose coordinates stay within its extent (|c| <= D) moves by at most D * 2^-24, 256
// times less, so only an offset hundreds of times the extent trips the rule, as when a
// georeferenced scan keeps its UTM coordinates. The reader then subtracts an origin: the centre of
// the bounding box rounded to a multiple of the largest power of ten not above D (a round
// number a person can read, which moves the local values by at most D / 2), and narrows
// stored − origin, in double, to float32: each position is then within half a float32 step of
// its local value, as for a cloud near zero. D, not the axis's own extent, is the scale: a wall scanned face-on is thin along one axis without its points
// being any closer together. Values that float32 holds exactly (integers up to 2^24) move by
// nothing and never warn.
#pragma once

#include <cstddef>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/byte_reader.hpp"
#include "io/strided_fields.hpp"
#include "sspc/io.hpp"
#include "sspc/point_cloud.hpp"

namespace sspc::io {

// Per axis: the range of a file's coordinates and the largest change narrowing to float32 made
// to any of them. Parts merge in any order with the same result.
struct CoordinateStats {
  Vec3d min = Vec3d::Constant(std::numeric_limits<double>::infinity());
  Vec3d max = Vec3d::Constant(-std::numeric_limits<double>::infinity());
  Vec3d max_error = Vec3d::Zero();

  void add(const Vec3d& stored, const Vec3f& held) {
    min = min.cwiseMin(stored);
    max = max.cwiseMax(stored);
    max_error = max_error.cwiseMax((held.cast<double>() - stored).cwiseAbs());
  }
  void merge(const CoordinateStats& other);
};

// What the rule above finds without an origin: the file, the worst axis, its magnitude and the
// precision lost; nullopt when float32 keeps the cloud's detail.
std::optional<std::string> float32_precision_warning(const CoordinateStats& stats,
                                                     std::string_view name);

// The origin the rule above chooses for a cloud of these stats (the rounded centre).
Vec3d round_origin(const CoordinateStats& stats);

class WidePositions {
 public:
  // `stored_wider`: the file stores positions in a type that float32 may not hold exactly
  // (double, integers, decimal text); they are then kept in double until finish(). When false,
  // the double copy is made from the floats and there is nothing to check.
  WidePositions(const ReadOptions& options, bool stored_wider);

  // Whether the reader must pass each position, as stored, to add() or add_block().
  bool wanted() const { return wanted_; }

  // Sequential readers, point after point: the stored value and the float the cloud holds.
  void add(const Vec3d& stored, const Vec3f& held) {
    stats_.add(stored, held);
    copy_->push_back(stored);
  }
  // Fixed-stride binary readers: the `held.size()` points of a block whose x, y and z are
  // `fields`, in parallel (unchecked, as decode_vec3).
  void add_block(const std::byte* block, const StridedField (&fields)[3], Endian endian,
                 std::span<const Vec3f> held);

  // Once the cloud is read: gives it an origin and narrows its positions again when the rule
  // calls for one, and completes the copy for float32 files.
  void finish(PointCloud& cloud);

  // The origin the rule chooses from every position added so far; nullopt when the positions
  // stay as read (float32 holds the cloud's detail, or the file stores nothing wider).
  std::optional<Vec3d> origin() const;

  // For a file read in chunks, whose origin a first pass chose. Narrows `positions`, the points
  // added since the last call, as stored − origin (exactly as finish() narrows a whole cloud),
  // then forgets their stored values.
  void narrow_added(const Vec3d& origin, std::span<Vec3f> positions);
  // Forgets the stored values added so far and keeps what the origin depends on (a first pass).
  void forget_added() { copy_->clear(); }

 private:
  bool stored_wider_;
  std::vector<Vec3d> own_copy_;
  std::vector<Vec3d>* copy_;  // ReadOptions::positions_f64, else own_copy_
  bool wanted_;
  CoordinateStats stats_;
};

}  // namespace sspc::io
