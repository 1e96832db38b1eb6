#!/usr/bin/env bash
# Rate–distortion and speed of the codec on the real scans, with Draco measured in the same run
# on the same files (issue: the codec, item 8). Writes docs/results/codec_rd.csv and the table
# in docs/RESULTS.md between its markers.
#
# Usage: scripts/rd_codec.sh [DATA_DIR]     (default ../shared/data)
#   LEVELS="0 1 2 3 4 5 6 7 8 9"  sspc levels for the small scans
#   AUTZEN_LEVELS="3 5 7 8 9" sspc levels for autzen.ply (10.6M points: minutes per level)
#   DRACO_QP="6 8 10 11 12 14 16"  Draco position quantisation bits
#   SCANS="bunny igea dragon_scans autzen"
#   KEEP_DIR=dir              keep each model (SCAN.lLEVEL.sspc) and its encode --json there
#   PEERS=file                the peers' measured curves (default DATA_DIR/../anchors/peer_curves.csv):
#                             each sspc row gets its bits as a multiple of G-PCC's (merged duplicates)
#                             and Draco's at equal paper PSNR, interpolated on their curves
# Installs what it needs (a release build, Debian's draco and time packages, python3).
set -euo pipefail
cd "$(dirname "$0")/.."
data="${1:-../shared/data}"
LEVELS="${LEVELS:-0 1 2 3 4 5 6 7 8 9}"
AUTZEN_LEVELS="${AUTZEN_LEVELS:-3 5 7 8 9}"
DRACO_QP="${DRACO_QP:-6 8 10 11 12 14 16}"
SCANS="${SCANS:-bunny igea dragon_scans autzen}"
if [ ! -d "$data" ]; then
  echo "rd_codec: no data directory $data; nothing to measure" >&2
  exit 0
fi

bash scripts/install_deps.sh draco time python3-matplotlib
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

peers="${PEERS:-$data/../anchors/peer_curves.csv}"
python3 - "$csv" docs/RESULTS.md "$(git rev-parse --short HEAD)" "$(nproc)" "$peers" <<'PY'
import csv, datetime, os, sys
sys.path.insert(0, "scripts")
from results_section import replace_section
path, results, commit, cores, peers = sys.argv[1:]
rows = list(csv.DictReader(open(path)))
curves = {}  # (scan, codec) -> [(psnr, bpp)] sorted by PSNR
if os.path.exists(peers):
    for r in csv.DictReader(open(peers)):
        if (r["codec"], r["variant"]) in (("gpcc", "merged"), ("draco", "cl7")):
            curves.setdefault((r["scan"], r["codec"]), []).append((float(r["psnr_paper"]), float(r["bpp"])))
    for c in curves.values():
        c.sort()

def times_peer(r, codec):
    """sspc's bpp over the peer's at sspc's PSNR (linear in PSNR between the two measured points
    around it); empty outside the peer's measured range."""
    c = curves.get((r["scan"], codec))
    if r["codec"] != "sspc" or not c:
        return ""
    p = float(r["psnr"])
    for (p0, b0), (p1, b1) in zip(c, c[1:]):
        if p0 <= p <= p1 and p1 > p0:
            return f"{float(r['bpp']) / (b0 + (b1 - b0) * (p - p0) / (p1 - p0)):.2f}"
    return ""
lines = [f"Measured {datetime.date.today()} at commit {commit} on {cores} cores by `scripts/rd_codec.sh`; "
         "raw figures in `docs/results/codec_rd.csv`. PSNR is the paper's (d_B peak, symmetric RMS); "
         "D1/D2 are MPEG's with the bounding-box diagonal as peak. Rates count positions only "
         "(sspc's default; Draco with `--skip NORMAL`). Times are wall-clock seconds of the CLI, "
         "file reading and writing included; peak memory is the process's maximum RSS.", "",
         "× G-PCC and × Draco: sspc's bits over the peer's at the same paper PSNR, on the curves of "
         "`anchors/peer_curves.csv` (G-PCC with merged duplicates; empty outside their measured range).", "",
         "| scan | codec | setting | bpp | × G-PCC | × Draco | PSNR dB | D1 dB | D2 dB | decoded pts | ratio | encode s | decode s | encode pts/s | decode pts/s | enc MiB | dec MiB |",
         "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
for r in rows:
    lines.append("| " + " | ".join([r["scan"], r["codec"], r["setting"], r["bpp"], times_peer(r, "gpcc"),
        times_peer(r, "draco"), r["psnr"], r["d1_psnr"],
        r["d2_psnr"], r["decoded_points"], r["codebook_ratio"], r["encode_s"], r["decode_s"],
        r["encode_points_per_s"], r["decode_points_per_s"], r["encode_peak_mib"], r["decode_peak_mib"]]) + " |")
lines += ["", "R–D curves (written by this script beside the table):", ""]
lines += [f"![{scan}: sspc against G-PCC and Draco](images/codec_rd_{scan}.png)"
          for scan in sorted({r["scan"] for r in rows})]
replace_section(results, "codec-rd", "Codec: rate, distortion, speed", lines)
print(f"wrote {path} and the table in {results}")
PY

# The R–D curves: sspc's levels against the peers' curves, one plot per scan.
/usr/bin/python3 - "$csv" "$peers" docs/images <<'PY'
import csv, os, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
path, peers, images = sys.argv[1:]
rows = list(csv.DictReader(open(path)))
peer_rows = list(csv.DictReader(open(peers))) if os.path.exists(peers) else []
for scan in sorted({r["scan"] for r in rows}):
    fig, ax = plt.subplots(figsize=(6, 4))
    mine = sorted((float(r["bpp"]), float(r["psnr"])) for r in rows if r["scan"] == scan and r["codec"] == "sspc")
    ax.plot(*zip(*mine), "o-", label="sspc (levels)")
    for codec, variant, style, name in (("gpcc", "merged", "s--", "G-PCC (merged duplicates)"), ("draco", "cl7", "^:", "Draco")):
        pts = sorted((float(r["bpp"]), float(r["psnr_paper"])) for r in peer_rows
                     if r["scan"] == scan and r["codec"] == codec and r["variant"] == variant)
        if pts:
            ax.plot(*zip(*pts), style, label=name)
    ax.set_xscale("log")
    ax.set_xlabel("bits per input point")
    ax.set_ylabel("PSNR (paper), dB")
    ax.set_title(scan)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(os.path.join(images, f"codec_rd_{scan}.png"), dpi=90)
    print(f"wrote {images}/codec_rd_{scan}.png")
PY
