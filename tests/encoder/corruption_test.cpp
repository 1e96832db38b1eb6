// A small file from the real encoder, each byte corrupted in turn (xor 0xFF, then + 1): opening
// and fully decoding it must fail with a kCorrupt (or kUnsupported, for the version field)
// Status, or give exactly the original decode. Never a crash, never different points silently.
// Complements ContainerTest.EveryFlippedByteIsCaughtOrHarmless, which flips one bit pattern of
// a hand-built model.
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <string>

#include "sspc/compressed_model.hpp"
#include "sspc/encoder.hpp"
#include "sspc/synthetic.hpp"
#include "test_util.hpp"

namespace sspc {
namespace {

bool same_cloud(const PointCloud& a, const PointCloud& b) {
  return a.positions == b.positions && a.normals == b.normals && a.colours == b.colours;
}

// A few-KB file with normals and colours, so that every section and payload plane is present.
std::string encode_small_file() {
  test::TempDir dir;
  PointCloud cloud = synthetic::bumps(600, 1.0, 2, 0.1);
  cloud.colours.resize(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    cloud.colours[i] = Rgb8{static_cast<std::uint8_t>(i), static_cast<std::uint8_t>(3 * i), 9};
  }
  EncodeOptions options;
  options.level = 9;
  options.patch_points = 32;
  options.store_normals = true;
  const auto path = dir.path() / "small.sspc";
  auto stats = encode(cloud, path, options);
  EXPECT_TRUE(stats.ok()) << stats.status().to_string();
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// What a reader of `bytes` sees: an error Status, or the whole decode.
StatusOr<PointCloud> open_and_decode(const std::string& bytes) {
  auto model = CompressedModel::from_bytes(bytes);
  if (!model.ok()) return model.status();
  SSPC_RETURN_IF_ERROR(model->verify());
  auto all = model->decode_all();
  if (!all.ok()) return all.status();
  // Random access must agree with the decode of the whole model.
  PointCloud joined;
  for (std::size_t k = 0; k < model->patch_count(); ++k) {
    SSPC_ASSIGN_OR_RETURN(PointCloud part, model->decode_patch(k));
    joined.positions.insert(joined.positions.end(), part.positions.begin(), part.positions.end());
    joined.normals.insert(joined.normals.end(), part.normals.begin(), part.normals.end());
    joined.colours.insert(joined.colours.end(), part.colours.begin(), part.colours.end());
  }
  EXPECT_TRUE(same_cloud(joined, *all));
  return all;
}

TEST(CorruptionTest, EveryCorruptedByteIsReportedOrHarmless) {
  const std::string bytes = encode_small_file();
  ASSERT_GT(bytes.size(), 500u);
  ASSERT_LT(bytes.size(), 8000u);
  const StatusOr<PointCloud> original = open_and_decode(bytes);
  ASSERT_TRUE(original.ok()) << original.status().to_string();
  ASSERT_TRUE(original->has_normals() && original->has_colours());

  int reported = 0, harmless = 0;
  for (const int change : {0xFF, 1}) {
    for (std::size_t i = 0; i < bytes.size(); ++i) {
      std::string corrupted = bytes;
      const auto b = static_cast<unsigned char>(corrupted[i]);
      corrupted[i] = static_cast<char>(change == 0xFF ? b ^ 0xFF : (b + 1) & 0xFF);
      const StatusOr<PointCloud> r = open_and_decode(corrupted);
      if (r.ok()) {
        ++harmless;
        EXPECT_TRUE(same_cloud(*r, *original)) << "byte " << i << " changed the decode silently";
      } else {
        ++reported;
        const StatusCode code = r.status().code();
        EXPECT_TRUE(code == StatusCode::kCorrupt || code == StatusCode::kUnsupported)
            << "byte " << i << ": " << r.status().to_string();
        EXPECT_FALSE(r.status().message().empty());
      }
    }
  }
  // The CRCs cover every byte of the file.
  EXPECT_EQ(harmless, 0);
  EXPECT_EQ(reported, static_cast<int>(2 * bytes.size()));
}

}  // namespace
}  // namespace sspc
