// libFuzzer target: the .sspc container and patch decoder on arbitrary bytes.
//
// Each input is tried twice: as it is, which exercises the header and seek-table checks, and
// with every CRC recomputed (crc_repair.hpp), which lets mutations through to zstd, the block
// decoders and the region decoder as a hostile file with valid checksums would. An open model
// is then decoded every way the API allows, and the ways must agree:
// - verify() passing means decode_all() succeeds and yields a valid cloud;
// - the patches decoded one at a time, in file order and again in a scrambled order on a
//   fresh model (a cold cache), concatenate to decode_all();
// - decode_box() of a box gives exactly decode_all()'s points inside it;
// - a resampled decode holds m² points a stored point, for the header's m and another.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <numeric>
#include <string>
#include <vector>

#include "crc_repair.hpp"
#include "fuzz_util.hpp"
#include "sspc/compressed_model.hpp"

namespace {

using sspc::CompressedModel;
using sspc::PointCloud;

// Patches and code words beyond these are not visited one by one (decode_all still covers
// them), so that one input cannot take seconds.
constexpr std::size_t kMaxVisited = 256;

bool same_cloud(const PointCloud& a, const PointCloud& b) {
  return a.positions == b.positions && a.normals == b.normals && a.colours == b.colours &&
         a.las.intensity == b.las.intensity && a.las.classification == b.las.classification &&
         a.las.return_number == b.las.return_number &&
         a.las.number_of_returns == b.las.number_of_returns;
}

void check_model(const std::string& bytes) {
  auto opened = CompressedModel::from_bytes(bytes);
  if (!opened.ok()) {
    SSPC_FUZZ_CHECK(!opened.status().message().empty());
    return;
  }
  const CompressedModel& model = *opened;
  const sspc::ModelInfo info = model.info();
  SSPC_FUZZ_CHECK(info.file_bytes == bytes.size());

  const sspc::Status verified = model.verify();
  auto all = model.decode_all();
  if (verified.ok()) SSPC_FUZZ_CHECK(all.ok());
  if (!all.ok()) {
    SSPC_FUZZ_CHECK(!all.status().message().empty());
    return;
  }
  SSPC_FUZZ_CHECK(all->validate().ok());
  // Resampling (FORMAT.md, "Resampling"): m × m points a stored point, for the header's m and
  // for another a decoder asks for.
  sspc::DecodeOptions stored_options, other_options;
  stored_options.resample = 0;
  other_options.resample = info.resample == 0 ? 2 : 0;
  auto stored = model.decode_all(stored_options);
  SSPC_FUZZ_CHECK(stored.ok() && stored->validate().ok());
  const auto m2 = static_cast<std::size_t>(info.resample * info.resample);
  SSPC_FUZZ_CHECK(all->size() == (info.resample == 0 ? stored->size() : m2 * stored->size()));
  auto other = model.decode_all(other_options);
  SSPC_FUZZ_CHECK(other.ok() && other->validate().ok());
  SSPC_FUZZ_CHECK(other->size() == (info.resample == 0 ? 4 * stored->size() : stored->size()));
  sspc::DecodeOptions overlap;
  overlap.overlap = true;
  auto whole = model.decode_all(overlap);
  SSPC_FUZZ_CHECK(whole.ok());
  SSPC_FUZZ_CHECK(whole->validate().ok());

  const std::size_t patches = model.patch_count();
  if (patches <= kMaxVisited) {
    PointCloud joined;
    for (std::size_t k = 0; k < patches; ++k) {
      auto record = model.patch(k);
      SSPC_FUZZ_CHECK(record.ok());
      SSPC_FUZZ_CHECK(record->codeword < model.codeword_count());
      auto part = model.decode_patch(k);
      SSPC_FUZZ_CHECK(part.ok());
      joined.append(*part);
    }
    SSPC_FUZZ_CHECK(same_cloud(joined, *all));

    // Random access on a cold cache, in an order the input chooses.
    auto fresh = CompressedModel::from_bytes(bytes);
    SSPC_FUZZ_CHECK(fresh.ok());
    std::vector<std::size_t> order(patches);
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::uint32_t state = static_cast<std::uint32_t>(bytes.size()) * 2654435761u;
    for (std::size_t i = order.size(); i > 1; --i) {
      state = state * 1664525u + 1013904223u;
      std::swap(order[i - 1], order[(state >> 8) % i]);
    }
    for (std::size_t k : order) {
      auto a = fresh->decode_patch(k);
      auto b = model.decode_patch(k);
      SSPC_FUZZ_CHECK(a.ok() && b.ok());
      SSPC_FUZZ_CHECK(same_cloud(*a, *b));
    }
  }
  for (std::size_t c = 0; c < std::min(model.codeword_count(), kMaxVisited); ++c) {
    auto word = model.codeword(c);
    SSPC_FUZZ_CHECK(word.ok());
    SSPC_FUZZ_CHECK(word->points.validate().ok());
  }
  SSPC_FUZZ_CHECK(!model.patch(patches).ok());
  SSPC_FUZZ_CHECK(!model.decode_patch(patches).ok());
  SSPC_FUZZ_CHECK(!model.codeword(model.codeword_count()).ok());

  // The lower half of the bounds, as a box the decode must clip to exactly.
  const sspc::Vec3f lo = info.bounds.min();
  const sspc::Vec3f hi = lo + (info.bounds.max() - lo) / 2;
  const sspc::Box3f box(lo, hi);
  if (box.min().allFinite() && box.max().allFinite()) {
    auto clipped = model.decode_box(box);
    SSPC_FUZZ_CHECK(clipped.ok());
    PointCloud expected;
    for (std::size_t i = 0; i < all->size(); ++i) {
      if (!box.contains(all->positions[i])) continue;
      expected.positions.push_back(all->positions[i]);
      if (!all->normals.empty()) expected.normals.push_back(all->normals[i]);
      if (!all->colours.empty()) expected.colours.push_back(all->colours[i]);
      const sspc::LasPointAttributes& a = all->las;
      if (!a.intensity.empty()) expected.las.intensity.push_back(a.intensity[i]);
      if (!a.classification.empty()) expected.las.classification.push_back(a.classification[i]);
      if (!a.return_number.empty()) expected.las.return_number.push_back(a.return_number[i]);
      if (!a.number_of_returns.empty()) {
        expected.las.number_of_returns.push_back(a.number_of_returns[i]);
      }
    }
    SSPC_FUZZ_CHECK(same_cloud(*clipped, expected));
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  check_model(bytes);
  const std::string repaired = sspc::fuzz::repair_crcs(bytes);
  if (repaired != bytes) check_model(repaired);
  return 0;
}
