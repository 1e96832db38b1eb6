// The renderers against an analytic sphere: the uncompressed one's silhouette within a pixel,
// depth within 1% of the radius, every pixel inside the silhouette hit, the same image on any
// thread count; the compressed model rendered directly agrees with it.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <zlib.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <algorithm>
#include <numbers>
#include <random>
#include <vector>

#include "render/compressed_scene.hpp"
#include "render/camera.hpp"
#include "render/mls_surface.hpp"
#include "render/shading.hpp"
#include "sspc/render.hpp"
#include "sspc/encoder.hpp"
#include "sspc/io.hpp"
#include "sspc/neighbours.hpp"
#include "sspc/normals.hpp"
#include "sspc/synthetic.hpp"
#include "test_util.hpp"

namespace sspc {
namespace {

std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

struct SphereScene {
  PointCloud cloud = synthetic::sphere(40000, 1.0);
  FrameOptions options;
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

// Two renders' depths, pixel by pixel: how many pixels one hit and the other missed, and the
// depth differences where both hit, sorted.
struct DepthComparison {
  int disagree = 0;
  int both = 0;
  std::vector<float> errors;
};

DepthComparison compare_depths(const Image& a, const Image& b) {
  DepthComparison c;
  for (std::size_t i = 0; i < a.depth.size(); ++i) {
    const bool x = std::isfinite(a.depth[i]), y = std::isfinite(b.depth[i]);
    if (x != y) ++c.disagree;
    if (x && y) {
      ++c.both;
      c.errors.push_back(std::abs(a.depth[i] - b.depth[i]));
    }
  }
  std::sort(c.errors.begin(), c.errors.end());
  return c;
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
  FrameOptions o = scene.options;
  o.width = 0;
  EXPECT_FALSE(render_point_cloud(scene.cloud, o).ok());
  o = scene.options;
  o.camera.target = o.camera.eye;
  EXPECT_FALSE(render_point_cloud(scene.cloud, o).ok());
  PointCloud no_normals = scene.cloud;
  no_normals.normals.clear();
  EXPECT_FALSE(render_point_cloud(no_normals, scene.options).ok());
  // A scene's options are checked by every factory.
  for (const SceneOptions bad : {SceneOptions{.bandwidth = 0}, SceneOptions{.memory_budget_bytes = 0}}) {
    EXPECT_FALSE(RenderScene::from_point_cloud(scene.cloud, bad).ok());
    EXPECT_FALSE(render_point_cloud(scene.cloud, scene.options, bad).ok());
  }
}

// A bandwidth far below float32's resolution at the ray's distance (a hostile header, a cloud of
// doubled points before the spacing ignored duplicates) cannot stall the march: each step moves
// t by a few units in the last place at least, and a ray stops after a bounded number of samples.
TEST(MlsSurface, AVanishingBandwidthStillEnds) {
  std::vector<Vec3f> points, normals;
  for (int y = 0; y < 40; ++y) {
    for (int x = 0; x < 40; ++x) {
      points.emplace_back(0.01f * static_cast<float>(x), 0.01f * static_cast<float>(y), 0.0f);
      normals.emplace_back(0.0f, 0.0f, 1.0f);
    }
  }
  for (const float h : {1e-9f, 1e-30f}) {
    const render::MlsSurface surface(points, normals, h);
    for (int r = 0; r < 4; ++r) {
      const Vec3f o(0.1f * static_cast<float>(r), 0.2f, 4.0f);
      const Vec3f d = (Vec3f(0.2f, 0.2f, 0.0f) - o).normalized();
      const auto hit = surface.intersect(o, d, 0.0f, 10.0f);  // returning at all is the test
      if (hit) {
        EXPECT_LE(hit->evaluations, (1 << 16) + 16);
      }
    }
  }
}

// A ray's MLS evaluations are counted whether it hits or not (RenderStats::evaluations is over
// all rays): one that runs along a plane within its support, never crossing it, evaluates f
// every half bandwidth and misses; one through the plane hits with its own count.
TEST(MlsSurface, EvaluationsAreCountedForMissesToo) {
  std::vector<Vec3f> points, normals;
  for (int y = 0; y < 40; ++y) {
    for (int x = 0; x < 40; ++x) {
      points.emplace_back(0.1f * static_cast<float>(x), 0.1f * static_cast<float>(y), 0.0f);
      normals.emplace_back(0.0f, 0.0f, 1.0f);
    }
  }
  const render::MlsSurface surface(points, normals, 0.15f);
  std::uint64_t evaluations = 0;
  EXPECT_FALSE(surface.intersect(Vec3f(-1, 1.95f, 0.05f), Vec3f(1, 0, 0), 0.0f, 10.0f, &evaluations));
  EXPECT_GE(evaluations, 40u);  // 3.9 units of plane in steps of at most h/2 = 0.075
  std::uint64_t hit_evaluations = 0;
  const auto hit = surface.intersect(Vec3f(1.95f, 1.95f, 1), Vec3f(0, 0, -1), 0.0f, 10.0f, &hit_evaluations);
  ASSERT_TRUE(hit);
  EXPECT_EQ(hit_evaluations, static_cast<std::uint64_t>(hit->evaluations));
}

// The surface does not depend on which way each normal points (the principal axis of the
// normals' tensor, not their mean): a sphere whose normals are flipped at random renders as the
// one whose normals all point out. With the mean normal, flips cancel and tear the surface.
TEST(MlsSurface, FlippedNormalsRenderTheSameSurface) {
  SphereScene scene;
  PointCloud flipped = scene.cloud;
  std::mt19937 rng(11);
  for (Vec3f& n : flipped.normals) {
    if (rng() & 1) n = -n;
  }
  auto outward = render_point_cloud(scene.cloud, scene.options);
  auto random = render_point_cloud(flipped, scene.options);
  ASSERT_TRUE(outward.ok() && random.ok());
  const auto c = compare_images(*outward, *random);
  ASSERT_TRUE(c.ok());
  EXPECT_GT(c->hit_both, 1500u);
  EXPECT_EQ(c->hit_first_only + c->hit_second_only, 0u);
  EXPECT_GE(c->psnr_hit, 50.0);
}

// The clearance is a lower bound on the distance to every point, and exact when the nearest point
// is within a cell: the march skips by clearance − r where the surface is undefined, which
// must never step over a point's support.
TEST(MlsSurface, ClearanceIsALowerBoundOnTheDistanceToEveryPoint) {
  std::vector<Vec3f> points, normals;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int i = 0; i < 200; ++i) {
    points.emplace_back(u(rng), u(rng), 0.1f * u(rng));
    normals.emplace_back(0.0f, 0.0f, 1.0f);
  }
  const render::MlsSurface surface(points, normals, 0.01f);
  for (int q = 0; q < 500; ++q) {
    const Vec3f x(1.5f * u(rng), 1.5f * u(rng), 0.5f * u(rng));
    float nearest = std::numeric_limits<float>::infinity();
    for (const Vec3f& p : points) nearest = std::min(nearest, (p - x).norm());
    const float bound = surface.clearance(x);
    EXPECT_LE(bound, nearest + 1e-6f) << q;
    EXPECT_GT(bound, 0.0f);
  }
}

// What the march skips as near no point (empty_until, which crosses empty cells, and blocks of
// 4³ and 16³ empty cells, in one step) holds no point within the support radius: checked along
// random rays against every point, on small clusters far apart in a grid of about 21³ cells.
TEST(MlsSurface, EmptySpaceSkipsNeverPassAPointsSupport) {
  std::vector<Vec3f> points, normals;
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int c = 0; c < 8; ++c) {
    const Vec3f centre(c & 1 ? 4.0f : -4.0f, c & 2 ? 4.0f : -4.0f, c & 4 ? 4.0f : -4.0f);
    for (int i = 0; i < 300; ++i) {
      points.push_back(centre + 0.2f * Vec3f(u(rng), u(rng), 0.1f * u(rng)));
      normals.emplace_back(0.0f, 0.0f, 1.0f);
    }
  }
  const render::MlsSurface surface(points, normals, 0.02f);
  const float r = surface.support_radius();
  // The distance from p to the segment o + t·d, t in [t0, t1].
  const auto distance = [](const Vec3f& p, const Vec3f& o, const Vec3f& d, float t0, float t1) {
    const float t = std::clamp((p - o).dot(d), t0, t1);
    return (o + t * d - p).norm();
  };
  int skips = 0;
  for (int ray = 0; ray < 300; ++ray) {
    const Vec3f o = 8.0f * Vec3f(u(rng), u(rng), u(rng));
    // Half the rays aim at a cluster, so that they pass near points after long empty stretches.
    const Vec3f aim = ray % 2 == 0 ? points[static_cast<std::size_t>(ray) * 7 % points.size()] : 8.0f * Vec3f(u(rng), u(rng), u(rng));
    const Vec3f d = (aim - o).normalized();
    float t = 0;
    const float t_max = 30;
    while (t < t_max) {
      const float until = surface.empty_until(o, d, t, t_max);
      if (until > t) {
        const float end = std::min(until, t_max);
        for (const Vec3f& p : points) ASSERT_GE(distance(p, o, d, t, end), r * (1 - 1e-4f)) << ray;
        ++skips;
        t = until;
      } else {
        t += 0.5f * r;
      }
    }
  }
  EXPECT_GT(skips, 300);
}

// A valid model whose header spacing is 0 or a denormal (the format allows ≥ 0) is refused with
// a message naming the spacing, rather than rendered in steps that never move.
TEST(Renderer, CompressedModelWithAVanishingSpacingIsRefused) {
  SphereScene scene;
  test::TempDir dir;
  const auto path = dir.path() / "sphere.sspc";
  EncodeOptions encode_options;
  encode_options.level = 9;
  ASSERT_TRUE(encode(synthetic::sphere(4000, 1.0), path, encode_options).ok());
  const std::string bytes = slurp(path);
  for (const float spacing : {0.0f, 1e-30f, 1.4e-45f}) {
    std::string hostile = bytes;
    std::memcpy(hostile.data() + 24, &spacing, 4);  // the header's spacing; its CRC32 at 192
    const auto crc = static_cast<std::uint32_t>(crc32(0, reinterpret_cast<const Bytef*>(hostile.data()), 192));
    std::memcpy(hostile.data() + 192, &crc, 4);
    auto model = CompressedModel::from_bytes(hostile);
    ASSERT_TRUE(model.ok()) << model.status().to_string();
    const auto image = render_compressed(*model, scene.options);
    ASSERT_FALSE(image.ok());
    EXPECT_NE(image.status().message().find("spacing"), std::string::npos) << image.status().to_string();
  }
}

// The compressed scene decodes a small model whole to measure its spacing, chosen by the header's
// count of source points; the decode stops once it holds more points than the budget allows,
// and below that bound gives decode_all's points.
TEST(BrickScene, DecodeWithinStopsPastItsBound) {
  test::TempDir dir;
  const auto path = dir.path() / "sphere.sspc";
  ASSERT_TRUE(encode(synthetic::sphere(4000, 1.0), path, EncodeOptions{}).ok());
  auto model = CompressedModel::open(path);
  ASSERT_TRUE(model.ok());
  const auto all = model->decode_all();
  ASSERT_TRUE(all.ok());
  ASSERT_GE(model->patch_count(), 2u);  // so that the bound stops a decode part way
  const auto whole = render::decode_within(*model, all->size());
  ASSERT_TRUE(whole.ok() && whole->has_value());
  EXPECT_EQ((*whole)->positions, all->positions);
  const auto short_of = render::decode_within(*model, all->size() - 1);
  ASSERT_TRUE(short_of.ok());
  EXPECT_FALSE(short_of->has_value());
}

// A model too large to decode whole is measured for its spacing without holding its decode, and
// to the bit as a render of the decode measures it (nominal_spacing of decode_all()), whatever
// the thread count: the two renders then take the same bandwidth. A margin too small for a
// sampled point's nearest gives up rather than guess.
TEST(BrickScene, ExactSpacingIsTheDecodesNominalSpacing) {
  test::TempDir dir;
  const auto path = dir.path() / "sphere.sspc";
  EncodeOptions encode_options;
  encode_options.patch_points = 256;
  ASSERT_TRUE(encode(synthetic::sphere(30000, 1.0), path, encode_options).ok());
  auto model = CompressedModel::open(path);
  ASSERT_TRUE(model.ok());
  const auto all = model->decode_all();
  ASSERT_TRUE(all.ok());
  ASSERT_GT(model->patch_count(), 50u);
  const double expected = nominal_spacing(*all);
  for (const int threads : {1, 2}) {
    tbb::global_control control(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    const auto spacing = render::exact_decoded_spacing(*model, 16 * model->info().spacing);
    ASSERT_TRUE(spacing.ok()) << spacing.status().to_string();
    ASSERT_TRUE(spacing->has_value());
    EXPECT_EQ(**spacing, expected);
  }
  const auto too_near = render::exact_decoded_spacing(*model, 0.01f * static_cast<float>(expected));
  ASSERT_TRUE(too_near.ok());
  EXPECT_FALSE(too_near->has_value());
}

// A header that understates its points (10 where the model holds 4,000) still renders, the
// same surface as the honest model's under the same budget: its whole decode passes the budget's
// bound and the scene samples instead.
TEST(Renderer, AHeaderThatUnderstatesItsPointsRendersTheSameSurface) {
  SphereScene scene;
  test::TempDir dir;
  const auto path = dir.path() / "sphere.sspc";
  ASSERT_TRUE(encode(synthetic::sphere(4000, 1.0), path, EncodeOptions{}).ok());
  const std::string bytes = slurp(path);
  std::string hostile = bytes;
  const std::uint64_t understated = 10;
  std::memcpy(hostile.data() + 32, &understated, 8);  // the header's source_points; its CRC32 at 192
  const auto crc = static_cast<std::uint32_t>(crc32(0, reinterpret_cast<const Bytef*>(hostile.data()), 192));
  std::memcpy(hostile.data() + 192, &crc, 4);
  auto honest = CompressedModel::from_bytes(bytes);
  auto lying = CompressedModel::from_bytes(hostile);
  ASSERT_TRUE(honest.ok() && lying.ok());
  ASSERT_EQ(lying->info().source_points, 10u);
  SceneOptions small;
  small.memory_budget_bytes = 128 << 10;  // 2,048 points at 64 bytes a point: under the model's
  const auto a = render_compressed(*honest, scene.options, small);
  const auto b = render_compressed(*lying, scene.options, small);
  ASSERT_TRUE(a.ok()) << a.status().to_string();
  ASSERT_TRUE(b.ok()) << b.status().to_string();
  const auto c = compare_images(*a, *b);
  ASSERT_TRUE(c.ok());
  EXPECT_GT(c->hit_both, 1000u);
  EXPECT_LE(c->one_only_fraction(), 0.01);
  EXPECT_GE(c->psnr_hit, 35.0);
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
  auto compressed = render_compressed(*model, scene.options, {}, &stats);
  ASSERT_TRUE(plain.ok() && compressed.ok()) << compressed.status().to_string();
  const auto [disagree, both, errors] = compare_depths(*plain, *compressed);
  ASSERT_GT(both, 1500);
  EXPECT_LT(disagree, both / 50);
  EXPECT_LT(errors[errors.size() / 2], 0.005f);
  EXPECT_LT(errors[errors.size() * 95 / 100], 0.02f);
  EXPECT_GT(stats.hits, 1500u);
}

// RenderScene::intersect is the renderer's own ray: at every 7th pixel its t equals the
// frame's depth, for a cloud and for a compressed model; a direction twice as long halves t; a
// ray that looks away misses; a zero direction is an error.
TEST(Renderer, IntersectIsTheRayOfTheImage) {
  SphereScene scene;
  test::TempDir dir;
  const auto path = dir.path() / "sphere.sspc";
  ASSERT_TRUE(encode(scene.cloud, path, EncodeOptions{}).ok());
  auto opened = CompressedModel::open(path);
  ASSERT_TRUE(opened.ok());
  auto cloud_scene = RenderScene::from_point_cloud(scene.cloud);
  auto model_scene = RenderScene::from_compressed(std::make_shared<const CompressedModel>(std::move(opened).value()));
  ASSERT_TRUE(cloud_scene.ok() && model_scene.ok());
  const render::PinholeCamera camera(scene.options.camera, scene.options.width, scene.options.height);
  for (const auto* s : {cloud_scene->get(), model_scene->get()}) {
    auto image = s->render(scene.options);
    ASSERT_TRUE(image.ok());
    int hits = 0;
    for (int y = 0; y < scene.options.height; y += 7) {
      for (int x = 0; x < scene.options.width; x += 7) {
        const float depth = image->depth[static_cast<std::size_t>(y * scene.options.width + x)];
        auto hit = s->intersect(camera.eye(), camera.direction(x, y));
        ASSERT_TRUE(hit.ok()) << hit.status().to_string();
        ASSERT_EQ(hit->has_value(), std::isfinite(depth)) << x << "," << y;
        if (!*hit) continue;
        ++hits;
        EXPECT_NEAR((*hit)->t, depth, 1e-6f * depth);  // the direction normalised once more
        EXPECT_NEAR((*hit)->normal.norm(), 1.0f, 1e-5f);
        EXPECT_LT((*hit)->normal.dot(camera.direction(x, y)), 0.0f);
        auto twice = s->intersect(camera.eye(), 2.0f * camera.direction(x, y));
        ASSERT_TRUE(twice.ok() && twice->has_value());
        EXPECT_NEAR((*twice)->t, 0.5f * depth, 1e-5f * depth);
      }
    }
    EXPECT_GT(hits, 20);
    auto away = s->intersect(camera.eye(), camera.eye());
    ASSERT_TRUE(away.ok());
    EXPECT_FALSE(away->has_value());
    EXPECT_FALSE(s->intersect(camera.eye(), Vec3f::Zero()).ok());
  }
}

// surface_bounds() holds every hit intersect() returns, which bounds() does not: a square of
// points' MLS surface reaches beyond its edges (up to the support radius), where a ray from
// above meets it without entering the points' box, and a host ray tracer culling rays by
// bounds() would lose those hits. For a cloud, a paged cloud and a compressed model.
TEST(Renderer, SurfaceBoundsHoldEveryHit) {
  PointCloud square;
  const int side = 40;
  for (int y = 0; y < side; ++y) {
    for (int x = 0; x < side; ++x) {
      square.positions.emplace_back(static_cast<float>(x) / (side - 1), static_cast<float>(y) / (side - 1), 0.0f);
      square.normals.emplace_back(Vec3f::UnitZ());
    }
  }
  test::TempDir dir;
  const auto path = dir.path() / "square.sspc";
  ASSERT_TRUE(encode(square, path, EncodeOptions{}).ok());
  auto opened = CompressedModel::open(path);
  ASSERT_TRUE(opened.ok());
  auto cloud_scene = RenderScene::from_point_cloud(square);
  auto paged_scene = RenderScene::from_point_cloud_paged(square, dir.path(), {.memory_budget_bytes = std::uint64_t{1} << 30});
  auto model_scene = RenderScene::from_compressed(std::make_shared<const CompressedModel>(std::move(opened).value()));
  ASSERT_TRUE(cloud_scene.ok() && paged_scene.ok() && model_scene.ok());
  for (const auto* s : {cloud_scene->get(), paged_scene->get(), model_scene->get()}) {
    const Box3f points = s->bounds(), surface = s->surface_bounds();
    EXPECT_TRUE(surface.contains(points));
    int hits = 0, beyond_points = 0;
    for (int j = 0; j <= 60; ++j) {
      for (int i = 0; i <= 60; ++i) {
        const Vec3f o(-0.15f + 1.3f * static_cast<float>(i) / 60, -0.15f + 1.3f * static_cast<float>(j) / 60, 1.0f);
        auto hit = s->intersect(o, -Vec3f::UnitZ());
        ASSERT_TRUE(hit.ok()) << hit.status().to_string();
        if (!*hit) continue;
        ++hits;
        const Vec3f p = o - (*hit)->t * Vec3f::UnitZ();
        EXPECT_LE(surface.exteriorDistance(p), 1e-6f) << p.transpose();
        if (points.exteriorDistance(p) > 0) ++beyond_points;
      }
    }
    EXPECT_GT(hits, 2000);
    if (s == cloud_scene->get()) {
      EXPECT_GT(beyond_points, 0);
    }
  }
}

// compare_images on a worked example: two hit pixels differing by 10 in every channel (MSE 100,
// 10·log10(255²/100) = 28.13 dB), one pixel hit in the first only, one missed by both.
TEST(Renderer, ImageComparisonOfAKnownDifference) {
  Image a, b;
  a.width = b.width = 4;
  a.height = b.height = 1;
  a.rgb = {100, 100, 100, 50, 60, 70, 40, 40, 40, 0, 0, 0};
  b.rgb = {110, 110, 110, 60, 70, 80, 0, 0, 0, 0, 0, 0};
  auto c = compare_images(a, b);
  ASSERT_TRUE(c.ok());
  EXPECT_NEAR(c->psnr_hit, 28.13, 0.01);
  EXPECT_EQ(c->hit_both, 2u);
  EXPECT_EQ(c->hit_first_only, 1u);
  EXPECT_EQ(c->hit_second_only, 0u);
  EXPECT_NEAR(c->one_only_fraction(), 1.0 / 3.0, 1e-12);
  EXPECT_TRUE(std::isinf(compare_images(a, a)->psnr_hit));
  b.width = 2;
  b.height = 2;
  EXPECT_FALSE(compare_images(a, b).ok());

  // A supersampled reference, twice the size each way: each 2 × 2 block averaged, misses as
  // black. Block 0 is 100 throughout (equal to a's 100); block 1 has one hit of 200 and three
  // misses (50, against a's 60: error 10); block 2 is missed (a's 40 hit in the first only).
  Image s;
  s.width = 6;
  s.height = 2;
  s.rgb.assign(3 * 12, 0);
  const auto put = [&](int x, int y, std::uint8_t v) {
    for (int k = 0; k < 3; ++k) s.rgb[static_cast<std::size_t>(3 * (y * 6 + x) + k)] = v;
  };
  for (const auto& [x, y] : {std::pair{0, 0}, std::pair{1, 0}, std::pair{0, 1}, std::pair{1, 1}}) put(x, y, 100);
  put(3, 1, 200);
  Image small;
  small.width = 3;
  small.height = 1;
  small.rgb = {100, 100, 100, 60, 60, 60, 40, 40, 40};
  auto ss = compare_images(small, s);
  ASSERT_TRUE(ss.ok()) << ss.status().to_string();
  EXPECT_EQ(ss->hit_both, 2u);
  EXPECT_EQ(ss->hit_first_only, 1u);
  EXPECT_NEAR(ss->psnr_hit, 10 * std::log10(255.0 * 255.0 / 50.0), 0.01);  // MSE (0 + 100) / 2
  s.width = 5;  // not a whole multiple
  s.rgb.resize(3 * 10);
  EXPECT_FALSE(compare_images(small, s).ok());
}

// write_png then read_png gives the pixels back; a file that is not a PNG, or is cut short, is
// an error naming it.
TEST(Renderer, PngRoundTripAndBadPngs) {
  Image image;
  image.width = 5;
  image.height = 3;
  for (int i = 0; i < 45; ++i) image.rgb.push_back(static_cast<std::uint8_t>(i * 5));
  test::TempDir dir;
  const auto path = dir.path() / "a.png";
  ASSERT_TRUE(write_png(image, path).ok());
  auto back = read_png(path);
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  EXPECT_EQ(back->width, 5);
  EXPECT_EQ(back->height, 3);
  EXPECT_EQ(back->rgb, image.rgb);
  const std::string bytes = slurp(path);
  const auto cut = dir.path() / "cut.png";
  std::ofstream(cut, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  auto bad = read_png(cut);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("cut.png"), std::string::npos) << bad.status().to_string();
  EXPECT_FALSE(read_png(dir.path() / "none.png").ok());
  std::ofstream(dir.path() / "text.png") << "not a png at all";
  EXPECT_FALSE(read_png(dir.path() / "text.png").ok());
}

// The direct render of a compressed model against the render of its decode (normals estimated
// the same way on both sides). The bar is ≥ 35 dB over the pixels hit and ≤ 0.2% of
// them hit by one only; since the bricks share the whole cloud's march (render/mls_march.hpp)
// these images are equal (inf dB, none hit by one only), so the bar here is far above the
// issue's: a change that lets the bricks drift apart again fails it (the bunny scored 56 dB at
// level 5 with the march restarted at each brick, 1024²).
void expect_direct_matches_decoded(const PointCloud& source, int level, const FrameOptions& options) {
  test::TempDir dir;
  const auto path = dir.path() / "model.sspc";
  EncodeOptions encode_options;
  encode_options.level = level;
  ASSERT_TRUE(encode(source, path, encode_options).ok());
  auto model = CompressedModel::open(path);
  ASSERT_TRUE(model.ok());
  auto decoded = model->decode_all();
  ASSERT_TRUE(decoded.ok());
  ASSERT_TRUE(ensure_normals(*decoded, NormalOptions{}).ok());
  auto reference = render_point_cloud(*decoded, options);
  auto direct = render_compressed(*model, options);
  ASSERT_TRUE(reference.ok() && direct.ok()) << direct.status().to_string();
  const auto c = compare_images(*direct, *reference);
  ASSERT_TRUE(c.ok());
  std::printf("level %d: %.2f dB over %llu pixels hit, %.3f%% hit by one only\n", level, c->psnr_hit,
              static_cast<unsigned long long>(c->hit_both), 100 * c->one_only_fraction());
  EXPECT_GT(c->hit_both, static_cast<std::uint64_t>(options.width * options.height / 8));
  EXPECT_GE(c->psnr_hit, 60.0) << "level " << level;
  EXPECT_LE(c->one_only_fraction(), 0.0005) << "level " << level;
}

TEST(Renderer, DirectRenderOfTheBunnyMatchesTheRenderOfItsDecode) {
  auto cloud = read_point_cloud(std::string(SSPC_SOURCE_DIR) + "/data/bunny.ply");
  ASSERT_TRUE(cloud.ok()) << cloud.status().to_string();
  FrameOptions options;
  options.width = options.height = 192;
  options.camera = frame_bounds(cloud->bounding_box());
  // The finest and the coarsest level (level 5 is in the CLI's and Python's tests; all three on
  // the real scans in scripts/bench_render.sh).
  expect_direct_matches_decoded(*cloud, 0, options);
  expect_direct_matches_decoded(*cloud, 9, options);
}

// A sphere split into many patches (a small patch radius at level 9 on a fine sampling): no
// seam, no hole, whatever the instancing did.
TEST(Renderer, DirectRenderOfASphereOfManyPatchesMatchesItsDecode) {
  SphereScene scene;
  expect_direct_matches_decoded(scene.cloud, 9, scene.options);
}

// The spacing a render takes its bandwidth from lies on the ladder of 2^(k/8), at most half a
// rung (4.4%) from the estimate, and nearby estimates share a rung: what makes a compressed
// model's render and its decode's, each estimating the spacing from its own sample, agree.
TEST(Renderer, SpacingsLieOnTheLadder) {
  for (const double s : {1e-6, 0.000228684, 0.7924, 0.8000, 1.0, 3.7, 1e5}) {
    const double l = render::ladder_spacing(s);
    const double rung = std::log2(l) * render::kSpacingLadder;
    EXPECT_NEAR(rung, std::round(rung), 1e-9) << s;
    EXPECT_LE(std::abs(std::log2(l / s)), 0.5 / render::kSpacingLadder + 1e-12) << s;
    EXPECT_EQ(render::ladder_spacing(l), l) << s;
  }
  EXPECT_EQ(render::ladder_spacing(0.7924), render::ladder_spacing(0.8000));  // autzen level 0's two estimates
  EXPECT_LE(render::ladder_spacing(1.0), render::ladder_spacing(1.05));
  EXPECT_EQ(render::ladder_spacing(0.0), 0.0);
}

// Every tile of the image once, each a neighbour of the one before where the tiles fill a square
// of a power of two a side (elsewhere the curve leaves the image and comes back).
TEST(Renderer, HilbertTilesCoverTheImageOnceInNeighbourOrder) {
  for (const auto& [w, h] : {std::pair{1, 1}, std::pair{17, 5}, std::pair{1000, 300}, std::pair{256, 256}}) {
    const auto tiles = render::hilbert_tiles(w, h);
    const int tx = (w + render::kTile - 1) / render::kTile, ty = (h + render::kTile - 1) / render::kTile;
    ASSERT_EQ(tiles.size(), static_cast<std::size_t>(tx * ty)) << w << "x" << h;
    std::vector<int> seen(static_cast<std::size_t>(tx * ty), 0);
    for (const auto& [x, y] : tiles) {
      ASSERT_TRUE(x % render::kTile == 0 && y % render::kTile == 0 && x < w && y < h);
      ++seen[static_cast<std::size_t>(y / render::kTile * tx + x / render::kTile)];
    }
    EXPECT_TRUE(std::all_of(seen.begin(), seen.end(), [](int n) { return n == 1; }));
  }
  const auto square = render::hilbert_tiles(256, 256);
  for (std::size_t i = 1; i < square.size(); ++i) {
    EXPECT_EQ(std::abs(square[i].first - square[i - 1].first) + std::abs(square[i].second - square[i - 1].second),
              render::kTile) << i;
  }
}

// `cloud` encoded at `level` and opened, shared as a scene holds it; null on failure.
std::shared_ptr<const CompressedModel> encoded_model(const PointCloud& cloud, int level = EncodeOptions{}.level) {
  test::TempDir dir;
  const auto path = dir.path() / "model.sspc";
  EncodeOptions encode_options;
  encode_options.level = level;
  if (!encode(cloud, path, encode_options).ok()) return nullptr;
  auto opened = CompressedModel::open(path);
  if (!opened.ok()) return nullptr;
  return std::make_shared<const CompressedModel>(std::move(opened).value());
}
std::shared_ptr<const CompressedModel> sphere_model(const SphereScene& scene) { return encoded_model(scene.cloud, 5); }

// A compressed scene's image depends neither on its budget nor on the thread count, and a
// second frame with room for every brick builds none.
TEST(BrickScene, SameImageWhateverTheBudgetAndThreads) {
  SphereScene scene;
  const auto model = sphere_model(scene);
  ASSERT_NE(model, nullptr);
  auto roomy = RenderScene::from_compressed(model, {.memory_budget_bytes = std::uint64_t{1} << 30});
  auto tight = RenderScene::from_compressed(model, {.memory_budget_bytes = 64 << 10});
  ASSERT_TRUE(roomy.ok() && tight.ok());
  RenderStats roomy_first, roomy_second, tight_stats;
  auto a = (*roomy)->render(scene.options, &roomy_first);
  auto b = (*roomy)->render(scene.options, &roomy_second);
  auto c = (*tight)->render(scene.options, &tight_stats);
  ASSERT_TRUE(a.ok() && b.ok() && c.ok());
  EXPECT_EQ(a->rgb, b->rgb);
  EXPECT_EQ(a->rgb, c->rgb);
  EXPECT_GT(roomy_first.pages_read, 0u);
  EXPECT_EQ(roomy_second.pages_read, 0u);  // every brick stayed
  // (Eviction itself is exercised by the paged scene's test: this sphere has fewer bricks than
  // a cache always keeps.)
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    auto single = (*tight)->render(scene.options);
    ASSERT_TRUE(single.ok());
    EXPECT_EQ(single->rgb, a->rgb);
  }
}

// The paged scene renders what the in-memory one does, within its budget: with room for every
// brick the second frame reads nothing; with room for a third of the scene it reads again, and
// the picture is the same.
TEST(Renderer, PagedSceneMatchesTheInMemoryOne) {
  SphereScene scene;
  RenderStats plain_stats;
  auto plain = render_point_cloud(scene.cloud, scene.options, {}, &plain_stats);
  ASSERT_TRUE(plain.ok());
  test::TempDir dir;
  for (const std::uint64_t budget : {std::uint64_t{1} << 30, plain_stats.scene_bytes / 3}) {
    auto paged = RenderScene::from_point_cloud_paged(scene.cloud, dir.path(), {.memory_budget_bytes = budget});
    ASSERT_TRUE(paged.ok()) << paged.status().to_string();
    RenderStats first, second;
    auto a = (*paged)->render(scene.options, &first);
    auto b = (*paged)->render(scene.options, &second);
    ASSERT_TRUE(a.ok() && b.ok());
    EXPECT_EQ(a->rgb, b->rgb);
    EXPECT_GT(first.bytes_read, scene.cloud.size() * 24);  // every point, and the halos
    if (budget > (1u << 20)) {
      EXPECT_EQ(second.bytes_read, 0u);
    } else {
      EXPECT_GT(second.bytes_read, 0u);
      EXPECT_LE(second.scene_bytes, budget + budget);  // a brick or so over the budget at most
    }
    const auto [disagree, both, errors] = compare_depths(*plain, *a);
    EXPECT_LE(disagree, 3);
    EXPECT_LT(errors[errors.size() * 99 / 100], 0.002f);
    // The march samples each ray where the whole cloud's surface does (render/mls_march.hpp):
    // the same image up to the order of float sums (equal today); before the march was shared,
    // rays restarted at every brick's face and the bricks' images differed visibly.
    const auto c = compare_images(*a, *plain);
    ASSERT_TRUE(c.ok());
    EXPECT_GE(c->psnr_hit, 60.0);
    EXPECT_EQ(c->hit_first_only + c->hit_second_only, 0u);
  }
  EXPECT_EQ(test::count_files(dir.path()), 0u);  // the page files went with their scenes
}

// A compressed plane shows no seams: where patches meet, the shading varies from pixel to pixel no
// more than inside patches. The plane is a jittered grid with a little noise in z, so patches are
// copies of one another up to their sampling, as on a scan.
TEST(Renderer, CompressedPlaneHasNoSeams) {
  PointCloud plane;
  std::mt19937 random(7);
  std::uniform_real_distribution<float> jitter(-0.3f, 0.3f);
  const int side = 150;
  const float step = 1.0f / side;
  for (int i = 0; i < side; ++i) {
    for (int j = 0; j < side; ++j) {
      plane.positions.emplace_back((static_cast<float>(i) + jitter(random)) * step,
                                   (static_cast<float>(j) + jitter(random)) * step, 0.1f * step * jitter(random));
      plane.normals.push_back(Vec3f::UnitZ());
    }
  }
  const auto model = encoded_model(plane);
  ASSERT_NE(model, nullptr);
  FrameOptions options;
  options.width = options.height = 160;
  options.camera.eye = Vec3f(0.5f, -0.1f, 0.7f);
  options.camera.target = Vec3f(0.5f, 0.5f, 0.0f);
  options.camera.fov_degrees = 40;
  auto image = render_compressed(*model, options);
  ASSERT_TRUE(image.ok()) << image.status().to_string();

  // Each hit pixel's surface point, and how far it is from the border between the regions of
  // its two nearest patch centres.
  std::vector<Vec3f> centres;
  for (std::size_t k = 0; k < model->patch_count(); ++k) centres.push_back(model->patch(k)->translation);
  const float spacing = model->info().spacing;
  const render::PinholeCamera camera(options.camera, options.width, options.height);
  const auto border_distance = [&](int x, int y) {
    const float t = image->depth[static_cast<std::size_t>(y * options.width + x)];
    const Vec3f p = camera.eye() + t * camera.direction(x, y);
    float d1 = std::numeric_limits<float>::infinity(), d2 = d1;
    for (const Vec3f& c : centres) {
      const float d = (p - c).norm();
      if (d < d1) {
        d2 = d1;
        d1 = d;
      } else if (d < d2) {
        d2 = d;
      }
    }
    return 0.5f * (d2 - d1);
  };
  double border_sum = 0, inside_sum = 0;
  int border_n = 0, inside_n = 0, hit = 0;
  for (int y = 0; y < options.height; ++y) {
    for (int x = 0; x + 1 < options.width; ++x) {
      const auto i = static_cast<std::size_t>(y * options.width + x);
      if (!std::isfinite(image->depth[i]) || !std::isfinite(image->depth[i + 1])) continue;
      ++hit;
      const double step_grey = std::abs(static_cast<double>(image->rgb[3 * i]) - static_cast<double>(image->rgb[3 * i + 3]));
      const float b = border_distance(x, y);
      if (b < 1.5f * spacing) {
        border_sum += step_grey * step_grey;
        ++border_n;
      } else if (b > 4.0f * spacing) {
        inside_sum += step_grey * step_grey;
        ++inside_n;
      }
    }
  }
  ASSERT_GT(hit, options.width * options.height / 2);
  ASSERT_GT(border_n, 500);
  ASSERT_GT(inside_n, 500);
  const double border = border_sum / border_n, inside = inside_sum / inside_n;
  // Mean squared grey step between neighbouring pixels: a seam would show as a larger one. Where
  // two code words meet, their grids do, and the decoded points lie a little less evenly than
  // inside either (2% of them within half a spacing of another, none inside): over this plane
  // with 8 seeds of its jitter the border's mean step was 1.29-1.94 times the inside's (the raw
  // points' render: 0.93-1.15 times, its steps 30 times smaller), so the bound is 2.5 times.
  EXPECT_LT(border, 2.5 * inside + 0.5) << "border " << border << ", inside " << inside;
  std::printf("mean squared grey step: %.2f across patch borders, %.2f inside patches\n", border, inside);
}

// Level of detail (FrameOptions::level_of_detail): where the points lie denser than the pixels,
// a compressed scene intersects a coarser form of the surface (one point a cell of 2, 4 or 8
// times the points' spacing, render/brick_scene.hpp). On a smooth surface that is the same
// picture (a sphere whose spacing projects to about 0.3 pixel: level 1 used, from a third of the
// points), and like every frame it depends neither on the budget nor on the thread count.
TEST(Renderer, LevelOfDetailKeepsASmoothSurfaceFromFewerPoints) {
  SphereScene scene;
  scene.options.width = scene.options.height = 48;
  const auto model = sphere_model(scene);
  ASSERT_NE(model, nullptr);
  const SceneOptions roomy{.memory_budget_bytes = std::uint64_t{1} << 30};
  auto fine_scene = RenderScene::from_compressed(model, roomy);
  auto coarse_scene = RenderScene::from_compressed(model, roomy);
  auto tight = RenderScene::from_compressed(model, {.memory_budget_bytes = 64 << 10});
  ASSERT_TRUE(fine_scene.ok() && coarse_scene.ok() && tight.ok());
  FrameOptions coarse = scene.options;
  coarse.level_of_detail = 1;
  auto full = (*fine_scene)->render(scene.options);
  auto a = (*coarse_scene)->render(coarse);
  ASSERT_TRUE(full.ok() && a.ok());
  const auto c = compare_images(*a, *full);
  ASSERT_TRUE(c.ok());
  std::printf("level of detail 1: %.2f dB over %llu pixels hit, %.3f%% hit by one only\n", c->psnr_hit,
              static_cast<unsigned long long>(c->hit_both), 100 * c->one_only_fraction());
  EXPECT_GT(c->hit_both, 800u);
  EXPECT_GE(c->psnr_hit, 35.0);
  EXPECT_LE(c->one_only_fraction(), 0.005);
  EXPECT_NE(a->rgb, full->rgb);  // the coarse levels were used
  auto b = (*tight)->render(coarse);
  ASSERT_TRUE(b.ok());
  EXPECT_EQ(a->rgb, b->rgb);
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    auto single = (*fine_scene)->render(coarse);
    ASSERT_TRUE(single.ok());
    EXPECT_EQ(single->rgb, a->rgb);
  }
  // Without level of detail, the frame is the full one again, from the same scene.
  auto again = (*coarse_scene)->render(scene.options);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again->rgb, full->rgb);
}

// Level of detail on a model whose extent dwarfs its spacing (two small spheres 10⁵ radii
// apart): the coarse bricks' cell grids are bounded, and the frame completes with both spheres.
TEST(Renderer, LevelOfDetailOnAFarSpreadModel) {
  PointCloud cloud = synthetic::sphere(3000, 1.0);
  const std::size_t half = cloud.size();
  for (std::size_t i = 0; i < half; ++i) {
    cloud.positions.push_back(cloud.positions[i] + Vec3f(1e5f, 0, 0));
    cloud.normals.push_back(cloud.normals[i]);
  }
  const auto model = encoded_model(cloud);
  ASSERT_NE(model, nullptr);
  FrameOptions options;
  options.width = options.height = 64;
  options.level_of_detail = 1;
  for (const float x : {0.0f, 1e5f}) {
    options.camera.eye = Vec3f(x, 0, 20);
    options.camera.target = Vec3f(x, 0, 0);
    auto image = render_compressed(*model, options);
    ASSERT_TRUE(image.ok()) << image.status().to_string();
    const auto hits = std::count_if(image->depth.begin(), image->depth.end(), [](float t) { return std::isfinite(t); });
    EXPECT_GT(hits, 20) << "sphere at x = " << x;
  }
}

}  // namespace
}  // namespace sspc
