// What the compressed scene (src/render/compressed_renderer.cpp) exposes to its tests.
#pragma once

#include <cstdint>
#include <optional>

#include "sspc/compressed_model.hpp"
#include "sspc/point_cloud.hpp"
#include "sspc/status.hpp"

namespace sspc::render {

// The points of model.decode_all(), decoded patch by patch in parallel, or nullopt once they
// number more than `max_points` (the compressed scene's whole decode: a header's count of source
// points is data, and one that understates it must not make the scene decode beyond its budget).
StatusOr<std::optional<PointCloud>> decode_within(const CompressedModel& model, std::uint64_t max_points);

// The spacing a render of model.decode_all() takes (nominal_spacing of the decode), measured
// without holding the decode, as the compressed scene measures a model too large to decode
// whole: each sampled point's nearest sought within `margin`; nullopt where a sampled point's
// nearest lies farther or at its very position.
StatusOr<std::optional<double>> exact_decoded_spacing(const CompressedModel& model, float margin);

}  // namespace sspc::render
