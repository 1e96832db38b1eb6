#include "encoder/levels.hpp"

#include <algorithm>
#include <array>
#include <bit>

namespace sspc::codec {

namespace {

// One row per level: patch size, descriptor radius ε, match threshold τ, code-word grid step.
// Measured with format version 3 on bunny, igea and dragon_scans against G-PCC's curves
// (scripts/rd_codec.sh, docs/RESULTS.md; the sweep behind this table is in FORMAT_NOTES.md,
// "Level table"):
// - the grid step sets the PSNR: one point per occupied cell scores an RMS of half a step, so
//   each halving gains 6 dB and costs 1.5–2.5 bits a point;
// - larger patches cost fewer transforms and fewer code-word borders: at the same step,
//   4096-point patches took igea from 3.66 (1024) and 5.08 (256) to about 3.2 bits a point at
//   62 dB, and the PSNR does not move; on the coarsest grids a code word keeps few points once
//   they are merged, so levels 7–9 take 8192 and 16384 (igea level 8: 1.72 → 1.53× G-PCC's
//   bits, dragon_scans 1.42 → 1.38×, bunny, with two patches left, 1.83 → 1.85×);
// - an instanced patch is off by about τ spacings RMS, its own code word by half a step, so a
//   match is accepted when it is no worse than the patch's own coding would be: τ = step / 2.
//   At the paper's τ of 1–2 spacings, instancing lost 0.3–1.6 dB for 5–10% of the bits at
//   steps below 1.4 spacings (above the resampling ceiling,
//   docs/FORMAT_NOTES.md "Level table");
// - on a range scan's regular lattice (its pitch is the spacing), a step of half the pitch
//   lays the samples in every other column of a frame turned to the lattice, a pattern the
//   occupancy contexts learn, while 0.38–0.45 spacings (2.2–2.6 columns a pitch) lay them in
//   patterns of period 5 or more: level 3 takes 0.5 spacings, not 0.4 (bunny 1.18 → 1.07×
//   G-PCC's bits at 59.5 dB instead of 61.4, igea 1.04 → 0.86×, dragon_scans, whose 15 scans
//   leave no lattice, 1.13 → 1.11×; FORMAT_NOTES.md, "Level table").
constexpr std::array<LevelParams, 10> kLevels = {{
    {4096, 0.50f, 0.04f, 0.08f},
    {4096, 0.50f, 0.07f, 0.14f},
    {4096, 0.60f, 0.12f, 0.25f},
    {4096, 0.60f, 0.25f, 0.50f},
    {4096, 0.70f, 0.30f, 0.60f},
    {4096, 0.70f, 0.42f, 0.85f},
    {4096, 0.80f, 0.60f, 1.20f},
    {8192, 0.90f, 0.85f, 1.70f},
    {16384, 1.00f, 1.25f, 2.50f},
    {16384, 1.20f, 1.80f, 3.60f},
}};

}  // namespace

// Large models take larger patches: at the same step the PSNR does not move with the patch size,
// and the transforms and code-word borders cost less. autzen (10.6M points), bits over G-PCC's at
// the same PSNR (docs/FORMAT_NOTES.md, "Level table"): level 5 1.19 with the row's 4096 points a
// patch, 1.16 with 16384 and 32768; level 7 1.174 with 8192, 1.157 with 16384, 1.143 with
// 32768; level 8 1.193 with 16384, 1.168 with 32768, 1.156 with 65536; level 9 1.10 with
// 16384, 1.054 with 32768, 1.028 with 65536 (version 6). A patch is random access's unit, and a
// warm patch decode takes time in proportion to its points (dragon_scans at level 5: 8.9 µs with
// 4096, 33 µs with 16384), so the unit grows with the model: the row's size for up to 2^22
// points (every scan of an object here: dragon_scans has 468,479), twice it up to 2^23, four
// times it beyond.
constexpr int kModelSizeOctaves = 2;  // at most 2^2 = 4 times the row's size
constexpr std::uint64_t kRowSizePoints = std::uint64_t{1} << 21;

// Past 2^23 points, the levels whose grid is coarser than kCoarseStep spacings (8 and 9) grow
// one octave more, to eight times the row's size (kMaxPatchPoints): one point a cell of 2.5 or
// 3.6 spacings keeps about a seventh or a thirteenth of a surface's points (autzen level 8: 5.45M
// of 10.65M in code words, merged), so their code words hold no more points than level 5's do
// at four times its row. autzen, bits over G-PCC's at the same PSNR: level 8 1.156 -> 1.139
// (1.469 -> 1.466 bits a point, 75.30 -> 75.35 dB), level 9 1.028 -> 1.007 (0.783 -> 0.772,
// 73.06 -> 73.12 dB). The price is random access at those levels, whose patches decode
// resampled: a warm patch 18 -> 37 ms at level 8 and 12 -> 23 ms at level 9, a whole decode
// 7.7 -> 8.7 s and 4.9 -> 5.3 s (decode_bench with SSPC_DECODE_BENCH_MODEL, one run each;
// docs/FORMAT_NOTES.md, "Level table").
constexpr float kCoarseStep = 2.0f;

LevelParams level_params(int level, std::uint64_t points) {
  LevelParams row = kLevels[static_cast<std::size_t>(level)];
  const std::uint64_t times = std::bit_floor(std::max<std::uint64_t>(points / kRowSizePoints, 1));
  int octaves = std::min(std::countr_zero(times), kModelSizeOctaves);
  if (octaves == kModelSizeOctaves && row.position_step > kCoarseStep) ++octaves;
  row.patch_points <<= octaves;
  return row;
}

}  // namespace sspc::codec
