// Tile jobs and results as bytes (encoder/tile_job.hpp).
#include "encoder/tile_job.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

#include "core/byte_reader.hpp"
#include "core/format_number.hpp"
#include "format/checksum.hpp"
#include "sspc/encoder.hpp"
#include "sspc/neighbours.hpp"

namespace sspc::codec {
namespace {

constexpr std::string_view kJobMagic{"SSPCTJ03", 8};
constexpr std::string_view kResultMagic{"SSPCTR03", 8};

std::uint32_t crc_of(std::string_view bytes) {
  return crc32_of(std::as_bytes(std::span(bytes.data(), bytes.size())));
}

// A message's last four bytes are the CRC32 of the rest: a job or result damaged in transit or on
// shared storage is refused before any of its fields is read.
StatusOr<std::string_view> checked_body(std::string_view bytes, std::string_view what) {
  if (bytes.size() < 12) return corrupt(std::string(what) + ": truncated (" + std::to_string(bytes.size()) + " bytes)");
  const std::string_view body = bytes.substr(0, bytes.size() - 4);
  std::uint32_t stored = 0;
  std::memcpy(&stored, bytes.data() + body.size(), 4);
  if (stored != crc_of(body)) return corrupt(std::string(what) + ": checksum mismatch (damaged or truncated)");
  return body;
}

bool finite(const Vec3f& v) { return v.allFinite(); }

bool all_finite(const std::vector<Vec3f>& v) {
  for (const Vec3f& p : v) {
    if (!finite(p)) return false;
  }
  return true;
}

bool within_range(const Vec3f& v) { return (v.cast<double>().array().abs() <= kMaxCoordinate).all(); }

// A rotation as a decoder would accept it: finite, orthonormal and proper within float rounding.
bool is_rotation(const Eigen::Matrix3f& r) {
  if (!r.allFinite()) return false;
  const Eigen::Matrix3f gram = r.transpose() * r;
  return (gram - Eigen::Matrix3f::Identity()).cwiseAbs().maxCoeff() < 1e-3f && std::abs(r.determinant() - 1.0f) < 1e-3f;
}

// The bounds a job's parameters must keep: those of an encode's own checks (check_options), and
// ratios between the patch radius, the spacing and the part's extent that any real cloud keeps
// (a patch holds 8 to kMaxPatchPoints points, so its radius is 1.6 to a few hundred spacings)
// and that keep every grid over them within 32-bit cells.
Status check_job(const TileJob& job) {
  const BuildOptions& b = job.build;
  const LevelParams& l = b.level;
  auto in = [](float v, float lo, float hi) { return std::isfinite(v) && v >= lo && v <= hi; };
  if (l.patch_points < 8 || l.patch_points > kMaxPatchPoints || !in(l.epsilon, 0, 1e3f) || !in(l.tau, 0, 1e3f) ||
      !in(l.position_step, 0, 1e3f)) {
    return corrupt("tile job: level parameters out of range");
  }
  if (job.normals.k < 3 || job.normals.k > 256) return corrupt("tile job: normals' k out of range");
  if (job.normals.viewpoint && !finite(*job.normals.viewpoint)) return corrupt("tile job: viewpoint not finite");
  if (!all_finite(job.part.positions) || !all_finite(job.part.normals)) {
    return corrupt("tile job: a point or normal is not finite");
  }
  // As an encode's own input: within kMaxCoordinate (a span of 6e38 overflowed float in the
  // points' ordering, found by the tile_result fuzzer).
  if (Status range = check_coordinate_range(job.part.positions); !range.ok()) {
    return corrupt("tile job: " + range.message());
  }
  const double radius = static_cast<double>(b.patch_radius);
  if (!(b.spacing > 0) || !std::isfinite(b.spacing) || !(radius > 0) || !std::isfinite(radius)) {
    return corrupt("tile job: spacing and patch radius must be finite and positive");
  }
  if (radius < b.spacing / 16 || radius > b.spacing * 65536) {
    return corrupt("tile job: a patch radius of " + format_number(radius / b.spacing) + " spacings (1/16 to 65536)");
  }
  const Box3f box = job.part.bounding_box();
  const double extent = box.isEmpty() ? 0.0 : (box.max().cast<double>() - box.min().cast<double>()).norm();
  if (extent / radius > double{1 << 24}) return corrupt("tile job: the part spans more than 2^24 patch radii");
  return Status();
}

}  // namespace

Status check_tile_result(const TileResult& result) {
  const EncodedModel& m = result.model;
  for (float v : {m.patch_radius, m.coverage_radius, m.spacing}) {
    if (!(v > 0) || !std::isfinite(v)) return corrupt("tile result: radii and spacing must be finite and positive");
  }
  if (!(result.max_coverage_distance >= 0) || !std::isfinite(result.max_coverage_distance)) {
    return corrupt("tile result: the coverage distance is not finite");
  }
  for (std::size_t c = 0; c < m.codebook.size(); ++c) {
    if (!all_finite(m.codebook[c].points) || !all_finite(m.codebook[c].normals) ||
        !std::all_of(m.codebook[c].points.begin(), m.codebook[c].points.end(), within_range)) {
      return corrupt("tile result: code word " + std::to_string(c) +
                     " has a point or normal that is not finite or beyond +-1e18");
    }
  }
  for (std::size_t k = 0; k < m.patches.size(); ++k) {
    const RigidTransform& t = m.patches[k].world_from_codeword;
    if (!is_rotation(t.rotation) || !finite(t.translation) || !within_range(t.translation)) {
      return corrupt("tile result: patch " + std::to_string(k) + "'s transform is not a finite rotation");
    }
  }
  return Status();
}

namespace {

class Writer {
 public:
  std::string out;
  template <typename T>
  void put(T v) {
    static_assert(std::is_trivially_copyable_v<T>);
    char bytes[sizeof(T)];
    std::memcpy(bytes, &v, sizeof(T));  // little-endian hosts only: see the constructor below
    out.append(bytes, sizeof(T));
  }
  void put_vec3s(const std::vector<Vec3f>& v) {
    put<std::uint64_t>(v.size());
    for (const Vec3f& p : v) {
      put(p.x());
      put(p.y());
      put(p.z());
    }
  }
  // The message with its CRC32 trailer (checked_body).
  std::string sealed() && {
    put(crc_of(out));
    return std::move(out);
  }
  Writer() { static_assert(std::endian::native == std::endian::little, "tile messages assume little-endian"); }
};

class Reader {
 public:
  explicit Reader(std::string_view bytes) : in_(std::as_bytes(std::span(bytes.data(), bytes.size()))) {}
  template <typename T>
  Status get(T& v) {
    return in_.read_into(v);
  }
  Status get_vec3s(std::vector<Vec3f>& v) {
    std::uint64_t n = 0;
    SSPC_RETURN_IF_ERROR(in_.read_into(n));
    if (n > in_.remaining() / 12) return corrupt("tile message: a count runs past its bytes");
    v.resize(n);
    for (Vec3f& p : v) {
      SSPC_RETURN_IF_ERROR(in_.read_into(p.x()));
      SSPC_RETURN_IF_ERROR(in_.read_into(p.y()));
      SSPC_RETURN_IF_ERROR(in_.read_into(p.z()));
    }
    return Status();
  }
  Status magic(std::string_view m) {
    auto got = in_.read_bytes(m.size());
    if (!got.ok() || std::memcmp(got->data(), m.data(), m.size()) != 0) {
      return corrupt("not a tile message of this sspc (bad magic)");
    }
    return Status();
  }
  std::size_t remaining() const { return in_.remaining(); }
  bool at_end() const { return in_.at_end(); }

 private:
  ByteReader in_;
};

}  // namespace

std::string serialise_tile_job(const TileJob& job) {
  Writer w;
  w.out.append(kJobMagic);
  w.put<std::uint64_t>(job.tile);
  const BuildOptions& b = job.build;
  w.put<std::int32_t>(b.level.patch_points);
  w.put(b.level.epsilon);
  w.put(b.level.tau);
  w.put(b.level.position_step);
  w.put<std::uint64_t>(b.seed);
  w.put(b.spacing);
  w.put(b.patch_radius);
  w.put<std::uint64_t>(b.core_points);
  w.put<std::uint8_t>(b.codeword_normals ? 1 : 0);
  w.put<std::uint8_t>(static_cast<std::uint8_t>(job.normals.mode));
  w.put<std::int32_t>(job.normals.k);
  w.put<std::uint8_t>(job.normals.viewpoint ? 1 : 0);
  const Vec3f view = job.normals.viewpoint.value_or(Vec3f::Zero());
  w.put(view.x());
  w.put(view.y());
  w.put(view.z());
  w.put_vec3s(job.part.positions);
  w.put_vec3s(job.part.normals);
  return std::move(w).sealed();
}

// The CRC32 of the job's body, which its trailer holds when intact. (Not the CRC of the whole
// message: a CRC over bytes followed by their own CRC is the same constant for every message.)
std::uint32_t tile_job_digest(std::string_view job) { return crc_of(job.substr(0, job.size() < 4 ? 0 : job.size() - 4)); }

StatusOr<TileJob> parse_tile_job(std::string_view bytes) {
  SSPC_ASSIGN_OR_RETURN(const std::string_view body, checked_body(bytes, "tile job"));
  Reader r(body);
  SSPC_RETURN_IF_ERROR(r.magic(kJobMagic));
  TileJob job;
  SSPC_RETURN_IF_ERROR(r.get(job.tile));
  BuildOptions& b = job.build;
  std::int32_t patch_points = 0, k = 0;
  std::uint64_t seed = 0, core = 0;
  std::uint8_t mode = 0, has_view = 0, codeword_normals = 0;
  Vec3f view;
  SSPC_RETURN_IF_ERROR(r.get(patch_points));
  SSPC_RETURN_IF_ERROR(r.get(b.level.epsilon));
  SSPC_RETURN_IF_ERROR(r.get(b.level.tau));
  SSPC_RETURN_IF_ERROR(r.get(b.level.position_step));
  SSPC_RETURN_IF_ERROR(r.get(seed));
  SSPC_RETURN_IF_ERROR(r.get(b.spacing));
  SSPC_RETURN_IF_ERROR(r.get(b.patch_radius));
  SSPC_RETURN_IF_ERROR(r.get(core));
  SSPC_RETURN_IF_ERROR(r.get(codeword_normals));
  SSPC_RETURN_IF_ERROR(r.get(mode));
  SSPC_RETURN_IF_ERROR(r.get(k));
  SSPC_RETURN_IF_ERROR(r.get(has_view));
  SSPC_RETURN_IF_ERROR(r.get(view.x()));
  SSPC_RETURN_IF_ERROR(r.get(view.y()));
  SSPC_RETURN_IF_ERROR(r.get(view.z()));
  SSPC_RETURN_IF_ERROR(r.get_vec3s(job.part.positions));
  SSPC_RETURN_IF_ERROR(r.get_vec3s(job.part.normals));
  if (!r.at_end()) return corrupt("tile job: bytes after its end");
  if (mode > static_cast<std::uint8_t>(NormalMode::kEstimate) || has_view > 1 || codeword_normals > 1) {
    return corrupt("tile job: bad normal options");
  }
  if (core == 0 || core > job.part.size() ||
      (!job.part.normals.empty() && job.part.normals.size() != job.part.size())) {
    return corrupt("tile job: point counts do not agree");
  }
  b.level.patch_points = patch_points;
  b.seed = seed;
  b.core_points = core;
  b.codeword_normals = codeword_normals != 0;
  job.normals.mode = static_cast<NormalMode>(mode);
  job.normals.k = k;
  if (has_view != 0) job.normals.viewpoint = view;
  SSPC_RETURN_IF_ERROR(check_job(job));
  return job;
}

std::string serialise_tile_result(const TileResult& result) {
  Writer w;
  w.out.append(kResultMagic);
  w.put<std::uint64_t>(result.tile);
  w.put<std::uint32_t>(result.job_digest);
  const EncodedModel& m = result.model;
  w.put(m.patch_radius);
  w.put(m.coverage_radius);
  w.put(m.spacing);
  w.put<std::uint64_t>(m.codebook.size());
  for (const Codeword& c : m.codebook) {
    w.put_vec3s(c.points);
    w.put_vec3s(c.normals);
  }
  w.put<std::uint64_t>(m.patches.size());
  for (const PatchInstance& p : m.patches) {
    w.put(p.codeword);
    for (int i = 0; i < 9; ++i) w.put(p.world_from_codeword.rotation(i / 3, i % 3));
    for (int a = 0; a < 3; ++a) w.put(p.world_from_codeword.translation[a]);
    w.put<std::uint8_t>(p.representative ? 1 : 0);
  }
  // Counts only: timings would make the same job's result differ from run to run.
  const BuildStats& s = result.stats;
  w.put<std::uint64_t>(s.codebook.candidates_tested);
  w.put<std::uint64_t>(s.codebook.codeword_points);
  w.put(result.max_coverage_distance);
  return std::move(w).sealed();
}

StatusOr<TileResult> parse_tile_result(std::string_view bytes) {
  SSPC_ASSIGN_OR_RETURN(const std::string_view body, checked_body(bytes, "tile result"));
  Reader r(body);
  SSPC_RETURN_IF_ERROR(r.magic(kResultMagic));
  TileResult result;
  SSPC_RETURN_IF_ERROR(r.get(result.tile));
  SSPC_RETURN_IF_ERROR(r.get(result.job_digest));
  EncodedModel& m = result.model;
  SSPC_RETURN_IF_ERROR(r.get(m.patch_radius));
  SSPC_RETURN_IF_ERROR(r.get(m.coverage_radius));
  SSPC_RETURN_IF_ERROR(r.get(m.spacing));
  std::uint64_t codewords = 0;
  SSPC_RETURN_IF_ERROR(r.get(codewords));
  if (codewords > r.remaining() / 16) return corrupt("tile result: a count runs past its bytes");
  m.codebook.resize(codewords);
  for (Codeword& c : m.codebook) {
    SSPC_RETURN_IF_ERROR(r.get_vec3s(c.points));
    SSPC_RETURN_IF_ERROR(r.get_vec3s(c.normals));
    if (!c.normals.empty() && c.normals.size() != c.points.size()) {
      return corrupt("tile result: a code word's normals do not match");
    }
  }
  std::uint64_t patches = 0;
  SSPC_RETURN_IF_ERROR(r.get(patches));
  constexpr std::size_t kPatchBytes = 4 + 12 * 4 + 1;
  if (patches > r.remaining() / kPatchBytes) return corrupt("tile result: a count runs past its bytes");
  m.patches.resize(patches);
  for (PatchInstance& p : m.patches) {
    SSPC_RETURN_IF_ERROR(r.get(p.codeword));
    if (p.codeword >= codewords) return corrupt("tile result: a code-word index out of range");
    for (int i = 0; i < 9; ++i) SSPC_RETURN_IF_ERROR(r.get(p.world_from_codeword.rotation(i / 3, i % 3)));
    for (int a = 0; a < 3; ++a) SSPC_RETURN_IF_ERROR(r.get(p.world_from_codeword.translation[a]));
    std::uint8_t rep = 0;
    SSPC_RETURN_IF_ERROR(r.get(rep));
    if (rep > 1) return corrupt("tile result: a bad representative flag");
    p.representative = rep != 0;
  }
  BuildStats& s = result.stats;
  std::uint64_t tested = 0, points = 0;
  SSPC_RETURN_IF_ERROR(r.get(tested));
  SSPC_RETURN_IF_ERROR(r.get(points));
  SSPC_RETURN_IF_ERROR(r.get(result.max_coverage_distance));
  if (!r.at_end()) return corrupt("tile result: bytes after its end");
  s.codebook.candidates_tested = tested;
  s.codebook.codeword_points = points;
  m.has_normals = true;
  SSPC_RETURN_IF_ERROR(check_tile_result(result));
  return result;
}

}  // namespace sspc::codec
