// Normals: PCA accuracy against analytic normals, Hoppe orientation (consistent, then outward by
// the +z seed rule), viewpoint orientation, the keep / estimate / auto policy, and determinism
// across thread counts.
#include "sspc/normals.hpp"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numbers>
#include <string>
#include <vector>

#include "geometry/normals_steps.hpp"
#include "sspc/neighbours.hpp"
#include "sspc/synthetic.hpp"

namespace sspc {
namespace {

double degrees(double radians) {
  return radians * 180.0 / std::numbers::pi;
}

// The angle between two unit vectors, in degrees; `unsigned_` ignores the sign.
double angle_deg(const Vec3f& a, const Vec3f& b, bool unsigned_ = false) {
  double c = a.cast<double>().dot(b.cast<double>());
  if (unsigned_) c = std::abs(c);
  return degrees(std::acos(std::clamp(c, -1.0, 1.0)));
}

// The cloud with its analytic normals moved aside into `truth`.
PointCloud without_normals(PointCloud cloud, std::vector<Vec3f>& truth) {
  truth = std::move(cloud.normals);
  cloud.normals.clear();
  return cloud;
}

NormalOptions estimate_mode() {
  NormalOptions options;
  options.mode = NormalMode::kEstimate;
  return options;
}

struct SignCount {
  std::size_t agree = 0, disagree = 0;
};

SignCount signs_against(const std::vector<Vec3f>& normals, const std::vector<Vec3f>& truth) {
  SignCount c;
  for (std::size_t i = 0; i < normals.size(); ++i) {
    (normals[i].dot(truth[i]) > 0 ? c.agree : c.disagree) += 1;
  }
  return c;
}

TEST(Normals, SphereGetsOutwardUnitNormalsWithinTwoDegrees) {
  std::vector<Vec3f> truth;
  PointCloud cloud = without_normals(synthetic::sphere(20000, 1.0), truth);
  ASSERT_TRUE(ensure_normals(cloud, estimate_mode()).ok());
  ASSERT_EQ(cloud.normals.size(), cloud.size());
  double worst = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    ASSERT_NEAR(cloud.normals[i].norm(), 1.0f, 1e-6f);
    worst = std::max(worst, angle_deg(cloud.normals[i], truth[i]));
  }
  EXPECT_LT(worst, 2.0);
}

TEST(Normals, PlaneNormalIsRightUpToSignBeforeOrientationAndUpAfter) {
  for (const double noise_fraction : {0.0, 0.01}) {
    // 40000 points on a 4 × 4 square: spacing 0.02; noise 1% of it.
    synthetic::Options o;
    o.seed = 3;
    o.noise = noise_fraction * 0.02;
    std::vector<Vec3f> truth;
    PointCloud cloud = without_normals(synthetic::plane(40000, 4.0, o), truth);

    ASSERT_TRUE(estimate_normals(cloud, {}).ok());
    double worst = 0;
    for (const Vec3f& n : cloud.normals)
      worst = std::max(worst, angle_deg(n, Vec3f::UnitZ(), true));
    EXPECT_LT(worst, noise_fraction == 0 ? 1e-3 : 2.0) << "noise " << noise_fraction;

    ASSERT_TRUE(orient_normals(cloud, {}).ok());
    // Consistent, and up: the highest point's normal faces +z.
    const SignCount c = signs_against(cloud.normals, truth);
    EXPECT_EQ(c.disagree, 0u) << "noise " << noise_fraction;
    EXPECT_EQ(c.agree, cloud.size());
  }
}

TEST(Normals, TorusIsConsistentlyOrientedAndOutward) {
  std::vector<Vec3f> truth;
  PointCloud cloud = without_normals(synthetic::torus(40000, 2.0, 0.5), truth);
  ASSERT_TRUE(ensure_normals(cloud, estimate_mode()).ok());
  const SignCount c = signs_against(cloud.normals, truth);
  // Consistent first (all one way), then the seed rule: the top of the tube faces +z, outward.
  EXPECT_TRUE(c.agree == 0 || c.disagree == 0) << c.agree << " agree, " << c.disagree << " not";
  EXPECT_EQ(c.agree, cloud.size());
}

TEST(Normals, NoisyBumpsAreConsistentlyOriented) {
  synthetic::Options o;
  o.noise = 0.0002;  // 1% of the 0.02 spacing
  std::vector<Vec3f> truth;
  PointCloud cloud = without_normals(synthetic::bumps(40000, 4.0, 4, 0.3, o), truth);
  ASSERT_TRUE(ensure_normals(cloud, estimate_mode()).ok());
  const SignCount c = signs_against(cloud.normals, truth);
  EXPECT_EQ(c.disagree, 0u);
}

TEST(Normals, OrientationRepairsRandomlyFlippedNormals) {
  // Exact normals, half of them flipped: Hoppe's propagation alone must restore them.
  PointCloud cloud = synthetic::torus(20000, 2.0, 0.5);
  const std::vector<Vec3f> truth = cloud.normals;
  synthetic::Rng rng(17);
  for (Vec3f& n : cloud.normals) {
    if (rng.next_u64() & 1) n = -n;
  }
  ASSERT_TRUE(orient_normals(cloud, {}).ok());
  for (std::size_t i = 0; i < cloud.size(); ++i) ASSERT_EQ(cloud.normals[i], truth[i]) << i;
}

TEST(Normals, EachConnectedComponentIsSeededAtItsOwnTop) {
  // Two spheres far apart (two components of the k-NN graph), the second one's normals all
  // flipped inward: each component must come out facing outward on its own.
  PointCloud a = synthetic::sphere(5000, 1.0);
  synthetic::Options o;
  o.seed = 9;
  PointCloud b = synthetic::sphere(5000, 1.0, o);
  PointCloud cloud = a;
  for (std::size_t i = 0; i < b.size(); ++i) {
    cloud.positions.push_back(b.positions[i] + Vec3f(100, 0, -50));
    cloud.normals.push_back(-b.normals[i]);
  }
  std::vector<Vec3f> truth = a.normals;
  truth.insert(truth.end(), b.normals.begin(), b.normals.end());
  ASSERT_TRUE(orient_normals(cloud, {}).ok());
  const SignCount c = signs_against(cloud.normals, truth);
  EXPECT_EQ(c.disagree, 0u);
}

TEST(Normals, ViewpointOrientationFacesTheViewpoint) {
  // Sphere seen from its centre: every normal inward, against the +z seed rule.
  std::vector<Vec3f> truth;
  PointCloud cloud = without_normals(synthetic::sphere(5000, 1.0), truth);
  NormalOptions options = estimate_mode();
  options.viewpoint = Vec3f::Zero();
  ASSERT_TRUE(ensure_normals(cloud, options).ok());
  for (std::size_t i = 0; i < cloud.size(); ++i) ASSERT_LT(cloud.normals[i].dot(truth[i]), 0.0f);

  // A plane seen from below, through orient_normals on normals it already has.
  PointCloud plane = synthetic::plane(2000, 2.0);
  NormalOptions below;
  below.viewpoint = Vec3f(0.3f, -0.2f, -5.0f);
  ASSERT_TRUE(orient_normals(plane, below).ok());
  for (const Vec3f& n : plane.normals) ASSERT_EQ(n, -Vec3f::UnitZ());
}

TEST(Normals, KeepWithoutNormalsIsAnError) {
  PointCloud cloud = synthetic::plane(100, 1.0, {.seed = 1, .normals = false});
  NormalOptions options;
  options.mode = NormalMode::kKeep;
  const Status s = ensure_normals(cloud, options);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("keep"), std::string::npos) << s.message();
  EXPECT_FALSE(cloud.has_normals());
}

TEST(Normals, KeepAndAutoLeaveFileNormalsAlone) {
  // Deliberately wrong "file" normals: a policy that re-estimated would change them.
  PointCloud cloud = synthetic::plane(500, 1.0);
  for (Vec3f& n : cloud.normals) n = Vec3f::UnitX();
  for (NormalMode mode : {NormalMode::kKeep, NormalMode::kAuto}) {
    NormalOptions options;
    options.mode = mode;
    ASSERT_TRUE(ensure_normals(cloud, options).ok());
    for (const Vec3f& n : cloud.normals) ASSERT_EQ(n, Vec3f::UnitX());
  }
  // kEstimate replaces them.
  ASSERT_TRUE(ensure_normals(cloud, estimate_mode()).ok());
  for (const Vec3f& n : cloud.normals) ASSERT_GT(n.z(), 0.999f);
}

TEST(Normals, AutoEstimatesAndOrientsWhenTheCloudHasNone) {
  PointCloud cloud = synthetic::plane(2000, 1.0, {.seed = 2, .normals = false});
  ASSERT_TRUE(ensure_normals(cloud, {}).ok());
  ASSERT_EQ(cloud.normals.size(), cloud.size());
  for (const Vec3f& n : cloud.normals) ASSERT_GT(n.z(), 0.999f);
}

TEST(Normals, BadArgumentsAreErrors) {
  PointCloud cloud = synthetic::plane(100, 1.0, {.seed = 1, .normals = false});
  NormalOptions options = estimate_mode();
  options.k = 2;
  EXPECT_EQ(ensure_normals(cloud, options).code(), StatusCode::kInvalidArgument);
  options.k = 257;
  EXPECT_EQ(estimate_normals(cloud, options).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(orient_normals(cloud, {}).code(), StatusCode::kInvalidArgument);  // no normals

  PointCloud two;
  two.positions = {Vec3f(0, 0, 0), Vec3f(1, 0, 0)};
  EXPECT_EQ(estimate_normals(two, {}).code(), StatusCode::kInvalidArgument);
  // Three points are enough; k larger than the cloud is clamped.
  two.positions.emplace_back(0, 1, 0);
  ASSERT_TRUE(ensure_normals(two, estimate_mode()).ok());
  for (const Vec3f& n : two.normals) EXPECT_EQ(n, Vec3f::UnitZ());
}

TEST(Normals, DuplicatePointsStillGetUnitNormals) {
  PointCloud cloud;
  for (int i = 0; i < 40; ++i) cloud.positions.emplace_back(1, 2, 3);
  ASSERT_TRUE(ensure_normals(cloud, estimate_mode()).ok());
  for (const Vec3f& n : cloud.normals) {
    ASSERT_TRUE(n.allFinite());
    ASSERT_NEAR(n.norm(), 1.0f, 1e-6f);
  }
}

class RecordingProgress final : public Progress {
 public:
  void begin_stage(std::string_view name, std::uint64_t total, std::string_view) override {
    stages.emplace_back(name);
    totals.push_back(total);
    done.push_back(0);
  }
  void advance(std::uint64_t n) override { done.back() += n; }  // tests run it on one thread
  void end_stage() override { ++ended; }

  std::vector<std::string> stages;
  std::vector<std::uint64_t> totals, done;
  int ended = 0;
};

TEST(Normals, ReportsPcaAndOrientStages) {
  tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
  PointCloud cloud = synthetic::bumps(70000, 4.0, 4, 0.3, {.seed = 1, .normals = false});
  RecordingProgress progress;
  NormalOptions options = estimate_mode();
  options.progress = &progress;
  ASSERT_TRUE(ensure_normals(cloud, options).ok());
  const std::vector<std::string> expected = {"normals: neighbours", "normals: PCA",
                                             "normals: orient"};
  EXPECT_EQ(progress.stages, expected);
  EXPECT_EQ(progress.ended, 3);
  for (std::size_t s = 0; s < progress.stages.size(); ++s) {
    EXPECT_EQ(progress.totals[s], cloud.size());
    EXPECT_EQ(progress.done[s], cloud.size()) << progress.stages[s];
  }
}

std::vector<Vec3f> normals_with_threads(int threads, const PointCloud& input) {
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                            static_cast<std::size_t>(threads));
  PointCloud cloud = input;
  EXPECT_TRUE(ensure_normals(cloud, estimate_mode()).ok());
  return cloud.normals;
}

TEST(Normals, ResultIsBitIdenticalOnOneAndTwoThreads) {
  synthetic::Options o;
  o.noise = 0.001;
  o.normals = false;
  const PointCloud cloud = synthetic::bumps(60000, 4.0, 4, 0.3, o);
  const auto one = normals_with_threads(1, cloud);
  const auto two = normals_with_threads(2, cloud);
  const auto four = normals_with_threads(4, cloud);
  ASSERT_EQ(one.size(), cloud.size());
  EXPECT_EQ(std::memcmp(one.data(), two.data(), one.size() * sizeof(Vec3f)), 0);
  EXPECT_EQ(std::memcmp(one.data(), four.data(), one.size() * sizeof(Vec3f)), 0);
}

// The orientation's graph: its reverse half holds, for each point j, every i whose row names j
// where j's row does not name i, each once. Checked against reading the rows on a cloud of exact
// ties (a lattice, every point with four neighbours at one distance), doubled points (the row
// of a point with duplicates ends at distance 0) and points in general position, and on a
// cloud smaller than k + 1 (short rows).
TEST(Normals, ReverseEdgesAreTheRowsThatDoNotNameTheirSource) {
  for (const std::size_t lattice : {std::size_t{40}, std::size_t{2}}) {
    std::vector<Vec3f> points;
    for (std::size_t y = 0; y < lattice; ++y) {
      for (std::size_t x = 0; x < lattice; ++x) points.emplace_back(static_cast<float>(x), static_cast<float>(y), 0.0f);
    }
    for (std::size_t i = 0; i < points.size(); i += 7) points.push_back(points[i]);
    const PointCloud bumps = synthetic::bumps(lattice * lattice, 40.0, 3, 1.0, {.seed = 3, .normals = false});
    points.insert(points.end(), bumps.positions.begin(), bumps.positions.end());
    const KnnTable table = KdTree3(points).knn_batch(points, 16, false, nullptr, false);
    const detail::ReverseEdges reverse = detail::reverse_edges(points, table, points.size());
    for (std::size_t j = 0; j < points.size(); ++j) {
      std::vector<std::uint32_t> expected;
      for (std::size_t i = 0; i < points.size(); ++i) {
        const auto row = table.row(i);
        if (std::find(row.begin(), row.end(), j) == row.end()) continue;
        const auto back = table.row(j);
        if (std::find(back.begin(), back.end(), i) == back.end()) expected.push_back(static_cast<std::uint32_t>(i));
      }
      const auto got_span = reverse.of(j);
      std::vector<std::uint32_t> got(got_span.begin(), got_span.end());
      std::sort(got.begin(), got.end());
      ASSERT_EQ(got, expected) << "point " << j << " of " << points.size();
    }
  }
}

}  // namespace
}  // namespace sspc
