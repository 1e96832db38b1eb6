// Tile jobs and results as bytes (encoder/tile_job.hpp).
#include "encoder/tile_job.hpp"

#include <bit>
#include <cstring>

#include "core/byte_reader.hpp"

namespace sspc::codec {
namespace {

constexpr std::string_view kJobMagic{"SSPCTJ02", 8};
constexpr std::string_view kResultMagic{"SSPCTR02", 8};

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
  return std::move(w.out);
}

StatusOr<TileJob> parse_tile_job(std::string_view bytes) {
  Reader r(bytes);
  SSPC_RETURN_IF_ERROR(r.magic(kJobMagic));
  TileJob job;
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
  return job;
}

std::string serialise_tile_result(const TileResult& result) {
  Writer w;
  w.out.append(kResultMagic);
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
  return std::move(w.out);
}

StatusOr<TileResult> parse_tile_result(std::string_view bytes) {
  Reader r(bytes);
  SSPC_RETURN_IF_ERROR(r.magic(kResultMagic));
  TileResult result;
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
  return result;
}

}  // namespace sspc::codec
