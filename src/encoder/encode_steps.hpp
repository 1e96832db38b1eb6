// The steps encode() and the tiled encoder (include/sspc/tiled_encoder.hpp) share: checking the
// options and the cloud, the build options a level gives, and the container's options and
// statistics for a built model.
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include "encoder/container_writer.hpp"
#include "encoder/model_builder.hpp"
#include "sspc/encoder.hpp"

namespace sspc::encoding {

Status check_options(const EncodeOptions& options);
// A cloud of `points` points within `bounds`: at least 16, fewer than 2^32, not all in one place.
Status check_size(std::uint64_t points, const Box3f& bounds);
// The level's row for a model of `points` points (codec::level_params), with the options'
// overrides.
codec::BuildOptions build_options(const EncodeOptions& options, std::uint64_t points);

// The weighted median of (value, weight) pairs: the value where the weights' running sum first
// reaches half their total.
double weighted_median(std::vector<std::pair<double, std::size_t>> v);

// The container's options for a model built with `build` whose spacing and patch radius came
// out as `build_stats` says, over a cloud within `bounds` keeping attribute `channels`.
struct ContainerChoice {
  codec::QuantOptions quant;
  float step = 0;  // the code words' grid step
};
ContainerChoice container_options(const EncodeOptions& options, const codec::BuildOptions& build,
                                  const codec::BuildStats& build_stats, const Box3f& bounds, std::uint8_t channels);

// The model-wide fields of what the writer writes, of a cloud with `origin` and `metadata`.
void set_model_fields(codec::EncodedModel& model, const EncodeOptions& options, const Vec3d& origin,
                      const CloudMetadata& metadata);

// `stats` completed from what was written.
void record_written(EncodeStats& stats, const codec::ContainerStats& written, const ContainerChoice& choice,
                    const codec::BuildStats& build_stats, std::uint64_t patches, std::uint64_t codewords);

}  // namespace sspc::encoding
