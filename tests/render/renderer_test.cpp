// The renderers against an analytic sphere: the uncompressed one's silhouette within a pixel,
// depth within 1% of the radius, every pixel inside the silhouette hit, the same image on any
// thread count; the compressed model rendered directly agrees with it.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <algorithm>
#include <numbers>
#include <vector>

#include "render/camera.hpp"
#include "sspc/render.hpp"
#include "sspc/encoder.hpp"
#include "sspc/synthetic.hpp"
#include "test_util.hpp"

namespace sspc {
namespace {

struct SphereScene {
  PointCloud cloud = synthetic::sphere(40000, 1.0);
  RenderOptions options;
  SphereScene() {
    options.width = 96;
    options.height = 96;
    options.camera.eye = Vec3f(0.3f, -0.2f, 4.0f);
    options.camera.target = Vec3f::Zero();
    options.camera.up = Vec3f::UnitY();
    options.camera.fov_degrees = 40;
  }
};

// The ray's first intersection with the unit sphere at the origin, or +inf.
float analytic_t(const Vec3f& o, const Vec3f& d) {
  const float b = o.dot(d);
  const float c = o.squaredNorm() - 1.0f;
  const float disc = b * b - c;
  return disc < 0 ? std::numeric_limits<float>::infinity() : -b - std::sqrt(disc);
}

TEST(Renderer, SphereSilhouetteAndDepthMatchTheAnalyticSphere) {
  SphereScene scene;
  auto image = render_point_cloud(scene.cloud, scene.options);
  ASSERT_TRUE(image.ok()) << image.status().to_string();
  const render::PinholeCamera camera(scene.options.camera, scene.options.width, scene.options.height);
  int inside = 0, wrong = 0;
  float worst_depth = 0;
  for (int y = 0; y < image->height; ++y) {
    for (int x = 0; x < image->width; ++x) {
      const Vec3f d = camera.direction(x, y);
      const float truth = analytic_t(camera.eye(), d);
      const float got = image->depth[static_cast<std::size_t>(y * image->width + x)];
      // A pixel counts as inside (outside) when its ray passes the sphere by more than a pixel's
      // footprint: the distance from the centre to the ray, against radius ± one pixel.
      const float miss = (camera.eye() - camera.eye().dot(d) * d).norm();
      const float pixel = 4.0f * 2.0f * std::tan(20.0f * std::numbers::pi_v<float> / 180) / 96.0f;
      if (miss < 1.0f - pixel) {
        ++inside;
        if (!std::isfinite(got)) {
          ++wrong;
        } else {
          worst_depth = std::max(worst_depth, std::abs(got - truth));
        }
      } else if (miss > 1.0f + pixel && std::isfinite(got)) {
        ++wrong;
      }
    }
  }
  EXPECT_GT(inside, 1500);
  EXPECT_EQ(wrong, 0);
  EXPECT_LT(worst_depth, 0.01f);
}

TEST(Renderer, SameImageOnAnyThreadCount) {
  SphereScene scene;
  scene.options.shade = Shade::kNormal;
  StatusOr<Image> one = invalid_argument("unset"), two = invalid_argument("unset");
  {
    tbb::global_control single(tbb::global_control::max_allowed_parallelism, 1);
    one = render_point_cloud(scene.cloud, scene.options);
  }
  two = render_point_cloud(scene.cloud, scene.options);
  ASSERT_TRUE(one.ok() && two.ok());
  EXPECT_EQ(one->rgb, two->rgb);
}

TEST(Renderer, BadOptionsAreRefused) {
  SphereScene scene;
  RenderOptions o = scene.options;
  o.width = 0;
  EXPECT_FALSE(render_point_cloud(scene.cloud, o).ok());
  o = scene.options;
  o.camera.target = o.camera.eye;
  EXPECT_FALSE(render_point_cloud(scene.cloud, o).ok());
  PointCloud no_normals = scene.cloud;
  no_normals.normals.clear();
  EXPECT_FALSE(render_point_cloud(no_normals, scene.options).ok());
}

// The compressed model of the sphere, rendered directly, agrees with the uncompressed render:
// the same pixels hit (up to a few on the silhouette) and the same depth to 2% of the radius.
TEST(Renderer, CompressedSphereAgreesWithTheUncompressedOne) {
  SphereScene scene;
  test::TempDir dir;
  const auto path = dir.path() / "sphere.sspc";
  EncodeOptions encode_options;
  encode_options.level = 3;
  ASSERT_TRUE(encode(scene.cloud, path, encode_options).ok());
  auto model = CompressedModel::open(path);
  ASSERT_TRUE(model.ok());
  auto plain = render_point_cloud(scene.cloud, scene.options);
  RenderStats stats;
  scene.options.shade = Shade::kCodeword;
  auto compressed = render_compressed(*model, scene.options, &stats);
  ASSERT_TRUE(plain.ok() && compressed.ok()) << compressed.status().to_string();
  int disagree = 0, both = 0;
  std::vector<float> errors;
  for (std::size_t i = 0; i < plain->depth.size(); ++i) {
    const bool a = std::isfinite(plain->depth[i]), b = std::isfinite(compressed->depth[i]);
    if (a != b) ++disagree;
    if (a && b) {
      ++both;
      errors.push_back(std::abs(plain->depth[i] - compressed->depth[i]));
    }
  }
  ASSERT_GT(both, 1500);
  EXPECT_LT(disagree, both / 50);
  std::sort(errors.begin(), errors.end());
  EXPECT_LT(errors[errors.size() / 2], 0.005f);
  EXPECT_LT(errors[errors.size() * 95 / 100], 0.02f);
  EXPECT_GT(stats.hits, 1500u);
}

}  // namespace
}  // namespace sspc
