#!/usr/bin/env bash
# A distributed encode that dies half way resumes to the uninterrupted run's bytes (python3 -m
# sspc.distributed, "Resuming" in docs/CLI.md), on a real scan:
#  1. the reference: `sspc encode` of the scan in tiles of TILE_POINTS on one machine;
#  2. a Dask scheduler and one worker started on 127.0.0.1, the encode sent to them, and the
#     scheduler killed (SIGKILL) once half the tiles' results are kept; then the same command on
#     a local cluster: it must resume and write the reference's bytes;
#  3. the client itself killed (SIGKILL) half way, then the same command again: the same check.
# Prints each step's outcome, the tiles kept and resumed, and the seconds of each run.
#
# Usage: scripts/resume_check.sh [SCAN]     (default ../shared/data/autzen.ply)
#   TILE_POINTS=1000000   LEVEL=5   WORK=/tmp/sspc_resume   BUILD=build (made when missing)
set -euo pipefail
cd "$(dirname "$0")/.."
scan="${1:-../shared/data/autzen.ply}"
TILE_POINTS="${TILE_POINTS:-1000000}"
LEVEL="${LEVEL:-5}"
WORK="${WORK:-/tmp/sspc_resume}"
BUILD="${BUILD:-build}"
if [ ! -f "$scan" ]; then
  echo "resume_check: no $scan; nothing to check" >&2
  exit 0
fi
bash scripts/install_deps.sh
if [ ! -x "$BUILD/sspc" ]; then
  cmake -S . -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build "$BUILD" --target sspc_cli _sspc >/dev/null
fi
py=/usr/bin/python3
[ -x "$py" ] || py=python3
export PYTHONPATH="$PWD/$BUILD/python${PYTHONPATH:+:$PYTHONPATH}"
rm -rf "$WORK"
mkdir -p "$WORK"
out="$WORK/dask.sspc"
staging="$WORK/.dask.sspc.sspc-tiles"
pids=()
cleanup() { for p in "${pids[@]}"; do kill -9 "$p" 2>/dev/null || true; done; }
trap cleanup EXIT

start=$SECONDS
"$BUILD/sspc" encode -q "$scan" "$WORK/reference.sspc" -l "$LEVEL" --tile-points "$TILE_POINTS"
echo "reference: $((SECONDS - start)) s"
tiles=$("$py" -c "import sspc,sys; print(sspc.TiledEncoder(sys.argv[1], tile_points=int(sys.argv[2]), level=int(sys.argv[3]), work_dir=sys.argv[4]).tile_count)" \
  "$scan" "$TILE_POINTS" "$LEVEL" "$WORK")
half=$((tiles / 2))
echo "tiles: $tiles; killing at $half kept"

kept() { find "$staging" -name '*.result' 2>/dev/null | wc -l; }
wait_for_half() {  # pid: until half the tiles are kept or the process ends
  while kill -0 "$1" 2>/dev/null && [ "$(kept)" -lt "$half" ]; do sleep 0.5; done
}
encode() {  # the distributed command, its arguments after the common ones
  "$py" -m sspc.distributed encode "$scan" "$out" -l "$LEVEL" --tile-points "$TILE_POINTS" "$@"
}
resume() {  # name: the same command on a local cluster, then the check
  local t0=$SECONDS
  encode --workers 2 --json > "$WORK/resume.json"
  local resumed
  resumed=$("$py" -c "import json,sys; print(json.load(open(sys.argv[1]))['resumed_tiles'])" "$WORK/resume.json")
  if cmp -s "$out" "$WORK/reference.sspc"; then same=yes; else same=no; fi
  echo "$1: resumed $resumed of $tiles tiles in $((SECONDS - t0)) s; same bytes as the reference: $same"
  [ "$same" = yes ] && [ ! -e "$staging" ]
  rm -f "$out"
}

# 2. The scheduler killed.
port=$("$py" -c "import socket; s=socket.socket(); s.bind(('127.0.0.1', 0)); print(s.getsockname()[1])")
"$py" -m distributed.cli.dask_scheduler --host 127.0.0.1 --port "$port" --no-dashboard > "$WORK/scheduler.log" 2>&1 &
scheduler=$!
pids+=("$scheduler")
sleep 3
"$py" -m distributed.cli.dask_worker "tcp://127.0.0.1:$port" --nworkers 2 --nthreads 1 --no-dashboard \
  > "$WORK/worker.log" 2>&1 &
pids+=("$!")
sleep 3
t0=$SECONDS
encode --scheduler "tcp://127.0.0.1:$port" --shared-dir "$WORK" > "$WORK/lost.txt" 2>&1 &
client=$!
wait_for_half "$client"
kill -9 "$scheduler"
status=0
wait "$client" || status=$?
cleanup
echo "scheduler killed at $(kept) kept tiles after $((SECONDS - t0)) s: the client exited $status: $(cat "$WORK/lost.txt")"
[ "$status" = 1 ] && [ ! -e "$out" ]
resume "scheduler killed"

# 3. The client killed.
t0=$SECONDS
encode --workers 2 > /dev/null 2>&1 &
client=$!
pids+=("$client")
wait_for_half "$client"
kill -9 "$client"
wait "$client" 2>/dev/null || true
echo "client killed at $(kept) kept tiles after $((SECONDS - t0)) s; output present: $([ -e "$out" ] && echo yes || echo no)"
[ ! -e "$out" ]
resume "client killed"
echo "resume_check: both resumed to the reference's bytes"
