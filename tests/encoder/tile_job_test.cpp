// Tile jobs and results as hostile bytes (encoder/tile_job.hpp): a damaged message is refused by
// its checksum, a job whose parameters would overflow a grid is refused before it runs, and a
// result is accepted only for the tile and the job it names, with finite points and proper
// rotations (TiledEncoder::add).
#include "encoder/tile_job.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <optional>
#include <limits>
#include <string>
#include <vector>

#include "sspc/synthetic.hpp"
#include "sspc/tiled_encoder.hpp"
#include "test_util.hpp"

namespace sspc::codec {
namespace {

class TileMessages : public ::testing::Test {
 protected:
  void SetUp() override {
    EncodeOptions options;
    options.level = 6;
    options.tile_points = 2500;
    options.patch_points = 256;
    auto planned = TiledEncoder::plan(synthetic::torus(8000, 1.0, 0.3), options);
    ASSERT_TRUE(planned.ok()) << planned.status().message();
    tiled_.emplace(std::move(*planned));
    ASSERT_GE(tiled_->tile_count(), 2u);
    for (std::size_t t = 0; t < 2; ++t) {
      auto job = tiled_->job(t);
      ASSERT_TRUE(job.ok());
      jobs_.push_back(*job);
      auto result = run_tile_job(*job);
      ASSERT_TRUE(result.ok()) << result.status().message();
      results_.push_back(*result);
    }
  }

  // Tile 0's result with `change` applied, sealed again as a worker would write it.
  std::string altered_result(const std::function<void(TileResult&)>& change) const {
    auto parsed = parse_tile_result(results_[0]);
    EXPECT_TRUE(parsed.ok());
    change(*parsed);
    return serialise_tile_result(*parsed);
  }

  // The error add() gives for `result` as tile 0's (a refused result leaves the writer waiting
  // for tile 0 still).
  std::string add_error(std::string result) {
    if (!begun_) {
      EXPECT_TRUE(tiled_->begin(dir_.path() / "m.sspc").ok());
    }
    begun_ = true;
    const Status added = tiled_->add(0, std::move(result));
    EXPECT_FALSE(added.ok());
    return added.message();
  }

  test::TempDir dir_;
  bool begun_ = false;
  std::optional<TiledEncoder> tiled_;
  std::vector<std::string> jobs_, results_;
};

TEST_F(TileMessages, JobsRoundTripWithTheirTile) {
  auto job = parse_tile_job(jobs_[1]);
  ASSERT_TRUE(job.ok()) << job.status().message();
  EXPECT_EQ(job->tile, 1u);
  EXPECT_EQ(serialise_tile_job(*job), jobs_[1]);
  auto result = parse_tile_result(results_[1]);
  ASSERT_TRUE(result.ok());
  EXPECT_EQ(result->tile, 1u);
  EXPECT_EQ(result->job_digest, tile_job_digest(jobs_[1]));
}

TEST_F(TileMessages, EveryDamagedByteIsRefused) {
  for (const std::string* message : {&jobs_[0], &results_[0]}) {
    for (std::size_t i = 0; i < message->size(); i += 97) {
      std::string damaged = *message;
      damaged[i] = static_cast<char>(damaged[i] ^ 0x20);
      const bool is_job = message == &jobs_[0];
      const Status status = is_job ? parse_tile_job(damaged).status() : parse_tile_result(damaged).status();
      EXPECT_FALSE(status.ok()) << "byte " << i;
    }
    EXPECT_FALSE(parse_tile_job(message->substr(0, message->size() - 1)).ok());
  }
}

// A patch radius of 1e-30 made the centres' hash grid index a cell past 2^31 (undefined
// behaviour, and a model that silently lost points); such a job is refused by its content.
TEST_F(TileMessages, JobsWithParametersNoCloudHasAreRefused) {
  auto with = [&](const std::function<void(TileJob&)>& change) {
    auto job = parse_tile_job(jobs_[0]);
    EXPECT_TRUE(job.ok());
    change(*job);
    return run_tile_job(serialise_tile_job(*job)).status();
  };
  const Status tiny = with([](TileJob& j) { j.build.patch_radius = 1e-30f; });
  EXPECT_FALSE(tiny.ok());
  EXPECT_NE(tiny.message().find("patch radius"), std::string::npos) << tiny.message();
  EXPECT_FALSE(with([](TileJob& j) { j.build.spacing = std::numeric_limits<double>::infinity(); }).ok());
  EXPECT_FALSE(with([](TileJob& j) { j.build.level.patch_points = 0; }).ok());
  EXPECT_FALSE(with([](TileJob& j) { j.normals.k = 100000; }).ok());
  EXPECT_FALSE(with([](TileJob& j) { j.part.positions[3].x() = std::nanf(""); }).ok());
  EXPECT_TRUE(with([](TileJob&) {}).ok());
}

TEST_F(TileMessages, AResultIsAcceptedOnlyForItsOwnTileAndJob) {
  EXPECT_NE(add_error(results_[1]).find("the result of tile 1 given for tile 0"), std::string::npos);
  // The result of another plan's tile 0 (another level): its job's digest differs.
  EncodeOptions other;
  other.level = 4;
  other.tile_points = 2500;
  other.patch_points = 256;
  auto plan = TiledEncoder::plan(synthetic::torus(8000, 1.0, 0.3), other);
  ASSERT_TRUE(plan.ok());
  auto foreign = run_tile_job(*plan->job(0));
  ASSERT_TRUE(foreign.ok());
  EXPECT_NE(add_error(*foreign).find("another job"), std::string::npos);
  // The right result is accepted after those refusals, and the rest follow.
  EXPECT_TRUE(tiled_->add(0, results_[0]).ok());
  EXPECT_TRUE(tiled_->add(1, results_[1]).ok());
}

TEST_F(TileMessages, AResultsContentIsCheckedAsADecoderWould) {
  const std::string zero_rotation = altered_result([](TileResult& r) {
    ASSERT_FALSE(r.model.patches.empty());
    r.model.patches[0].world_from_codeword.rotation.setZero();
  });
  EXPECT_NE(add_error(zero_rotation).find("not a finite rotation"), std::string::npos);
  const std::string nan_point = altered_result([](TileResult& r) {
    ASSERT_FALSE(r.model.codebook.empty());
    r.model.codebook[0].points[0].y() = std::nanf("");
  });
  EXPECT_NE(add_error(nan_point).find("not finite"), std::string::npos);
  const std::string far_patch = altered_result([](TileResult& r) {
    r.model.patches[0].world_from_codeword.translation += Vec3f(100, 0, 0);
  });
  EXPECT_NE(add_error(far_patch).find("outside tile 0"), std::string::npos);
  const std::string other_radius = altered_result([](TileResult& r) { r.model.patch_radius *= 2; });
  EXPECT_NE(add_error(other_radius).find("patch radius"), std::string::npos);
}

}  // namespace
}  // namespace sspc::codec
