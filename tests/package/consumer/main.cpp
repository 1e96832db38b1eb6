// A downstream program: generates a sphere, writes and reads it back through the installed API,
// encodes it, decodes one patch of the file and renders the file to a PNG.
#include <sspc/compressed_model.hpp>
#include <sspc/encoder.hpp>
#include <sspc/io.hpp>
#include <sspc/render.hpp>
#include <sspc/synthetic.hpp>

#include <cstdio>

namespace {

int fail(const sspc::Status& status) {
  std::fprintf(stderr, "%s\n", status.to_string().c_str());
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: consumer OUT.sspc OUT.png\n");
    return 2;
  }
  const sspc::PointCloud sphere = sspc::synthetic::sphere(1000, 1.0);
  const std::string bytes = sspc::encode_ply(sphere);
  auto back = sspc::read_ply(std::as_bytes(std::span(bytes.data(), bytes.size())), "memory");
  if (!back.ok()) return fail(back.status());
  std::printf("points=%zu\n", back->size());
  if (back->size() != 1000) return 1;

  if (auto stats = sspc::encode(*back, argv[1]); !stats.ok()) return fail(stats.status());
  auto model = sspc::CompressedModel::open(argv[1]);
  if (!model.ok()) return fail(model.status());
  auto patch = model->decode_patch(0);
  if (!patch.ok()) return fail(patch.status());
  std::printf("patches=%zu patch0=%zu\n", model->patch_count(), patch->size());

  sspc::FrameOptions options;
  options.width = 64;
  options.height = 64;
  options.camera = sspc::frame_bounds(model->info().bounds);
  sspc::RenderStats stats;
  auto image = sspc::render_compressed(*model, options, {}, &stats);
  if (!image.ok()) return fail(image.status());
  if (auto written = sspc::write_png(*image, argv[2]); !written.ok()) return fail(written);
  std::printf("hits=%llu\n", static_cast<unsigned long long>(stats.hits));
  return patch->size() > 0 && stats.hits > 0 ? 0 : 1;
}
