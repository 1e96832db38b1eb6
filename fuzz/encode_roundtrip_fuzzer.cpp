// libFuzzer target: the encoder on small fuzzer-made clouds, then the decoder on its output.
//
// Input: one options byte, then 3 bytes per point (a 256³ grid with a spacing of 0.01, at most
// kMaxPoints points). What must hold:
// - encode() succeeds, except with kInvalidArgument for the inputs it documents (fewer than 16
//   points, all points at one place);
// - what it wrote opens, verifies and decodes to a valid, non-empty cloud;
// - encoding the same cloud again gives the same bytes (the encoder is deterministic);
// - the model renders directly, and its decoded cloud renders, or fails with a message (whatever
//   the encoder writes, the renderer accepts: its checks of a model's spacing must not refuse it).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "fuzz_util.hpp"
#include "sspc/compressed_model.hpp"
#include "sspc/encoder.hpp"
#include "sspc/normals.hpp"
#include "sspc/render.hpp"

namespace {

constexpr std::size_t kMaxPoints = 2000;

// A private directory for the encoder's output, removed when the process exits.
class ScratchDir {
 public:
  ScratchDir() {
    std::string pattern =
        (std::filesystem::temp_directory_path() / "sspc-fuzz-XXXXXX").string();
    if (mkdtemp(pattern.data()) == nullptr) std::abort();
    path_ = pattern;
  }
  ~ScratchDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  static const ScratchDir scratch;
  const std::uint8_t flags = data[0];
  sspc::PointCloud cloud;
  for (std::size_t i = 1; i + 3 <= size && cloud.size() < kMaxPoints; i += 3) {
    cloud.positions.emplace_back(0.01f * static_cast<float>(data[i]),
                                 0.01f * static_cast<float>(data[i + 1]),
                                 0.01f * static_cast<float>(data[i + 2]));
  }
  if ((flags & 0x10) != 0) {
    cloud.colours.resize(cloud.size());
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      const auto v = static_cast<std::uint8_t>(i * 37);
      cloud.colours[i] = sspc::Rgb8{v, static_cast<std::uint8_t>(255 - v), flags};
    }
  }
  sspc::EncodeOptions options;
  options.level = 7 + flags % 3;  // the fast end of the level table
  options.store_normals = (flags & 0x04) != 0;
  options.full_spheres = (flags & 0x08) != 0;
  if ((flags & 0x20) != 0) options.patch_points = 16;

  const std::filesystem::path first = scratch.path() / "first.sspc";
  const std::filesystem::path second = scratch.path() / "second.sspc";
  auto stats = sspc::encode(cloud, first, options);
  if (!stats.ok()) {
    SSPC_FUZZ_CHECK(stats.status().code() == sspc::StatusCode::kInvalidArgument);
    SSPC_FUZZ_CHECK(!std::filesystem::exists(first));
    return 0;
  }
  auto model = sspc::CompressedModel::open(first);
  SSPC_FUZZ_CHECK(model.ok());
  SSPC_FUZZ_CHECK(model->verify().ok());
  auto decoded = model->decode_all();
  SSPC_FUZZ_CHECK(decoded.ok());
  SSPC_FUZZ_CHECK(!decoded->empty());
  SSPC_FUZZ_CHECK(decoded->validate().ok());
  SSPC_FUZZ_CHECK(decoded->has_normals() == options.store_normals);
  SSPC_FUZZ_CHECK(model->info().source_points == cloud.size());

  sspc::FrameOptions render;
  render.width = 8;
  render.height = 8;
  render.camera = sspc::frame_bounds(model->info().bounds, 40);
  const auto direct = sspc::render_compressed(*model, render);
  SSPC_FUZZ_CHECK(direct.ok());
  SSPC_FUZZ_CHECK(direct->rgb.size() == 3u * 8u * 8u);
  sspc::PointCloud surface = std::move(decoded).value();
  if (sspc::ensure_normals(surface, sspc::NormalOptions{}).ok()) {
    const auto plain = sspc::render_point_cloud(surface, render);
    if (!plain.ok()) SSPC_FUZZ_CHECK(!plain.status().message().empty());
  }

  auto again = sspc::encode(cloud, second, options);
  SSPC_FUZZ_CHECK(again.ok());
  const std::string a = slurp(first), b = slurp(second);
  SSPC_FUZZ_CHECK(a.size() == stats->file_bytes);
  SSPC_FUZZ_CHECK(a == b);
  std::filesystem::remove(first);
  std::filesystem::remove(second);
  return 0;
}
