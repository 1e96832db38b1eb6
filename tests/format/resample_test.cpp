// Resampling (docs/FORMAT.md, "Resampling"): the local fit reproduces planes and quadrics it is
// given exactly; a resampled model's whole, patch and box decodes relate as the stored ones do;
// the header byte is read, refused where it cannot be, and chosen by the writer's rule.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "container_test_models.hpp"
#include "encoder/container_writer.hpp"
#include "format/checksum.hpp"
#include "format/container_format.hpp"
#include "format/resample.hpp"
#include "sspc/compressed_model.hpp"

// A namespace of its own: the suite compiles as one unity file with container_test.cpp.
namespace sspc::codec::resample_test {
namespace {

// A square grid of `side` × `side` points of spacing `g` centred on the origin, lifted by f.
template <typename F>
std::vector<Vec3f> grid_surface(int side, float g, F f) {
  std::vector<Vec3f> points;
  for (int i = 0; i < side; ++i) {
    for (int j = 0; j < side; ++j) {
      const float x = static_cast<float>(i - side / 2) * g, y = static_cast<float>(j - side / 2) * g;
      points.emplace_back(x, y, f(x, y));
    }
  }
  return points;
}

std::uint32_t index_of(const std::vector<Vec3f>& points, const Vec3f& p) {
  for (std::uint32_t i = 0; i < points.size(); ++i) {
    if (points[i] == p) return i;
  }
  ADD_FAILURE() << "no such point";
  return 0;
}

TEST(Resample, PointsOfATiltedPlaneLieOnItSpreadOverTheCell) {
  const float g = 0.5f;
  const auto plane = [](float x, float y) { return 0.3f * x - 0.2f * y + 1.0f; };
  const std::vector<Vec3f> points = grid_surface(9, g, plane);
  const CodewordFit surface(points);
  const std::uint32_t centre = index_of(points, Vec3f(0, 0, 1));
  for (int m = 1; m <= kMaxResample; ++m) {
    SCOPED_TRACE("m = " + std::to_string(m));
    std::vector<Vec3f> out, normals;
    surface.resample(centre, m, g, out, &normals);
    ASSERT_EQ(out.size(), static_cast<std::size_t>(m * m));
    ASSERT_EQ(normals.size(), out.size());
    const Vec3f n = Vec3f(-0.3f, 0.2f, 1.0f).normalized();  // oriented towards +z
    Vec3f mean = Vec3f::Zero();
    for (std::size_t s = 0; s < out.size(); ++s) {
      EXPECT_NEAR(out[s].z(), plane(out[s].x(), out[s].y()), 1e-5f);
      EXPECT_GT(normals[s].dot(n), 1.0f - 1e-5f);
      mean += out[s];
      // Within the cell around the stored point: its tangent offsets are at most half a step.
      EXPECT_LE((out[s] - points[centre]).norm(), g * std::sqrt(0.5f) + 1e-5f);
    }
    mean /= static_cast<float>(out.size());
    EXPECT_LT((mean - points[centre]).norm(), 1e-5f);  // the split is centred on the point
    if (m >= 2) {
      // Neighbours in the split are g / m apart along the tangent through the frame's x axis.
      const Vec3f t1 = (Vec3f::UnitX() - n.x() * n).normalized();
      EXPECT_NEAR((out[static_cast<std::size_t>(m)] - out[0]).dot(t1), g / static_cast<float>(m), 1e-5f);
    }
  }
}

TEST(Resample, AQuadricIsFitted) {
  const float g = 0.25f;
  const auto bowl = [](float x, float y) { return 0.4f * x * x + 0.1f * x * y - 0.3f * y * y; };
  const std::vector<Vec3f> points = grid_surface(11, g, bowl);
  const CodewordFit surface(points);
  std::vector<Vec3f> out, normals;
  surface.resample(index_of(points, Vec3f(0, 0, 0)), 3, g, out, &normals);
  ASSERT_EQ(out.size(), 9u);
  for (std::size_t s = 0; s < out.size(); ++s) {
    const float x = out[s].x(), y = out[s].y();
    // Within 1e-4 (the tangent plane misses by up to 3e-3): the fit is made in the frame of the
    // neighbours' principal axes, slightly tilted, where the quadric is nearly but not exactly one.
    EXPECT_NEAR(out[s].z(), bowl(x, y), 1e-4f);
    // The fit's normal is the quadric's: (−∂z/∂x, −∂z/∂y, 1) normalised.
    const Vec3f n = Vec3f(-(0.8f * x + 0.1f * y), -(0.1f * x - 0.6f * y), 1.0f).normalized();
    EXPECT_GT(normals[s].dot(n), 1.0f - 1e-5f) << s;
  }
  // Unlike the tangent plane, the fit bends: the corner points leave z = 0.
  EXPECT_GT(std::abs(out[0].z()), 1e-4f);
}

TEST(Resample, TooFewPointsForAFitGiveTheTangentPlaneOfTheFrame) {
  const std::vector<Vec3f> points = {Vec3f(1, 2, 3), Vec3f(1.5f, 2, 3)};
  const CodewordFit surface(points);
  std::vector<Vec3f> out, normals;
  surface.resample(0, 2, 1.0f, out, &normals);
  ASSERT_EQ(out.size(), 4u);
  for (std::size_t s = 0; s < out.size(); ++s) {
    EXPECT_FLOAT_EQ(out[s].z(), 3.0f);
    EXPECT_EQ(normals[s], Vec3f::UnitZ());
  }
  EXPECT_FLOAT_EQ(out[0].x(), 0.75f);  // (½ / 2 − ½) steps from the point along x
  EXPECT_FLOAT_EQ(out[0].y(), 1.75f);
  EXPECT_FLOAT_EQ(out[3].x(), 1.25f);
  EXPECT_FLOAT_EQ(out[3].y(), 2.25f);
}

// A step of 0 or below float's normals (a hostile header's patch radius of 9e-44) makes the
// fit's slopes 0/0: every point and normal must still be finite, the normals unit.
TEST(Resample, AVanishingStepGivesFiniteNormals) {
  const std::vector<Vec3f> points = grid_surface(5, 0.5f, [](float x, float y) { return 0.1f * x + 0.2f * y; });
  const CodewordFit surface(points);
  for (const float step : {0.0f, 1e-45f, 4e-44f}) {
    std::vector<Vec3f> out, normals;
    surface.resample(index_of(points, Vec3f(0, 0, 0)), 2, step, out, &normals);
    ASSERT_EQ(normals.size(), 4u);
    for (std::size_t s = 0; s < out.size(); ++s) {
      EXPECT_TRUE(out[s].allFinite()) << "step " << step;
      EXPECT_TRUE(normals[s].allFinite()) << "step " << step;
      EXPECT_NEAR(normals[s].norm(), 1.0f, 1e-5f) << "step " << step;
    }
  }
}

TEST(Resample, TheWritersRuleResamplesCoarseGridsOnly) {
  EXPECT_EQ(resample_for(1000, 800, 2.0), 0);   // the decode holds 80%
  EXPECT_EQ(resample_for(1000, 500, 0.5), 0);   // a grid finer than the spacing: duplicates lost
  EXPECT_EQ(resample_for(1000, 600, 2.0), 2);   // ceil(sqrt(1.67))
  EXPECT_EQ(resample_for(1000, 150, 3.0), 3);   // ceil(sqrt(6.7))
  EXPECT_EQ(resample_for(1000, 10, 4.0), kMaxResample);
  EXPECT_EQ(resample_for(1000, 0, 4.0), kMaxResample);
}

test::ModelShape plane_shape() {
  test::ModelShape s;  // patch radius 4, centres 3 apart, 5 code words
  s.side = 30;
  return s;
}

QuantOptions options_with(int resample, int version = kFormatVersion) {
  QuantOptions o;
  o.patches_per_block = 8;
  o.codewords_per_block = 2;
  o.position_bits = 6;
  o.resample = resample;
  o.format_version = version;
  return o;
}

CompressedModel open_or_die(const std::string& bytes) {
  auto model = CompressedModel::from_bytes(bytes);
  EXPECT_TRUE(model.ok()) << model.status().to_string();
  return std::move(model).value();
}

std::string encode_or_die(const EncodedModel& m, const QuantOptions& o) {
  auto bytes = encode_container(m, o);
  EXPECT_TRUE(bytes.ok()) << bytes.status().to_string();
  return bytes.ok() ? *bytes : std::string();
}

TEST(Resample, WholePatchAndBoxDecodesAgree) {
  const EncodedModel m = test::make_plane_model(plane_shape());
  const CompressedModel stored = open_or_die(encode_or_die(m, options_with(0)));
  const CompressedModel model = open_or_die(encode_or_die(m, options_with(2)));
  EXPECT_EQ(stored.info().resample, 0);
  ASSERT_EQ(model.info().resample, 2);

  auto as_stored = stored.decode_all();
  auto all = model.decode_all();
  ASSERT_TRUE(as_stored.ok() && all.ok());
  ASSERT_EQ(all->size(), 4 * as_stored->size());
  ASSERT_TRUE(all->has_normals() && all->has_colours());
  // Each stored point's four stand in its cell, on the plane the code word's disc lies on.
  const float g = position_step(m.patch_radius, 6);
  for (std::size_t i = 0; i < as_stored->size(); ++i) {
    for (std::size_t s = 0; s < 4; ++s) {
      const std::size_t j = 4 * i + s;
      EXPECT_LE((all->positions[j] - as_stored->positions[i]).norm(), g) << i;
      EXPECT_EQ(all->colours[j], as_stored->colours[i]);
      EXPECT_GE(all->normals[j].dot(as_stored->normals[i]), 0.0f);
    }
  }

  // Decoded as stored on request, the same points as a file that asks for none.
  DecodeOptions plain;
  plain.resample = 0;
  auto without = model.decode_all(plain);
  ASSERT_TRUE(without.ok());
  EXPECT_TRUE(without->positions == as_stored->positions);
  // Overlap mode is never resampled.
  DecodeOptions overlap;
  overlap.overlap = true;
  auto whole = model.decode_all(overlap);
  auto whole_stored = stored.decode_all(overlap);
  ASSERT_TRUE(whole.ok() && whole_stored.ok());
  EXPECT_TRUE(whole->positions == whole_stored->positions);

  // The patches, in order, are the whole model.
  PointCloud joined;
  for (std::size_t k = 0; k < model.patch_count(); ++k) {
    auto part = model.decode_patch(k);
    ASSERT_TRUE(part.ok());
    joined.append(*part);
  }
  EXPECT_TRUE(joined.positions == all->positions);
  EXPECT_TRUE(joined.normals == all->normals);

  // A box holds exactly the whole model's points inside it, in order.
  const Box3f box(Vec3f(5.3f, 7.1f, -1), Vec3f(17.6f, 13.2f, 1));
  auto inside = model.decode_box(box);
  ASSERT_TRUE(inside.ok());
  std::vector<Vec3f> expected;
  for (const Vec3f& p : all->positions) {
    if (box.contains(p)) expected.push_back(p);
  }
  ASSERT_FALSE(expected.empty());
  EXPECT_TRUE(inside->positions == expected);
}

TEST(Resample, TheHeaderByteIsCheckedByVersion) {
  const EncodedModel m = test::make_plane_model(plane_shape());
  const auto set_byte = [](std::string bytes, int value) {
    bytes[71] = static_cast<char>(value);
    const auto span = std::as_bytes(std::span<const char>(bytes.data(), kHeaderCrcOffset));
    const std::uint32_t crc = crc32_of(span);
    for (int i = 0; i < 4; ++i) {
      bytes[kHeaderCrcOffset + static_cast<std::size_t>(i)] = static_cast<char>((crc >> (8 * i)) & 0xFF);
    }
    return bytes;
  };
  const std::string v4 = encode_or_die(m, options_with(0));
  EXPECT_EQ(open_or_die(set_byte(v4, 3)).info().resample, 3);
  auto refused = CompressedModel::from_bytes(set_byte(v4, kMaxResample + 1));
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("resample"), std::string::npos) << refused.status().message();
  const std::string v3 = encode_or_die(m, options_with(0, 3));
  refused = CompressedModel::from_bytes(set_byte(v3, 1));
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("71"), std::string::npos) << refused.status().message();
  // And the writer will not put it in a version 3 file.
  EXPECT_FALSE(encode_container(m, options_with(2, 3)).ok());
}

}  // namespace
}  // namespace sspc::codec::resample_test
