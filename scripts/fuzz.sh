#!/usr/bin/env bash
# Runs one libFuzzer target (fuzz/, docs/FUZZING.md) for SECONDS under ASan + UBSan (with
# float-cast-overflow: a float too large for the integer it is cast to).
#
#   scripts/fuzz.sh TARGET SECONDS     TARGET: ply_reader pcd_reader xyz_reader sspc_decoder
#                                              encode_roundtrip render tile_result
#
# Builds build-fuzz (clang, -fsanitize=fuzzer,address,undefined) when needed. The run works in
# fuzz-work/TARGET/: corpus/ starts as a copy of fuzz/corpus/TARGET and keeps what the fuzzer
# adds across runs (merge the interesting inputs back by hand), artifacts/ receives crashes,
# timeouts, leaks and out-of-memory inputs, fuzz.log the whole output. Exit status: libFuzzer's
# (0 when nothing was found). Environment: SSPC_FUZZ_BUILD_DIR (default build-fuzz),
# SSPC_FUZZ_WORK (default fuzz-work), SSPC_FUZZ_JOBS (build parallelism, default 2).
set -euo pipefail
cd "$(dirname "$0")/.."
if (($# != 2)); then
  sed -n 4,5p "$0" | sed 's/^# *//' >&2
  exit 2
fi
target="$1"
seconds="$2"
case "$target" in
  ply_reader | pcd_reader | xyz_reader | las_reader) max_len=4096 timeout=10 ;;
  sspc_decoder) max_len=8192 timeout=10 ;;
  encode_roundtrip) max_len=6001 timeout=30 ;;  # 1 options byte + 2000 points of 3 bytes
  render) max_len=12288 timeout=20 ;;            # .sspc models and small clouds
  tile_result) max_len=16384 timeout=20 ;;       # a selector byte and a tile job or result
  *)
    echo "fuzz.sh: unknown target '$target'" >&2
    exit 2
    ;;
esac

build="${SSPC_FUZZ_BUILD_DIR:-build-fuzz}"
if ! command -v clang++ >/dev/null; then
  echo "fuzz.sh: needs clang and libFuzzer (Debian: apt-get install clang libclang-rt-14-dev)" >&2
  exit 2
fi
if [ ! -f "$build/build.ninja" ]; then
  CC=clang CXX=clang++ cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DSSPC_WERROR=OFF -DSSPC_BUILD_FUZZ=ON -DSSPC_SANITIZE=address,undefined,float-cast-overflow \
    -DSSPC_BUILD_TESTS=OFF -DSSPC_BUILD_BENCH=OFF -DSSPC_BUILD_APPS=OFF
fi
cmake --build "$build" -j "${SSPC_FUZZ_JOBS:-2}" --target "${target}_fuzzer"

work="${SSPC_FUZZ_WORK:-fuzz-work}/$target"
mkdir -p "$work/corpus" "$work/artifacts"
cp -n fuzz/corpus/"$target"/* "$work/corpus/" 2>/dev/null || true
log="$work/fuzz.log"

echo "fuzzing $target for ${seconds}s; log: $log, artifacts: $work/artifacts/" >&2
status=0
ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:allocator_may_return_null=0" \
UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1" \
  "$build/fuzz/${target}_fuzzer" "$work/corpus" -max_total_time="$seconds" \
  -max_len="$max_len" -timeout="$timeout" -rss_limit_mb=2048 -malloc_limit_mb=2048 \
  -print_final_stats=1 -artifact_prefix="$work/artifacts/" >"$log" 2>&1 || status=$?

# The last status line (execs, cov, ft, corpus), the final counters and any finding.
grep -E '^#[0-9]+' "$log" | tail -n 1 || true
grep -E '^(stat::|Done )' "$log" || true
grep -E 'ERROR: (AddressSanitizer|LeakSanitizer|libFuzzer)|runtime error:|Test unit written' \
  "$log" | head -n 20 || true
echo "corpus: $(find "$work/corpus" -type f | wc -l) files; artifacts: $(find "$work/artifacts" -type f | wc -l)"
exit "$status"
