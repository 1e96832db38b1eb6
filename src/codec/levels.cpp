#include "codec/levels.hpp"

#include <array>

namespace sspc::codec {

namespace {

// Larger patches mean fewer transforms per point; a wider ε and τ let more patches share a
// code word; coarser quantisation costs distortion but few bits. The rows move all of them
// together, from near-lossless to small.
constexpr std::array<LevelParams, 10> kLevels = {{
    {24, 0.20f, 0.10f, 0.06f},
    {32, 0.30f, 0.15f, 0.08f},
    {40, 0.40f, 0.20f, 0.10f},
    {48, 0.50f, 0.25f, 0.12f},
    {56, 0.60f, 0.30f, 0.18f},
    {64, 0.70f, 0.35f, 0.25f},
    {80, 0.85f, 0.45f, 0.35f},
    {96, 1.00f, 0.55f, 0.50f},
    {128, 1.20f, 0.70f, 0.70f},
    {160, 1.50f, 0.90f, 1.00f},
}};

}  // namespace

LevelParams level_params(int level) { return kLevels[static_cast<std::size_t>(level)]; }

}  // namespace sspc::codec
