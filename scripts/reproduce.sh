#!/usr/bin/env bash
# Reproduces the paper's results section on the real scans, next to Draco (issue 5), and writes
# it into docs/RESULTS.md with its plots (docs/images/fig*.png) and raw CSVs (docs/results/):
#   Figure 3a  compression ratio against code-book ratio, per scan
#   Figure 4   rate–distortion (paper PSNR and D1 PSNR) for every scan, 6 sspc levels and
#              9 Draco quantisations (6-16 bits) measured in the same run on the same files
#   Figure 5   frame times along a 30-frame camera path over autzen, compressed against
#              uncompressed when the uncompressed scene does not fit the memory budget, and
#              the uncompressed path's median frame at larger budgets
#   Figure 6   code-word renders of dragon_scans at 4 rates, with bpp and PSNR
#   encoding time per stage for every scan
#
# Usage: scripts/reproduce.sh [DATA_DIR]    (default ../shared/data)
#   SCANS, LEVELS, AUTZEN_LEVELS, DRACO_QP   as for scripts/rd_codec.sh (6 rates each by default)
#   FIG5_SCAN=autzen  FIG5_BUDGET_MIB=96  FIG5_FRAMES=30  FIG5_SIZE=512x512
#   FIG5_MORE_BUDGETS="160 256 512"   the uncompressed path again at these budgets (MiB)
# Installs what it needs (apt: draco, time, python3-matplotlib) and builds a release sspc.
set -euo pipefail
cd "$(dirname "$0")/.."
data="${1:-../shared/data}"
export SCANS="${SCANS:-bunny igea dragon_scans autzen}"
export LEVELS="${LEVELS:-0 2 4 5 7 9}"
export AUTZEN_LEVELS="${AUTZEN_LEVELS:-4 5 6 7 8 9}"
# Draco over the issue's 8-16 bits, and 6-7 to reach down to sspc's lowest rates.
export DRACO_QP="${DRACO_QP:-6 7 8 9 10 11 12 14 16}"
FIG5_SCAN="${FIG5_SCAN:-autzen}"
FIG5_BUDGET_MIB="${FIG5_BUDGET_MIB:-96}"
FIG5_FRAMES="${FIG5_FRAMES:-30}"
FIG5_SIZE="${FIG5_SIZE:-512x512}"
FIG5_MORE_BUDGETS="${FIG5_MORE_BUDGETS:-160 256 512}"
FIG6_SCAN="${FIG6_SCAN:-dragon_scans}"
if [ ! -d "$data" ]; then
  echo "reproduce: no data directory $data" >&2
  exit 1
fi
start=$(date +%s)
stage() { echo "== [$(( $(date +%s) - start )) s] $*" >&2; }

bash scripts/install_deps.sh draco time python3-matplotlib
stage "build"
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build --target sspc_cli >/dev/null
sspc="$PWD/build/sspc"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
results=docs/results
images=docs/images
mkdir -p "$results" "$images"

# Figures 3a and 4: the rate–distortion sweep, keeping the models for the figures after it.
stage "rate–distortion sweep (scripts/rd_codec.sh)"
KEEP_DIR="$work/models" bash scripts/rd_codec.sh "$data"

# Encoding time per stage, at the default level, from the sweep's encode statistics.
stage "encoding stages"
echo "scan,points,read,normals,centres,descriptors,clustering,writing,total,points_per_s" > "$results/encode_stages.csv"
for scan in $SCANS; do
  json="$work/models/$scan.l5.encode.json"
  [ -f "$json" ] || continue
  python3 - "$scan" "$json" >> "$results/encode_stages.csv" <<'EOF'
import json, sys
scan, path = sys.argv[1:]
e = json.load(open(path))
print(",".join(str(v) for v in [scan, e["points"], e["read_seconds"], e["normals_seconds"], e["centres_seconds"],
      e["descriptors_seconds"], e["clustering_seconds"], e["write_seconds"], e["seconds"], e["points_per_second"]]))
EOF
done

# Normals, counted separately: the default level with --store-normals against positions only.
stage "normals' rate"
# The rate with normals stored, at every setting of the sweep, for the scans whose files carry
# normals (autzen has none). Positions are the same with or without them (sspc builds the same
# patches; Draco quantises positions alike), so the PSNR of the sweep holds for both rates.
echo "scan,codec,setting,positions_bpp,total_bpp" > "$results/normals_rate.csv"
normals_row() {  # scan codec setting positions_file with_normals_file points
  awk -v s="$1,$2,$3" -v a="$(stat -c %s "$4")" -v b="$(stat -c %s "$5")" -v n="$6" \
    'BEGIN { printf "%s,%.4f,%.4f\n", s, 8 * a / n, 8 * b / n }' >> "$results/normals_rate.csv"
}
for scan in $SCANS; do
  info="$("$sspc" info "$data/$scan.ply" --json)"
  python3 -c 'import json, sys; sys.exit(0 if json.loads(sys.argv[1])["normals"] else 1)' "$info" || continue
  points=$(python3 -c 'import json, sys; print(json.loads(sys.argv[1])["points"])' "$info")
  for level in $LEVELS; do
    [ -f "$work/models/$scan.l$level.sspc" ] || continue
    "$sspc" --quiet encode "$data/$scan.ply" "$work/n.sspc" --level "$level" --store-normals -f > /dev/null
    normals_row "$scan" sspc "level $level" "$work/models/$scan.l$level.sspc" "$work/n.sspc" "$points"
  done
  for qp in $DRACO_QP; do
    draco_encoder -point_cloud -i "$data/$scan.ply" -o "$work/p.drc" -qp "$qp" -cl 7 --skip NORMAL > /dev/null
    draco_encoder -point_cloud -i "$data/$scan.ply" -o "$work/n.drc" -qp "$qp" -cl 7 > /dev/null
    normals_row "$scan" draco "qp $qp" "$work/p.drc" "$work/n.drc" "$points"
  done
done

# Figure 5: a camera path over the scan; the uncompressed scene paged within the budget, the
# compressed one (default level) in memory.
if [ -f "$data/$FIG5_SCAN.ply" ] && [ -f "$work/models/$FIG5_SCAN.l5.sspc" ]; then
  stage "Figure 5: $FIG5_SCAN, $FIG5_FRAMES frames, budget $FIG5_BUDGET_MIB MiB"
  "$sspc" --quiet normals "$data/$FIG5_SCAN.ply" "$work/fig5.ply" --normals auto > /dev/null
  "$sspc" info "$data/$FIG5_SCAN.ply" --json | python3 scripts/fig5_path.py "$FIG5_FRAMES" > "$work/path.txt"
  common=(--quiet --threads 2 render --size "$FIG5_SIZE" --camera-path "$work/path.txt" -f --json)
  "$sspc" "${common[@]}" --memory-budget "$FIG5_BUDGET_MIB" "$work/models/$FIG5_SCAN.l5.sspc" -o "$work/c.png" \
    --times "$results/fig5_compressed.csv" > "$work/c.json"
  "$sspc" "${common[@]}" --memory-budget "$FIG5_BUDGET_MIB" "$work/fig5.ply" -o "$work/u.png" \
    --times "$results/fig5_uncompressed.csv" > "$work/u.json"
  # How the uncompressed path's frame time follows the budget: the same path at other budgets.
  echo "budget_mib,frame,render_seconds,bytes_read" > "$results/fig5_budgets.csv"
  for budget in $FIG5_MORE_BUDGETS; do
    "$sspc" "${common[@]}" --memory-budget "$budget" "$work/fig5.ply" -o "$work/u.png" --times "$work/b.csv" > /dev/null
    python3 - "$budget" "$work/b.csv" >> "$results/fig5_budgets.csv" <<'EOF'
import csv, sys
budget, path = sys.argv[1:]
for r in csv.DictReader(open(path)):
    print(f'{budget},{r["frame"]},{r["render_seconds"]},{r["bytes_read"]}')
EOF
  done
  # The uncompressed scene's size in memory, for the caption: one frame without a budget.
  "$sspc" --quiet --threads 2 render "$work/fig5.ply" -o "$work/full.png" --size 64x64 -f --json > "$work/full.json"
  python3 - "$FIG5_SCAN" "$FIG5_BUDGET_MIB" "$FIG5_SIZE" "$work/c.json" "$work/full.json" \
    "$work/models/$FIG5_SCAN.l5.encode.json" > "$results/fig5.json" <<'EOF'
import json, sys
scan, budget, size, c, full, enc = sys.argv[1:]
c, full, enc = json.load(open(c)), json.load(open(full)), json.load(open(enc))
print(json.dumps({"scan": scan, "budget_mib": int(budget), "size": size, "threads": 2, "points": c["points"],
                  "compressed_within_budget": c["within_budget"],
                  "level": enc["level"], "bpp": enc["bits_per_point"],
                  "compressed_mib": c["scene_bytes"] / 2**20, "uncompressed_mib": full["scene_bytes"] / 2**20}))
EOF
fi

# Figure 6: code words at four rates.
stage "Figure 6: $FIG6_SCAN code words"
echo "setting,bpp,psnr,image" > "$results/fig6.csv"
for level in 0 4 7 9; do
  model="$work/models/$FIG6_SCAN.l$level.sspc"
  [ -f "$model" ] || continue
  image="fig6_l$level.png"
  "$sspc" --quiet render "$model" -o "$images/$image" -f --shade codeword --size 400x300 \
    --eye -0.02,0.15,0.38 --target -0.025,0.118,-0.035 --fov 30 > /dev/null
  python3 - "$FIG6_SCAN" "level $level" "$image" "$results/codec_rd.csv" >> "$results/fig6.csv" <<'EOF'
import csv, sys
scan, setting, image, path = sys.argv[1:]
for r in csv.DictReader(open(path)):
    if r["scan"] == scan and r["codec"] == "sspc" and r["setting"] == setting:
        print(f'{setting},{r["bpp"]},{r["psnr"]},{image}')
EOF
done

stage "plots and RESULTS.md"
/usr/bin/python3 scripts/plot_results.py "$results" "$images" docs/RESULTS.md "$(git rev-parse --short HEAD)" "$(nproc)"
stage "done"
