#!/usr/bin/env bash
# Rate–distortion and speed of the codec on the real scans, with Draco measured in the same run
# on the same files (issue: the codec, item 8). Writes docs/results/codec_rd.csv and the table
# in docs/RESULTS.md between its markers.
#
# Usage: scripts/rd_codec.sh [DATA_DIR]     (default ../shared/data)
#   LEVELS="1 3 5 7 9"        sspc levels for the small scans
#   AUTZEN_LEVELS="5 9"       sspc levels for autzen.ply (10.6M points: minutes per level)
#   DRACO_QP="6 8 10 11 12 14 16"  Draco position quantisation bits
#   SCANS="bunny igea dragon_scans autzen"
#   KEEP_DIR=dir              keep each model (SCAN.lLEVEL.sspc) and its encode --json there
# Installs what it needs (a release build, Debian's draco and time packages, python3).
set -euo pipefail
cd "$(dirname "$0")/.."
data="${1:-../shared/data}"
LEVELS="${LEVELS:-1 3 5 7 9}"
AUTZEN_LEVELS="${AUTZEN_LEVELS:-5 9}"
DRACO_QP="${DRACO_QP:-6 8 10 11 12 14 16}"
SCANS="${SCANS:-bunny igea dragon_scans autzen}"
if [ ! -d "$data" ]; then
  echo "rd_codec: no data directory $data; nothing to measure" >&2
  exit 0
fi

bash scripts/install_deps.sh
need=()
command -v draco_encoder >/dev/null || need+=(draco)
[ -x /usr/bin/time ] || need+=(time)
command -v python3 >/dev/null || need+=(python3)
if ((${#need[@]})); then
  SUDO=""; [ "$(id -u)" != 0 ] && SUDO=sudo
  $SUDO apt-get update -q && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q "${need[@]}"
fi
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build --target sspc_cli >/dev/null
sspc=build/sspc

tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
csv=docs/results/codec_rd.csv
mkdir -p docs/results
echo "scan,points,codec,setting,bytes,bpp,psnr,d1_psnr,d2_psnr,decoded_points,codebook_ratio,encode_s,decode_s,encode_points_per_s,decode_points_per_s,encode_peak_mib,decode_peak_mib" > "$csv.tmp"

# Runs a command under /usr/bin/time; prints "seconds peak_kib". The seconds come from the
# clock in nanoseconds around it (time's %e has 10 ms steps, too coarse for bunny's decode).
timed() {
  local t0 t1
  t0=$(date +%s.%N)
  /usr/bin/time -f "%M" -o "$tmp/time" "$@" > "$tmp/stdout"
  t1=$(date +%s.%N)
  echo "$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.3f", b - a }') $(cat "$tmp/time")"
}

# Appends one CSV row from the files the run left in $tmp.
row() {  # scan points codec setting bytes enc_time enc_peak dec_time dec_peak ratio
  python3 - "$@" >> "$csv.tmp" <<'PY'
import json, os, sys
scan, points, codec, setting, size, et, ep, dt, dp, ratio = sys.argv[1:]
e = json.load(open(os.environ["EVAL_JSON"]))
points, size, et, dt = int(points), int(size), float(et), float(dt)
print(",".join(str(v) for v in [
    scan, points, codec, setting, size, round(8 * size / points, 4), round(e["psnr"], 3),
    round(e["d1_psnr"], 3), round(e["d2_psnr"], 3), e["test_points"], ratio, et, dt,
    round(points / et) if et > 0 else "", round(points / dt) if dt > 0 else "",
    round(int(ep) / 1024, 1), round(int(dp) / 1024, 1)]))
PY
}

for scan in $SCANS; do
  src="$data/$scan.ply"
  [ -f "$src" ] || { echo "rd_codec: $src missing, skipped" >&2; continue; }
  points=$("$sspc" info "$src" --json | python3 -c 'import json,sys; print(json.load(sys.stdin)["points"])')
  levels="$LEVELS"; [ "$scan" = autzen ] && levels="$AUTZEN_LEVELS"
  for level in $levels; do
    echo "== $scan: sspc level $level" >&2
    read -r et ep < <(timed "$sspc" encode "$src" "$tmp/m.sspc" --level "$level" --force --json --quiet)
    ratio=$(python3 -c 'import json,sys; print(round(json.load(open(sys.argv[1]))["codebook_ratio"],3))' "$tmp/stdout")
    if [ -n "${KEEP_DIR:-}" ]; then  # the models and encode statistics, for scripts/reproduce.sh
      mkdir -p "$KEEP_DIR"
      cp "$tmp/m.sspc" "$KEEP_DIR/$scan.l$level.sspc"
      cp "$tmp/stdout" "$KEEP_DIR/$scan.l$level.encode.json"
    fi
    read -r dt dp < <(timed "$sspc" decode "$tmp/m.sspc" "$tmp/d.ply" --force --quiet)
    "$sspc" eval "$src" "$tmp/d.ply" --json --quiet > "$tmp/eval.json"
    EVAL_JSON="$tmp/eval.json" row "$scan" "$points" sspc "level $level" "$(stat -c %s "$tmp/m.sspc")" "$et" "$ep" "$dt" "$dp" "$ratio"
  done
  for qp in $DRACO_QP; do
    echo "== $scan: draco -qp $qp" >&2
    read -r et ep < <(timed draco_encoder -point_cloud -i "$src" -o "$tmp/m.drc" -qp "$qp" -cl 7 --skip NORMAL)
    read -r dt dp < <(timed draco_decoder -i "$tmp/m.drc" -o "$tmp/d.ply")
    "$sspc" eval "$src" "$tmp/d.ply" --json --quiet > "$tmp/eval.json"
    EVAL_JSON="$tmp/eval.json" row "$scan" "$points" draco "qp $qp" "$(stat -c %s "$tmp/m.drc")" "$et" "$ep" "$dt" "$dp" ""
  done
done
mv "$csv.tmp" "$csv"

python3 - "$csv" docs/RESULTS.md "$(git rev-parse --short HEAD)" "$(nproc)" <<'PY'
import csv, datetime, sys
sys.path.insert(0, "scripts")
from results_section import replace_section
path, results, commit, cores = sys.argv[1:]
rows = list(csv.DictReader(open(path)))
lines = [f"Measured {datetime.date.today()} at commit {commit} on {cores} cores by `scripts/rd_codec.sh`; "
         "raw figures in `docs/results/codec_rd.csv`. PSNR is the paper's (d_B peak, symmetric RMS); "
         "D1/D2 are MPEG's with the bounding-box diagonal as peak. Rates count positions only "
         "(sspc's default; Draco with `--skip NORMAL`). Times are wall-clock seconds of the CLI, "
         "file reading and writing included; peak memory is the process's maximum RSS.", "",
         "| scan | codec | setting | bpp | PSNR dB | D1 dB | D2 dB | decoded pts | ratio | encode s | decode s | encode pts/s | decode pts/s | enc MiB | dec MiB |",
         "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
for r in rows:
    lines.append("| " + " | ".join([r["scan"], r["codec"], r["setting"], r["bpp"], r["psnr"], r["d1_psnr"],
        r["d2_psnr"], r["decoded_points"], r["codebook_ratio"], r["encode_s"], r["decode_s"],
        r["encode_points_per_s"], r["decode_points_per_s"], r["encode_peak_mib"], r["decode_peak_mib"]]) + " |")
replace_section(results, "codec-rd", "Codec: rate, distortion, speed", lines)
print(f"wrote {path} and the table in {results}")
PY
