#!/usr/bin/env bash
# The whole test suite: install, then build and run every test twice, as a release build with
# warnings as errors and as an AddressSanitizer + UndefinedBehaviorSanitizer build (both replay
# the fuzz corpora, fuzz/), then the tests of the parallel stages (parallel loops, encoder,
# decoder, eval, renderer) in a ThreadSanitizer build.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh
jobs="$(nproc)"
# Each stage's wall time, so that the suite's growth shows where it comes from.
stage_start=$SECONDS
stage_done() { echo "== $1: $((SECONDS - stage_start)) s (total $SECONDS s)"; stage_start=$SECONDS; }

echo "== release build (-Werror)"
cmake -S . -B build-release -G Ninja -DCMAKE_BUILD_TYPE=Release -DSSPC_WERROR=ON
cmake --build build-release -j "$jobs"
stage_done "release build"
ctest --test-dir build-release --output-on-failure -j "$jobs" --timeout 600
stage_done "release tests"

# At -O1 with line tables only, like the TSan build below: the stack traces keep their lines and
# compiles faster than -O2 -g.
echo "== AddressSanitizer + UndefinedBehaviorSanitizer build"
cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSSPC_WERROR=ON \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" -DSSPC_SANITIZE=address,undefined -DSSPC_BUILD_BENCH=OFF \
  -DSSPC_BUILD_PYTHON=OFF
cmake --build build-asan -j "$jobs"
stage_done "ASan+UBSan build"
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 \
  ctest --test-dir build-asan --output-on-failure -j "$jobs" --timeout 900 -E '^(package|python)\.'
stage_done "ASan+UBSan tests"

# Only the test executables of the parallel stages are built (at -O1 with line tables only,
# which compiles a third faster), and only their multithreaded tests run, the slowest (a second
# encoder determinism run) left out: TSan slows code 5-15x, and the rest of the suite is
# single-threaded. src/core/parallel.hpp runs the loops on std::threads under TSan.
echo "== ThreadSanitizer build (parallel stages)"
cmake -S . -B build-tsan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSSPC_WERROR=ON \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" -DSSPC_SANITIZE=thread \
  -DSSPC_BUILD_BENCH=OFF -DSSPC_BUILD_APPS=OFF -DSSPC_BUILD_PYTHON=OFF
cmake --build build-tsan -j "$jobs" --target sspc_core_tests sspc_geometry_tests sspc_codec_tests \
  sspc_container_tests sspc_eval_tests sspc_render_tests
stage_done "TSan build"
TSAN_OPTIONS=halt_on_error=1:second_deadlock_stack=1 \
  ctest --test-dir build-tsan --output-on-failure -j "$jobs" --timeout 600 -R \
  '^(Parallel|Normals\.ResultIsBitIdentical|ModelBuilder\.SelfSimilar|DecoderTest|ContainerTest\.Deterministic|Evaluate\.SameResult|Renderer\.(SameImageOnAnyThreadCount|PagedScene|CompressedSphere)|BrickScene)\.'
stage_done "TSan tests"
