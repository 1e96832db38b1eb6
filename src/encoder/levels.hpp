// Rate levels: one table of parameters, as zstd's levels are (paper §4.3: ε and τ set the
// rate). Level 0 keeps the most detail, level 9 makes the smallest files. Expert flags override
// single fields of the row.
#pragma once

#include <cstdint>
#include <optional>

namespace sspc::codec {

struct LevelParams {
  int patch_points = 0;        // expected points in one patch sphere
  float epsilon = 0;           // L1 radius in descriptor space (match distance)
  float tau = 0;               // MLS RMS error threshold, in units of the point spacing
  float position_step = 0;     // code-word coordinates' grid step, in point spacings
};

inline constexpr int kMinLevel = 0;
inline constexpr int kMaxLevel = 9;
inline constexpr int kDefaultLevel = 5;

// Requires kMinLevel ≤ level ≤ kMaxLevel. `points`, the model's points when known, scales the
// row's patch size for large models: the row's up to 2^22 points, twice it up to 2^23, four
// times it beyond, eight times at levels 8 and 9 (131072 points, kMaxPatchPoints).
LevelParams level_params(int level, std::uint64_t points = 0);

}  // namespace sspc::codec
