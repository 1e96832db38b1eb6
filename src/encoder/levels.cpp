#include "encoder/levels.hpp"

#include <array>

namespace sspc::codec {

namespace {

// One row per level: patch size, descriptor radius ε, match threshold τ, code-word grid step.
// Measured on dragon_scans (scripts/rd_codec.sh, docs/RESULTS.md), what moves the rate is:
// - the grid step: a point costs about 3 bits more per halving, and the PSNR gains 3–5 dB
//   while the step is above a quarter of the spacing (below that, sampling noise dominates);
// - the patch size: each patch costs about 55 bits of transform, so 256-point patches spend
//   0.9 bpp where 64-point ones spend 3.1, with the same PSNR at the same step;
// - τ, the RMS nearest-point distance a replaced patch may have: τ = 1 spacing replaces 20–25%
//   of the patches on scans (a 15–20% smaller file for 1–4 dB), τ = 1.6 about half, at the cost
//   of the decoded density, which the 10% point-count rule bounds.
// Level 5, the default, is the one that reaches 65 dB on dragon_scans.
constexpr std::array<LevelParams, 10> kLevels = {{
    {64, 0.50f, 0.40f, 0.10f},
    {96, 0.50f, 0.50f, 0.20f},
    {128, 0.60f, 0.60f, 0.30f},
    {192, 0.60f, 0.60f, 0.45f},
    {256, 0.70f, 0.80f, 0.60f},
    {256, 0.70f, 1.00f, 0.80f},
    {256, 0.80f, 1.20f, 1.10f},
    {256, 0.90f, 1.40f, 1.40f},
    {384, 1.00f, 1.60f, 1.60f},
    {512, 1.20f, 2.00f, 2.00f},
}};

}  // namespace

LevelParams level_params(int level) { return kLevels[static_cast<std::size_t>(level)]; }

}  // namespace sspc::codec
