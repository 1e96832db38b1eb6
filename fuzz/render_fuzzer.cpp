// libFuzzer target: the renderers on whatever the decoder or a reader accepts.
//
// An input that starts with the .sspc magic is opened as a compressed model (as it is, and with
// every CRC recomputed, crc_repair.hpp, so that hostile values with valid checksums reach the
// renderer: a header spacing of 0 once made the march stand still) and rendered directly, one in
// three also with level of detail. Any
// other input goes to the reader its first bytes name (PLY, PCD, else XYZ text), gets normals
// when it has none, and is rendered in memory and, for one input in four, paged through a file.
// What must hold: a render finishes (libFuzzer's -timeout reports one that does not), and either
// fails with a message or returns an image of the size asked for, whose hit pixels have finite
// depths.
#include <unistd.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <string_view>

#include "crc_repair.hpp"
#include "fuzz_util.hpp"
#include "sspc/compressed_model.hpp"
#include "sspc/io.hpp"
#include "sspc/normals.hpp"
#include "sspc/render.hpp"

namespace {

constexpr int kSide = 12;  // pixels: enough rays to cross every part of a small scene

sspc::FrameOptions options_for(const sspc::Box3f& bounds) {
  sspc::FrameOptions o;
  o.width = kSide;
  o.height = kSide;
  o.camera = sspc::frame_bounds(bounds, 40);
  return o;
}

void check_image(const sspc::StatusOr<sspc::Image>& image) {
  if (!image.ok()) {
    SSPC_FUZZ_CHECK(!image.status().message().empty());
    return;
  }
  SSPC_FUZZ_CHECK(image->width == kSide && image->height == kSide);
  SSPC_FUZZ_CHECK(image->rgb.size() == static_cast<std::size_t>(3 * kSide * kSide));
  SSPC_FUZZ_CHECK(image->depth.size() == static_cast<std::size_t>(kSide * kSide));
  for (const float d : image->depth) SSPC_FUZZ_CHECK(std::isinf(d) || (std::isfinite(d) && d >= 0));
}

void render_model(const std::string& bytes) {
  auto model = sspc::CompressedModel::from_bytes(bytes);
  if (!model.ok()) return;  // the decoder's own target covers what it refuses
  // Half the inputs with a budget of a few bricks, so that eviction runs too.
  sspc::SceneOptions options;
  options.memory_budget_bytes = bytes.size() % 2 == 0 ? sspc::kDefaultMemoryBudget : 64 << 10;
  auto scene = sspc::RenderScene::from_compressed(std::make_shared<const sspc::CompressedModel>(std::move(*model)), options);
  if (!scene.ok()) {
    SSPC_FUZZ_CHECK(!scene.status().message().empty());
    return;
  }
  sspc::FrameOptions frame = options_for((*scene)->bounds());
  check_image((*scene)->render(frame));
  // And through the coarser levels of detail, for one input in three: a 12-pixel image puts
  // most scenes' points far below a pixel.
  if (bytes.size() % 3 == 0) {
    frame.level_of_detail = 1;
    check_image((*scene)->render(frame));
  }
}

// A private folder for the paged scene's page file, removed when the process exits.
const std::filesystem::path& scratch() {
  struct Dir {
    std::filesystem::path path;
    Dir() {
      std::string pattern = (std::filesystem::temp_directory_path() / "sspc-fuzz-render-XXXXXX").string();
      if (mkdtemp(pattern.data()) == nullptr) std::abort();
      path = pattern;
    }
    ~Dir() {
      std::error_code ec;
      std::filesystem::remove_all(path, ec);
    }
  };
  static const Dir dir;
  return dir.path;
}

void render_cloud(std::string_view text, std::size_t seed) {
  const auto bytes = std::as_bytes(std::span<const char>(text.data(), text.size()));
  sspc::StatusOr<sspc::PointCloud> cloud = sspc::invalid_argument("unread");
  if (text.starts_with("ply")) {
    cloud = sspc::read_ply(bytes, "fuzz.ply");
  } else if (text.starts_with("# .PCD") || text.starts_with("VERSION")) {
    cloud = sspc::read_pcd(bytes, "fuzz.pcd");
  } else {
    cloud = sspc::read_xyz(bytes, "fuzz.xyz");
  }
  if (!cloud.ok()) return;  // the readers' own targets cover what they refuse
  if (cloud->size() > 4000) return;  // normals and a scene of more would make one input slow
  const sspc::Status normals = sspc::ensure_normals(*cloud, sspc::NormalOptions{});
  if (!normals.ok()) {
    SSPC_FUZZ_CHECK(!normals.message().empty());
    return;
  }
  const bool paged = seed % 4 == 3;
  auto scene = paged ? sspc::RenderScene::from_point_cloud_paged(*cloud, scratch(), {.memory_budget_bytes = 1 << 16})
                     : sspc::RenderScene::from_point_cloud(*cloud);
  if (!scene.ok()) {
    SSPC_FUZZ_CHECK(!scene.status().message().empty());
    return;
  }
  check_image((*scene)->render(options_for((*scene)->bounds())));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  if (size >= 4 && data[0] == 0x8A && std::memcmp(data + 1, "SPC", 3) == 0) {  // the .sspc magic
    render_model(bytes);
    const std::string repaired = sspc::fuzz::repair_crcs(bytes);
    if (repaired != bytes) render_model(repaired);
    return 0;
  }
  render_cloud(bytes, size);
  return 0;
}
