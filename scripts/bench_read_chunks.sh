#!/usr/bin/env bash
# Reading in chunks (read_point_cloud_chunks): the peak resident memory of reading a binary PLY
# larger than the chunks (POINTS float x y z, 1.2 GB at the default 100 M, generated into WORK and
# deleted afterwards) in chunks of CHUNK points, against reading it whole; and the read rate on
# autzen.ply, whole against in chunks (median of REPEATS runs each). Both by bench/read_chunks.cpp
# (`read_chunks`), its peak memory as /usr/bin/time reports it (`%M`, the maximum resident set).
# The generated file sits in the page cache when it is read: the figures are the reader's, not
# the disk's. Writes the section "Reading in chunks" of docs/RESULTS.md.
#
# Usage: scripts/bench_read_chunks.sh [DATA_DIR]     (default ../shared/data)
#   POINTS=100000000   CHUNK=1000000   REPEATS=5   WHOLE=1 (0: skip the whole read of the big file)
#   BUILD=build   WORK=/tmp/sspc_bench_read_chunks
set -euo pipefail
cd "$(dirname "$0")/.."
data="${1:-../shared/data}"
POINTS="${POINTS:-100000000}"
CHUNK="${CHUNK:-1000000}"
REPEATS="${REPEATS:-5}"
WHOLE="${WHOLE:-1}"
BUILD="${BUILD:-build}"
WORK="${WORK:-/tmp/sspc_bench_read_chunks}"
# Debian's python3 has numpy (scripts/install_deps.sh); another python3 earlier on PATH may not.
PY=python3
if [ -x /usr/bin/python3 ]; then PY=/usr/bin/python3; fi

bash scripts/install_deps.sh time
cmake -S . -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$BUILD" --target read_chunks >/dev/null
reader="$BUILD/bench/read_chunks"
mkdir -p "$WORK"
big="$WORK/big.ply"
trap 'rm -f "$big"' EXIT

# One run: read_chunks's JSON object with the peak memory /usr/bin/time saw added.
run() {
  /usr/bin/time -f "%M" -o "$WORK/rss" "$reader" "$@" >"$WORK/run.json"
  python3 - "$WORK/run.json" "$WORK/rss" <<'EOF'
import json, sys
run = json.load(open(sys.argv[1]))
run["time_max_rss_mib"] = int(open(sys.argv[2]).read().split()[-1]) / 1024
print(json.dumps(run))
EOF
}

# Written a few million points at a time, so that the generator's memory stays small as well.
"$PY" - "$big" "$POINTS" <<'EOF'
import sys
import numpy as np
path, n = sys.argv[1], int(sys.argv[2])
rng = np.random.default_rng(1)
with open(path, "wb") as f:
    f.write((f"ply\nformat binary_little_endian 1.0\nelement vertex {n}\n"
             "property float x\nproperty float y\nproperty float z\nend_header\n").encode())
    for begin in range(0, n, 5_000_000):
        m = min(5_000_000, n - begin)
        (rng.random((m, 3), dtype=np.float32) * np.float32(100)).astype("<f4").tofile(f)
EOF
runs="$WORK/runs.jsonl"
: >"$runs"
run "$big" "$CHUNK" | tee -a "$runs"
if [ "$WHOLE" = 1 ]; then run "$big" whole | tee -a "$runs"; fi
rm -f "$big"

autzen="$data/autzen.ply"
if [ -f "$autzen" ]; then
  for _ in $(seq "$REPEATS"); do
    run "$autzen" whole | tee -a "$runs"
    run "$autzen" "$CHUNK" | tee -a "$runs"
  done
else
  echo "bench_read_chunks: $autzen missing, its rates skipped" >&2
fi

python3 - "$runs" docs/RESULTS.md "$(git rev-parse --short HEAD)" "$(nproc)" "$big" <<'EOF'
import datetime, json, os, statistics, sys
sys.path.insert(0, "scripts")
from results_section import replace_section
path, results, commit, cores, big = sys.argv[1:]
runs = [json.loads(line) for line in open(path)]
lines = [f"Measured {datetime.date.today()} at commit {commit} on {cores} cores by "
         "`scripts/bench_read_chunks.sh` (`bench/read_chunks.cpp`): `read_point_cloud_chunks`, the "
         "sink counting the points and dropping each chunk, against `read_point_cloud`. Peak memory "
         "is the process's maximum resident set (`/usr/bin/time`); the files are in the page cache.",
         "", "| file | points | file MB | read | chunks | seconds | M points/s | peak MiB |",
         "|---|---:|---:|---|---:|---:|---:|---:|"]
def row(name, size_mb, group):
    mode = group[0]["mode"]
    seconds = statistics.median(r["seconds"] for r in group)
    rate = statistics.median(r["points_per_second"] for r in group) / 1e6
    rss = max(r["time_max_rss_mib"] for r in group)
    how = "whole" if mode == "whole" else f"chunks of {int(mode):,}"
    runs_note = f" (median of {len(group)})" if len(group) > 1 else ""
    lines.append(f"| {name} | {group[0]['points']:,} | {size_mb:,.0f} | {how}{runs_note} | "
                 f"{group[0]['chunks']} | {seconds:.3f} | {rate:.1f} | {rss:.0f} |")
generated = [r for r in runs if r["path"] == big]
for r in generated:
    row("generated, float x y z", r["points"] * 12 / 1e6, [r])
autzen = [r for r in runs if r["path"] != big]
for mode in dict.fromkeys(r["mode"] for r in autzen):
    group = [r for r in autzen if r["mode"] == mode]
    row("autzen.ply", os.path.getsize(group[0]["path"]) / 1e6, group)
replace_section(results, "read-chunks", "Reading in chunks", lines)
print("\n".join(lines))
EOF
