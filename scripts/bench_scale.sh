#!/usr/bin/env bash
# Scale benchmark (issue: clouds larger than memory): how an encode under --memory-limit grows with
# the input, and what Dask workers buy.
#  1. autzen (10.6M points) encoded untiled, the reference rate; then under --memory-limit:
#     decoded PSNR of both (paper, `sspc eval`), bits per point, points/s, CPU seconds per
#     million points, peak resident memory (GNU time's maximum RSS, the process's own count).
#  2. Generated clouds of each size in SIZES (scripts/make_large_cloud.py: jittered, turned,
#     thinned copies of autzen on a grid, binary PLY) encoded under --memory-limit: the same
#     figures, so that their growth with size shows (10M against 100M).
#  3. autzen in tiles of DASK_TILE_POINTS on a local Dask cluster of 1, 2 and 4 worker
#     processes (python3 -m sspc.distributed, the input read in passes): wall seconds, the
#     speed-up over 1 worker, and whether the file is byte for byte the local encode's with the
#     same tiles. Tiles smaller than the limit allows, so that two workers have enough tiles to
#     share evenly. The worker counts run in turn ROUNDS times, and the table gives the median
#     wall time and the median of each round's speed-up over that round's 1 worker: the machine's
#     load drifts by about 10% from one run to the next, and a ratio of two runs side by side
#     is what survives it.
# Writes docs/results/scale_bench.csv and its table in docs/RESULTS.md ("Scale").
#
# Usage: scripts/bench_scale.sh [DATA_DIR]     (default ../shared/data)
#   SIZES="10M 100M" (SIZES= none; 1G needs about 36 GB of disk and 95 minutes of 2 cores)   LIMIT=2G   LEVEL=5
#   WORKERS="1 2 4"   ROUNDS=3   DASK_TILE_POINTS=1000000
#   WORK=/tmp/sspc_bench_scale (generated clouds are kept there between runs; a size whose cloud
#   and spill would not fit the free disk is skipped and named)
# Installs what it needs (a release build with the Python module, Debian's time, python3-numpy,
# python3-scipy, python3-distributed).
set -euo pipefail
cd "$(dirname "$0")/.."
data="${1:-../shared/data}"
SIZES="${SIZES-10M 100M}"  # set but empty (SIZES=) skips the generated clouds
LIMIT="${LIMIT:-2G}"
LEVEL="${LEVEL:-5}"
WORKERS="${WORKERS:-1 2 4}"
ROUNDS="${ROUNDS:-3}"
DASK_TILE_POINTS="${DASK_TILE_POINTS:-1000000}"
WORK="${WORK:-/tmp/sspc_bench_scale}"
if [ ! -f "$data/autzen.ply" ]; then
  echo "bench_scale: no $data/autzen.ply; nothing to measure" >&2
  exit 0
fi
bash scripts/install_deps.sh time python3-scipy
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build --target sspc_cli _sspc >/dev/null
sspc=build/sspc
# The Python the sspc module was built for (Debian's, which has numpy, scipy and Dask).
py=/usr/bin/python3
[ -x "$py" ] || py=python3
export PYTHONPATH="$PWD/build/python${PYTHONPATH:+:$PYTHONPATH}"
mkdir -p "$WORK" docs/results
csv=docs/results/scale_bench.csv
echo "run,input,points,tiles,workers,round,wall_s,cpu_s,points_per_s,cpu_s_per_mpoint,peak_rss_mb,rss_bytes_per_point,bits_per_point,psnr,same_bytes" > "$csv.tmp"
say() { if [ -t 2 ]; then echo "$@" >&2; fi; }

# One measured command: wall and CPU seconds and peak RSS from GNU time into $WORK/time.txt.
timed() { /usr/bin/time -f "%e %U %S %M" -o "$WORK/time.txt" "$@"; }
row() {  # run input points tiles workers round json_or_empty psnr same
  python3 - "$WORK/time.txt" "$@" >> "$csv.tmp" <<'PY'
import json, sys
wall, user, sys_, rss = open(sys.argv[1]).read().split()[-4:]
run, inp, points, tiles, workers, round_, stats, psnr, same = sys.argv[2:]
wall, cpu, rss = float(wall), float(user) + float(sys_), int(rss) * 1024
points = int(points)
bpp = json.load(open(stats))["bits_per_point"] if stats else ""
print(",".join(str(v) for v in [run, inp, points, tiles, workers, round_, f"{wall:.1f}", f"{cpu:.1f}",
                                f"{points / wall:.0f}", f"{cpu / points * 1e6:.2f}", f"{rss / 2**20:.0f}",
                                f"{rss / points:.1f}", f"{bpp:.4f}" if bpp != "" else "", psnr, same]))
PY
}
psnr() {  # source model -> paper PSNR of the decode
  "$sspc" --quiet decode "$2" "$WORK/decoded.ply" --force
  "$sspc" --quiet eval "$1" "$WORK/decoded.ply" --json | python3 -c 'import json,sys; print("%.3f" % json.load(sys.stdin)["psnr"])'
}
field() { python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))[sys.argv[2]])' "$1" "$2"; }

autzen="$data/autzen.ply"
n_autzen=$("$sspc" info "$autzen" --json | python3 -c 'import json,sys; print(json.load(sys.stdin)["points"])')
say "== autzen untiled"
timed "$sspc" --quiet encode "$autzen" "$WORK/untiled.sspc" -l "$LEVEL" --force --json > "$WORK/untiled.json"
row untiled autzen "$n_autzen" 0 0 "" "$WORK/untiled.json" "$(psnr "$autzen" "$WORK/untiled.sspc")" ""
say "== autzen --memory-limit $LIMIT"
timed "$sspc" --quiet encode "$autzen" "$WORK/limited.sspc" -l "$LEVEL" --memory-limit "$LIMIT" --force --json > "$WORK/limited.json"
row "memory-limit $LIMIT" autzen "$n_autzen" "$(field "$WORK/limited.json" tiles)" 0 "" "$WORK/limited.json" \
  "$(psnr "$autzen" "$WORK/limited.sspc")" ""

skipped=""
for size in $SIZES; do
  points=$(python3 -c 'import sys; s=sys.argv[1]; u={"K":1e3,"M":1e6,"G":1e9,"B":1e9}; print(int(float(s[:-1])*u[s[-1]]) if s[-1] in u else int(s))' "$size")
  cloud="$WORK/large_$size.ply"
  # The cloud (12 bytes a point), the tiles' spill (as much) and the code books' (about as much).
  need=$((points * 40))
  free=$(df --output=avail -B1 "$WORK" | tail -1)
  if [ ! -f "$cloud" ] && [ "$need" -gt "$free" ]; then
    skipped="$skipped $size"
    echo "bench_scale: $size points need about $((need >> 30)) GiB of disk, $((free >> 30)) GiB free: skipped" >&2
    continue
  fi
  if [ ! -f "$cloud" ]; then
    say "== generating $size points"
    "$py" scripts/make_large_cloud.py "$autzen" "$cloud.tmp" --points "$points" >&2
    mv "$cloud.tmp" "$cloud"
  fi
  say "== $size points --memory-limit $LIMIT"
  (cd "$WORK" && timed "$OLDPWD/$sspc" --quiet encode "$cloud" "$WORK/large.sspc" -l "$LEVEL" --memory-limit "$LIMIT" --force --json) > "$WORK/large.json"
  row "memory-limit $LIMIT" "generated $size" "$points" "$(field "$WORK/large.json" tiles)" 0 "" "$WORK/large.json" "" ""
done

say "== autzen in tiles of $DASK_TILE_POINTS, here"
timed "$sspc" --quiet encode "$autzen" "$WORK/tiles.sspc" -l "$LEVEL" --memory-limit "$LIMIT" \
  --tile-points "$DASK_TILE_POINTS" --force --json > "$WORK/tiles.json"
row "tile-points $DASK_TILE_POINTS" autzen "$n_autzen" "$(field "$WORK/tiles.json" tiles)" 0 "" "$WORK/tiles.json" \
  "$(psnr "$autzen" "$WORK/tiles.sspc")" ""
for round in $(seq "$ROUNDS"); do
  for workers in $WORKERS; do
    say "== autzen on Dask, $workers workers (round $round of $ROUNDS)"
    timed "$py" -m sspc.distributed encode -f "$autzen" "$WORK/dask.sspc" -l "$LEVEL" --memory-limit "$LIMIT" \
      --tile-points "$DASK_TILE_POINTS" --workers "$workers" --json > "$WORK/dask.json"
    same=no
    if cmp -s "$WORK/dask.sspc" "$WORK/tiles.sspc"; then same=yes; fi
    row dask autzen "$n_autzen" "$(field "$WORK/dask.json" tiles)" "$workers" "$round" "$WORK/dask.json" "" "$same"
  done
done
mv "$csv.tmp" "$csv"

python3 - "$csv" docs/RESULTS.md "$(git rev-parse --short HEAD)" "$LIMIT" "$LEVEL" "$skipped" "$(nproc)" <<'PY'
import csv, datetime, statistics, sys
sys.path.insert(0, "scripts")
from results_section import replace_section
path, results, commit, limit, level, skipped, cores = sys.argv[1:]
rows = list(csv.DictReader(open(path)))
lines = [f"Measured {datetime.date.today()} at commit {commit} by `scripts/bench_scale.sh` on {cores} cores, "
         f"level {level}; raw figures in `docs/results/scale_bench.csv`. Peak RSS is GNU time's maximum resident "
         "set (for Dask, that of the largest of the client and its worker processes, which it waits for). CPU s per million points is "
         "user + system time over the input's points. The generated clouds are jittered, turned and thinned copies "
         "of autzen (`scripts/make_large_cloud.py`). PSNR: the paper's, `sspc eval` of the decode against the "
         "input. Dask rows: medians over the rounds; the speed-up is the median of each round's ratio to that "
         "round's 1 worker, and its rounds are listed. Dask's CPU time is the client's and its "
         "workers' together.", ""]
if skipped.strip():
    lines += [f"Skipped for lack of disk: {skipped.strip()} points.", ""]
table = ["| run | input | points | tiles | workers | wall s | points/s | CPU s / M points | peak RSS MB | RSS B/point | bpp | PSNR dB | same bytes |",
         "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
dask = [r for r in rows if r["run"] == "dask"]
# Dask: one row a worker count, each figure the median over the rounds, and the speed-up the median
# of each round's ratio to that round's 1 worker (the runs side by side, under the same load).
one = {r["round"]: float(r["wall_s"]) for r in dask if r["workers"] == "1"}
summary = []
for workers in dict.fromkeys(r["workers"] for r in dask):
    runs = [r for r in dask if r["workers"] == workers]
    med = lambda key: statistics.median(float(r[key]) for r in runs)
    ratios = [one[r["round"]] / float(r["wall_s"]) for r in runs if r["round"] in one]
    label = workers + (f" ({statistics.median(ratios):.2f}×; rounds " +
                       ", ".join(f"{x:.2f}" for x in ratios) + ")" if ratios and workers != "1" else "")
    summary.append(dict(runs[0], workers=label, wall_s=f"{med('wall_s'):.1f}",
                        points_per_s=f"{med('points_per_s'):.0f}", cpu_s_per_mpoint=f"{med('cpu_s_per_mpoint'):.2f}",
                        peak_rss_mb=f"{med('peak_rss_mb'):.0f}", rss_bytes_per_point=f"{med('rss_bytes_per_point'):.1f}",
                        same_bytes="yes" if all(r["same_bytes"] == "yes" for r in runs) else "no"))
for r in [r for r in rows if r["run"] != "dask"] + summary:
    table.append("| " + " | ".join([r["run"], r["input"], f"{int(r['points']):,}", r["tiles"], r["workers"] if r["run"] == "dask" else "",
                                     r["wall_s"], f"{int(r['points_per_s']):,}", r["cpu_s_per_mpoint"], r["peak_rss_mb"],
                                     r["rss_bytes_per_point"], r["bits_per_point"], r["psnr"], r["same_bytes"]]) + " |")
lines += table
replace_section(results, "scale", "Scale: memory-limited and distributed encoding", lines)
print("\n".join(table))
PY
