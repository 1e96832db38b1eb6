// libFuzzer target: a distributed encode's messages as a hostile worker or scheduler would send
// them (encoder/tile_job.hpp, include/sspc/tiled_encoder.hpp).
//
// The first byte chooses the message, the rest are its bytes, tried as they are and again with
// their CRC32 trailer recomputed (so that mutations reach the fields behind the checksum):
// - even: a tile result given to TiledEncoder::add as tile 0 of a fixed plan (a small torus in
//   a few tiles). add() must refuse it with a message, or accept it; a result it accepts must be
//   tile 0's own (only the planner's job's result carries that job's digest) and the model it
//   finishes with the other tiles' true results must verify;
// - odd: a tile job given to run_tile_job (bounded to kMaxPoints points so that one input cannot
//   take seconds). It must fail with a message, or give a result that parses and names the job.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>
#include <unistd.h>

#include "encoder/tile_job.hpp"
#include "format/checksum.hpp"
#include "fuzz_util.hpp"
#include "sspc/compressed_model.hpp"
#include "sspc/synthetic.hpp"
#include "sspc/tiled_encoder.hpp"

namespace {

constexpr std::size_t kMaxPoints = 3000;

std::string resealed(std::string s) {
  if (s.size() < 4) return s;
  const std::uint32_t crc =
      sspc::codec::crc32_of(std::as_bytes(std::span<const char>(s.data(), s.size() - 4)));
  for (std::size_t i = 0; i < 4; ++i) s[s.size() - 4 + i] = static_cast<char>((crc >> (8 * i)) & 0xFF);
  return s;
}

class Planner {
 public:
  Planner() {
    char pattern[] = "/tmp/sspc-fuzz-tiles-XXXXXX";
    if (mkdtemp(pattern) == nullptr) std::abort();
    dir_ = pattern;
    reset();
    for (std::size_t t = 1; t < tiled_->tile_count(); ++t) rest_.push_back(*sspc::run_tile_job(*tiled_->job(t)));
  }
  ~Planner() {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  Planner(const Planner&) = delete;
  Planner& operator=(const Planner&) = delete;

  void try_result(const std::string& bytes) {
    const sspc::Status added = tiled_->add(0, bytes);
    if (!added.ok()) {
      SSPC_FUZZ_CHECK(!added.message().empty());
      return;
    }
    auto parsed = sspc::codec::parse_tile_result(bytes);
    SSPC_FUZZ_CHECK(parsed.ok() && parsed->tile == 0);
    for (std::size_t t = 1; t < tiled_->tile_count(); ++t) SSPC_FUZZ_CHECK(tiled_->add(t, rest_[t - 1]).ok());
    SSPC_FUZZ_CHECK(tiled_->finish().ok());
    auto model = sspc::CompressedModel::open(dir_ / "m.sspc");
    SSPC_FUZZ_CHECK(model.ok() && model->verify().ok());
    reset();  // a writer that accepted tile 0 waits for it no longer
  }

 private:
  void reset() {
    sspc::EncodeOptions options;
    options.level = 6;
    options.tile_points = 250;
    options.patch_points = 48;
    tiled_.reset();
    auto planned = sspc::TiledEncoder::plan(sspc::synthetic::torus(600, 1.0, 0.3), options);
    if (!planned.ok() || planned->tile_count() < 2) std::abort();
    tiled_.emplace(std::move(*planned));
    if (!tiled_->begin(dir_ / "m.sspc").ok()) std::abort();
  }

  std::filesystem::path dir_;
  std::optional<sspc::TiledEncoder> tiled_;
  std::vector<std::string> rest_;  // the true results of tiles 1 and on
};

void try_job(const std::string& bytes) {
  auto job = sspc::codec::parse_tile_job(bytes);
  if (!job.ok()) {
    SSPC_FUZZ_CHECK(!job.status().message().empty());
    return;
  }
  if (job->part.size() > kMaxPoints) return;
  auto result = sspc::run_tile_job(bytes);
  if (!result.ok()) {
    SSPC_FUZZ_CHECK(!result.status().message().empty());
    return;
  }
  auto parsed = sspc::codec::parse_tile_result(*result);
  SSPC_FUZZ_CHECK(parsed.ok());
  SSPC_FUZZ_CHECK(parsed->tile == job->tile && parsed->job_digest == sspc::codec::tile_job_digest(bytes));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  static Planner planner;
  const std::string bytes(reinterpret_cast<const char*>(data) + 1, size - 1);
  for (const std::string& message : {bytes, resealed(bytes)}) {
    if (data[0] % 2 == 0) {
      planner.try_result(message);
    } else {
      try_job(message);
    }
  }
  return 0;
}
