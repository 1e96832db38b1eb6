#!/usr/bin/env bash
# Many files as one cloud, at survey scale: a generated cloud (scripts/make_large_cloud.py, copies
# of autzen) cut into TILES files of consecutive points, encoded from their folder under
# --memory-limit, against the same points as one file under the same limit. Measures each run's
# wall and CPU seconds and peak resident memory (GNU time's maximum RSS) and checks that the two
# models are byte for byte the same. Writes docs/results/tiles_bench.csv.
#
# Usage: scripts/bench_tiles.sh [DATA_DIR]     (default ../shared/data)
#   POINTS=100M   TILES=1000   LIMIT=2G   LEVEL=5   WORK=/tmp/sspc_bench_tiles (the cloud and its
#   tiles are kept there between runs: 2.4 GB at 100M points)   BUILD=build (a release build with
#   the Python module, made when missing)
set -euo pipefail
cd "$(dirname "$0")/.."
data="${1:-../shared/data}"
POINTS="${POINTS:-100M}"
TILES="${TILES:-1000}"
LIMIT="${LIMIT:-2G}"
LEVEL="${LEVEL:-5}"
WORK="${WORK:-/tmp/sspc_bench_tiles}"
BUILD="${BUILD:-build}"
if [ ! -f "$data/autzen.ply" ]; then
  echo "bench_tiles: no $data/autzen.ply; nothing to measure" >&2
  exit 0
fi
bash scripts/install_deps.sh time python3-scipy
if [ ! -x "$BUILD/sspc" ]; then
  cmake -S . -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build "$BUILD" --target sspc_cli _sspc >/dev/null
fi
sspc="$BUILD/sspc"
py=/usr/bin/python3
[ -x "$py" ] || py=python3
export PYTHONPATH="$PWD/$BUILD/python${PYTHONPATH:+:$PYTHONPATH}"
mkdir -p "$WORK" docs/results
points=$("$py" -c "import sys; t=sys.argv[1]; m={'K':1e3,'M':1e6,'G':1e9}; print(int(float(t.rstrip('KMG'))*m.get(t[-1],1)))" "$POINTS")
big="$WORK/cloud_$POINTS.ply"
tiles="$WORK/tiles_${POINTS}_$TILES"
if [ ! -f "$big" ]; then "$py" scripts/make_large_cloud.py "$data/autzen.ply" "$big" --points "$points"; fi
if [ ! -d "$tiles" ]; then
  # Consecutive runs of records, each a binary PLY of its own: concatenated, the big file's points.
  "$py" - "$big" "$tiles" "$TILES" <<'PY'
import os, sys
src, out, count = sys.argv[1], sys.argv[2], int(sys.argv[3])
with open(src, "rb") as f:
    header = b""
    while not header.endswith(b"end_header\n"):
        header += f.readline()
    lines = header.decode().split("\n")
    n = next(int(l.split()[2]) for l in lines if l.startswith("element vertex"))
    record = 12  # float32 x, y, z (make_large_cloud.py)
    os.makedirs(out + ".part")
    for k in range(count):
        m = n * (k + 1) // count - n * k // count
        head = header.decode().replace(f"element vertex {n}", f"element vertex {m}").encode()
        with open(os.path.join(out + ".part", f"tile_{k:05d}.ply"), "wb") as t:
            t.write(head)
            t.write(f.read(m * record))
os.rename(out + ".part", out)
PY
fi
csv=docs/results/tiles_bench.csv
echo "input,files,points,limit,wall_s,cpu_s,peak_rss_mib,bits_per_point,same_bytes" > "$csv.tmp"
run() {  # name input... -> a model in $WORK, a row in the CSV
  local name="$1"
  shift
  /usr/bin/time -f "%e %U %S %M" -o "$WORK/time_$name.txt" \
    "$sspc" encode -q -f --json -l "$LEVEL" --memory-limit "$LIMIT" "$@" "$WORK/$name.sspc" > "$WORK/$name.json"
}
run tiles "$tiles"
run whole "$big"
same=no
cmp -s "$WORK/tiles.sspc" "$WORK/whole.sspc" && same=yes
# Each run's figures, from its JSON and GNU time.
"$py" - "$WORK" "$csv.tmp" "$same" "$LIMIT" <<'PY'
import json, os, sys
work, csv, same, limit = sys.argv[1:]
for name in ("tiles", "whole"):
    stats = json.load(open(os.path.join(work, name + ".json")))
    wall, user, system, rss = open(os.path.join(work, f"time_{name}.txt")).read().split()[-4:]
    with open(csv, "a") as out:
        out.write(f"{name},{stats['input_files']},{stats['points']},{limit},{wall},{float(user) + float(system):.1f},"
                  f"{int(rss) / 1024:.0f},{stats['bits_per_point']:.4f},{same}\n")
PY
mv "$csv.tmp" "$csv"
cat "$csv"
