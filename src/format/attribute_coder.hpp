// Per-point attributes coded per patch against the decoded geometry (docs/FORMAT.md,
// "Attributes"): colours, LAS intensity, classification and returns, each channel of a patch in
// its own range-coder stream, so that one patch decodes its attributes alone (random access).
//
// Why per patch and not per code word: a code word is shared by every instance of it, so its
// colours would show the representative's paint on every copy (15.7 dB colour PSNR on a
// coloured bunny). Attributes belong to the place, the geometry to the code book.
//
// Each value is predicted from (at most) three of the nearest of the 64 points before it in the
// patch's decode order (a code word's columns run in raster order, so the window reaches the
// row before), the residual quantised with the channel's step and coded by an adaptive value
// model chosen by how much the references disagree (flat colour and edges get apart
// statistics). Classification and returns are lossless: "same as the nearest reference" is one
// modelled bit.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "sspc/point_cloud.hpp"
#include "sspc/status.hpp"

namespace sspc::codec {

inline constexpr std::uint8_t kChannelColour = 1u << 0;
inline constexpr std::uint8_t kChannelIntensity = 1u << 1;
inline constexpr std::uint8_t kChannelClassification = 1u << 2;
inline constexpr std::uint8_t kChannelReturns = 1u << 3;
inline constexpr std::uint8_t kKnownChannels = 0x0F;
inline constexpr int kChannelCount = 4;
inline constexpr int kMaxColourStep = 64;
inline constexpr int kMaxIntensityStep = 4096;

struct AttributeParams {
  std::uint8_t channels = 0;  // kChannel* bits
  int colour_step = 1;        // 1..kMaxColourStep; 1 is lossless
  int intensity_step = 1;     // 1..kMaxIntensityStep; 1 is lossless
  // Version 7's value models code lengths in unary (docs/FORMAT.md, "Range coding"): not stored,
  // it follows the file's format version (the reader and the writer set it).
  bool unary_lengths = false;
  int channel_count() const;
};

// The reference points of each point of a patch (docs/FORMAT.md, "Attributes", Prediction).
struct AttributeReferences {
  std::vector<std::array<std::uint32_t, 3>> index;
  std::vector<std::uint8_t> count;
  void find(std::span<const Vec3f> positions);
};

// One channel's stream for the patch's points `values` (the cloud's positions are the decoded
// positions in decode order; the channel's arrays must be filled). Lossy channels quantise.
std::string encode_attribute_stream(std::uint8_t channel, const AttributeParams& params,
                                    const AttributeReferences& refs, const PointCloud& values);

// Decodes one channel's stream for the `refs.count.size()` points of a patch and appends the
// values to `out`'s arrays of that channel (colours, las.intensity, las.classification, or
// las.return_number and las.number_of_returns). Fails (kCorrupt) on a stream that is not used
// exactly or decodes an impossible value.
Status decode_attribute_stream(std::uint8_t channel, const AttributeParams& params,
                               const AttributeReferences& refs, std::span<const std::byte> stream,
                               PointCloud& out);

// The channels `cloud` has values for.
std::uint8_t channels_present(const PointCloud& cloud);

}  // namespace sspc::codec
