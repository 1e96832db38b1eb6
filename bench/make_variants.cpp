// make_variants IN OUT_DIR [NOISE_FRACTION]: the degraded copies that calibrate `sspc eval`.
//
// Writes OUT_DIR/noisy.ply (every point moved by isotropic Gaussian noise of NOISE_FRACTION ×
// nominal spacing per axis, default 0.01) and OUT_DIR/half.ply (a deterministic random half of
// the points). Used by scripts/eval_calibration.sh; not part of the installed tool.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "sspc/io.hpp"
#include "sspc/neighbours.hpp"
#include "sspc/synthetic.hpp"

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: make_variants IN OUT_DIR [NOISE_FRACTION]\n");
    return 2;
  }
  const std::filesystem::path out_dir = argv[2];
  const double fraction = argc > 3 ? std::atof(argv[3]) : 0.01;
  auto cloud = sspc::read_point_cloud(argv[1]);
  if (!cloud.ok()) {
    std::fprintf(stderr, "%s\n", cloud.status().to_string().c_str());
    return 1;
  }
  const double spacing = sspc::nominal_spacing(*cloud);
  const double sigma = fraction * spacing;

  sspc::PointCloud noisy = *cloud;
  sspc::synthetic::Rng rng(12345);
  for (sspc::Vec3f& p : noisy.positions) {
    for (int a = 0; a < 3; ++a) p[a] += static_cast<float>(sigma * rng.gaussian());
  }
  sspc::PointCloud half;
  sspc::synthetic::Rng pick(777);
  for (std::size_t i = 0; i < cloud->size(); ++i) {
    if (pick.uniform() < 0.5) continue;
    half.positions.push_back(cloud->positions[i]);
    if (cloud->has_normals()) half.normals.push_back(cloud->normals[i]);
    if (cloud->has_colours()) half.colours.push_back(cloud->colours[i]);
  }
  for (const auto& [name, c] : {std::pair{"noisy.ply", &noisy}, std::pair{"half.ply", &half}}) {
    const sspc::Status s = sspc::write_ply(*c, out_dir / name);
    if (!s.ok()) {
      std::fprintf(stderr, "%s\n", s.to_string().c_str());
      return 1;
    }
  }
  std::printf("spacing %.9g, noise sigma %.9g per axis, half keeps %zu of %zu points\n", spacing,
              sigma, half.size(), cloud->size());
  return 0;
}
