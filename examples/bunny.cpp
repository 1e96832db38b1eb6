// The README's C++ example (keep the two in step): encode the bunny, open the model for random
// access, decode one box of it and render it directly to a PNG. Built as `sspc_example`; the test
// `example.bunny` runs it in the build tree, where `data/` links to the repository's.
#include <sspc/compressed_model.hpp>
#include <sspc/encoder.hpp>
#include <sspc/io.hpp>
#include <sspc/render.hpp>

int main() {
  auto cloud = sspc::read_point_cloud("data/bunny.ply");       // StatusOr<PointCloud>
  if (!cloud.ok()) return 1;
  auto stats = sspc::encode(*cloud, "bunny.sspc", {.level = 5});  // EncodeStats: bits_per_point, ...
  auto model = sspc::CompressedModel::open("bunny.sspc");       // random access from here on
  auto part = model->decode_box(sspc::Box3f(sspc::Vec3f(-0.05f, 0.05f, -0.05f), sspc::Vec3f(0, 0.12f, 0.05f)));
  sspc::FrameOptions view{.width = 512, .height = 512, .camera = sspc::frame_bounds(model->info().bounds)};
  auto image = sspc::render_compressed(*model, view);          // decodes only the bricks rays reach
  return stats.ok() && part.ok() && image.ok() && sspc::write_png(*image, "bunny.png").ok() ? 0 : 1;
}
