// The order the encoder takes a cloud's points in (codec::point_order, src/encoder/spatial_order.hpp):
// Morton order, ties by position, so that the same points in any order give the same file,
// untiled and tiled; and PointCloud::select and PointCloud::concatenate, which reorder and join
// clouds with every per-point array.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "encoder/spatial_order.hpp"
#include "sspc/encoder.hpp"
#include "sspc/synthetic.hpp"
#include "test_util.hpp"

namespace sspc::codec {
namespace {

// A torus with per-point colours and intensities, so that attributes must follow their points.
PointCloud attributed_torus() {
  PointCloud cloud = synthetic::torus(6000, 1.0, 0.35, {.seed = 5, .normals = true});
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Vec3f& p = cloud.positions[i];
    cloud.colours.push_back({static_cast<std::uint8_t>(128 + 100 * p.x()), static_cast<std::uint8_t>(128 + 100 * p.y()),
                             static_cast<std::uint8_t>(128 + 300 * p.z())});
    cloud.las.intensity.push_back(static_cast<std::uint16_t>(1000 + 500 * p.z()));
  }
  return cloud;
}

std::string file_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::vector<std::uint32_t> shuffled(std::size_t n, unsigned seed) {
  std::vector<std::uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  std::shuffle(order.begin(), order.end(), std::mt19937(seed));
  return order;
}

TEST(PointOrder, SelectCarriesEveryArrayWithItsPoint) {
  const PointCloud cloud = attributed_torus();
  const std::vector<std::uint32_t> order = shuffled(cloud.size(), 1);
  const PointCloud moved = cloud.select(order);
  ASSERT_EQ(moved.size(), cloud.size());
  ASSERT_TRUE(moved.validate().ok());
  for (std::size_t i = 0; i < order.size(); ++i) {
    const std::uint32_t from = order[i];
    ASSERT_EQ(moved.positions[i], cloud.positions[from]);
    ASSERT_EQ(moved.normals[i], cloud.normals[from]);
    ASSERT_EQ(moved.colours[i], cloud.colours[from]);
    ASSERT_EQ(moved.las.intensity[i], cloud.las.intensity[from]);
  }
  // A subset, repeats allowed.
  const std::uint32_t some[] = {7, 7, 0};
  const PointCloud picked = cloud.select(some);
  ASSERT_EQ(picked.size(), 3u);
  EXPECT_EQ(picked.positions[1], cloud.positions[7]);
  EXPECT_EQ(picked.las.intensity[2], cloud.las.intensity[0]);
}

TEST(PointOrder, ConcatenateJoinsPartsWithEveryArray) {
  PointCloud cloud = attributed_torus();
  cloud.origin = Vec3d(1, 2, 3);
  std::vector<PointCloud> parts;
  parts.push_back(PointCloud());  // an empty part first: it carries no arrays
  for (std::size_t begin = 0, size = 1; begin < cloud.size(); begin += size, size = 3 * size + 1) {
    parts.push_back(cloud.slice(begin, std::min(cloud.size(), begin + size)));
  }
  parts.push_back(PointCloud());
  parts[0].origin = cloud.origin;
  const PointCloud joined = PointCloud::concatenate(std::move(parts));
  ASSERT_TRUE(joined.validate().ok());
  EXPECT_EQ(joined.positions, cloud.positions);
  EXPECT_EQ(joined.normals, cloud.normals);
  EXPECT_EQ(joined.colours, cloud.colours);
  EXPECT_EQ(joined.las.intensity, cloud.las.intensity);
  EXPECT_EQ(joined.origin, cloud.origin);
  EXPECT_TRUE(PointCloud::concatenate({}).empty());
}

TEST(PointOrder, IsAPermutationInMortonOrderWhateverTheInputOrder) {
  const PointCloud cloud = attributed_torus();
  const std::vector<std::uint32_t> order = point_order(cloud.positions);
  std::vector<std::uint32_t> sorted = order;
  std::sort(sorted.begin(), sorted.end());
  std::vector<std::uint32_t> all(cloud.size());
  std::iota(all.begin(), all.end(), 0u);
  ASSERT_EQ(sorted, all);
  Box3f bounds = cloud.bounding_box();
  for (std::size_t i = 1; i < order.size(); ++i) {
    ASSERT_LE(morton_code(cloud.positions[order[i - 1]], bounds), morton_code(cloud.positions[order[i]], bounds));
  }
  // The shuffled cloud's order names the same positions in the same sequence.
  const PointCloud moved = cloud.select(shuffled(cloud.size(), 2));
  const std::vector<std::uint32_t> again = point_order(moved.positions);
  for (std::size_t i = 0; i < order.size(); ++i) ASSERT_EQ(moved.positions[again[i]], cloud.positions[order[i]]);
}

TEST(PointOrder, TheSamePointsInAnyOrderGiveTheSameFile) {
  test::TempDir dir;
  const PointCloud cloud = attributed_torus();
  const PointCloud moved = cloud.select(shuffled(cloud.size(), 3));
  EncodeOptions untiled;
  untiled.level = 4;
  untiled.patch_points = 256;
  EncodeOptions tiled = untiled;
  tiled.tile_points = 1500;
  for (const EncodeOptions& options : {untiled, tiled}) {
    SCOPED_TRACE(options.tile_points > 0 ? "tiled" : "untiled");
    auto a = encode(cloud, dir.path() / "a.sspc", options);
    auto b = encode(moved, dir.path() / "b.sspc", options);
    ASSERT_TRUE(a.ok() && b.ok()) << a.status().to_string() << b.status().to_string();
    EXPECT_EQ(a->tiles, b->tiles);
    const std::string first = file_bytes(dir.path() / "a.sspc"), second = file_bytes(dir.path() / "b.sspc");
    EXPECT_EQ(first.size(), second.size());
    EXPECT_TRUE(first == second);  // not EXPECT_EQ: it would print both files
  }
}

}  // namespace
}  // namespace sspc::codec
