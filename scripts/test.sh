#!/usr/bin/env bash
# The whole test suite: install, then build what users run (the library, the CLI, the Python
# package, the benchmarks) as a release build with warnings as errors and test it end to end (the
# CLI's tests, pytest, the installed package); build everything as an AddressSanitizer +
# UndefinedBehaviorSanitizer build and run every test there (the unit suites, the CLI's again,
# the fuzz corpora of fuzz/); then the tests of the parallel stages (parallel loops, decoder,
# renderer and the encoder and normals it runs) in a ThreadSanitizer build.
#
# The unit suites run once, under the sanitizers, not also at -O3: CI must stay within 15
# minutes on 2 cores, and compiling and running them twice cost about 75 s of 1,118.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh
jobs="$(nproc)"
# Each stage's wall time, so that the suite's growth shows where it comes from.
stage_start=$SECONDS
stage_done() { echo "== $1: $((SECONDS - stage_start)) s (total $SECONDS s)"; stage_start=$SECONDS; }

# The libraries compile as unity batches (SSPC_UNITY_BUILD) here too: 166 CPU seconds against
# 381 one source at a time, which CI's 15 minutes cannot spare (it took 916 s). Each source on its
# own, as a missing #include would show, is what the default build compiles: the README's
# demo (scripts/demo.sh) and a developer's build.
echo "== release build (-Werror)"
cmake -S . -B build-release -G Ninja -DCMAKE_BUILD_TYPE=Release -DSSPC_WERROR=ON -DSSPC_UNITY_BUILD=ON
release_targets=(sspc_cli sspc_cli_tests sspc_example)
# The Embree example and reference renderer exist when CMake found Embree 3 (the test
# example.embree). The list is read whole first: grep -q leaving a pipe early fails it under pipefail.
build_targets="$(cmake --build build-release --target help)"
if grep -q '^sspc_embree_example:' <<<"$build_targets"; then release_targets+=(sspc_embree_example); fi
if grep -q '^SSPC_BUILD_PYTHON:BOOL=ON' build-release/CMakeCache.txt; then release_targets+=(_sspc); fi
if grep -q '^SSPC_BUILD_BENCH:BOOL=ON' build-release/CMakeCache.txt; then
  release_targets+=(eval_bench normals_bench io_bench decode_bench make_variants)
  if grep -q '^embree_discs_bench:' <<<"$build_targets"; then release_targets+=(embree_discs_bench); fi
fi
cmake --build build-release -j "$jobs" --target "${release_targets[@]}"
stage_done "release build"
ctest --test-dir build-release --output-on-failure -j "$jobs" --timeout 600 \
  -R '^(Cli|CliHelp|CliLas|CliReadWarnings|CliReliability|JsonKeys|Pipes|RateRegression|example|python|package)\.'
stage_done "release tests"

# At -O1 with line tables only, like the TSan build below: the stack traces keep their lines and
# compiles faster than -O2 -g. The sanitizer builds compile the libraries as unity batches
# (SSPC_UNITY_BUILD), as the release build above does, and include the Python module, whose tests run
# here too with the sanitizer runtimes preloaded (python/CMakeLists.txt). The programs around the library (tests, CLI, fuzz replays) compile
# at -Og (SSPC_DRIVER_FLAGS), the library they test at -O1 as before: their objects took 242 CPU
# seconds against 400, and the suite ran as fast (141 s against 146). At -O0 they compiled
# faster still, but the tests that instantiate Eigen's and nanoflann's templates in their own
# code ran 2-4 times slower (the suite 189 s). UBSan's alignment check is left out: it instruments every member access and
# reference binding, and cost 18-20% of this build's compile time (the CLI's unity batch 55.7 s
# with it, 45.5 s without; the I/O tests' 44.6 s and 37.5 s), which CI's 15 minutes cannot
# spare. Our decoders copy bytes with memcpy; the one cast of bytes to a struct reads the
# kernel's directory entries, which are 8-byte aligned. The other UBSan checks (overflow, shifts,
# bounds, casts, null) stay.
echo "== AddressSanitizer + UndefinedBehaviorSanitizer build"
cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSSPC_WERROR=ON \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG -fno-sanitize=alignment" \
  -DSSPC_SANITIZE=address,undefined -DSSPC_BUILD_BENCH=OFF \
  -DSSPC_BUILD_PYTHON=ON -DSSPC_UNITY_BUILD=ON -DSSPC_DRIVER_FLAGS=-Og
cmake --build build-asan -j "$jobs"
stage_done "ASan+UBSan build"
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 \
  ctest --test-dir build-asan --output-on-failure -j "$jobs" --timeout 1200 -E '^(package|RateRegression|example)\.|^python\.install$'
stage_done "ASan+UBSan tests"

# Only the test executables of the parallel stages are built (at -O1 with line tables only,
# which compiles a third faster): the loops themselves, the decoder's concurrent queries, and the
# renderer's, whose tests also encode models and estimate normals on many threads. Only their
# multithreaded tests run: TSan slows code 5-15x, and the rest of the suite is single-threaded.
# src/core/parallel.hpp runs the loops on std::threads under TSan.
echo "== ThreadSanitizer build (parallel stages)"
cmake -S . -B build-tsan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSSPC_WERROR=ON \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" -DSSPC_SANITIZE=thread \
  -DSSPC_BUILD_BENCH=OFF -DSSPC_BUILD_APPS=OFF -DSSPC_BUILD_PYTHON=OFF -DSSPC_UNITY_BUILD=ON \
  -DSSPC_DRIVER_FLAGS=-Og
cmake --build build-tsan -j "$jobs" --target sspc_core_tests sspc_container_tests sspc_render_tests
stage_done "TSan build"
TSAN_OPTIONS=halt_on_error=1:second_deadlock_stack=1 \
  ctest --test-dir build-tsan --output-on-failure -j "$jobs" --timeout 600 -R \
  '^(Parallel|DecoderTest|ContainerTest\.Deterministic|Renderer\.(SameImageOnAnyThreadCount|PagedScene|CompressedSphere)|BrickScene)\.'
stage_done "TSan tests"
