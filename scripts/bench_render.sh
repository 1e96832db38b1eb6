#!/usr/bin/env bash
# Primary-ray rendering benchmark (issue: the renderer, item 6): each scan rendered at 1024×1024
# on 2 threads from the automatic camera, uncompressed (one MLS surface over its points) and
# compressed (the .sspc model at each level, rendered directly under each memory budget): scene
# build seconds, Mrays/s (median of 3 renders), hits, MLS evaluations per hit, scene bytes per
# original point (peak of the brick cache for a compressed model), peak memory, and, for the
# compressed model, the image PSNR over hit pixels and the pixels hit in one only against the
# render of the same model's decode (docs/METRICS.md, "Images"). Rays per CPU-second (every
# thread's time while rendering) compare the renderers whatever their threads. When the build has
# Embree 3, each scan also gets the reference a fast raw-point renderer gives: Embree's oriented
# discs on the source points with the uncompressed scene's normals, DISC_RADIUS point spacings
# wide, through the same camera, pixels and shading (bench/embree_discs.cpp; rtcIntersect1 per
# ray, and packets of 16 rays on 4×4 tiles), compared with the uncompressed render. Writes
# docs/results/render_bench.csv and its table in docs/RESULTS.md.
#
# Level of detail (`--lod`): the level-LOD_LEVEL model rendered at each of LODS, and its decode
# rendered with one ray a pixel, all against the decode rendered with 2 × 2 rays a pixel (a
# supersampled reference, docs/METRICS.md "Images"): what each image shows of what the pixels
# cover, and what the coarser levels save of the first frame's time and the scene's memory.
# Writes docs/results/render_lod.csv and its table in docs/RESULTS.md.
#
# The paper's Figure 5 (`path`): PATH_FRAMES frames of PATH_SIZE along a camera path circling
# above PATH_SCAN (scripts/reproduce.sh's path), the uncompressed cloud paged from a file under a
# budget of a quarter of its in-memory scene (and in memory, without a budget), against the
# level-PATH_LEVEL model under the same budget (with every point and with `--lod 0.5`) and with
# its default 512 MiB, and Embree's discs on the same views: each a process over the whole path,
# the median and first frame, the pages each frame read (a paged cloud's pages from its page
# file, a compressed model's bricks built), the peak memory. Writes docs/results/render_path.csv
# and its table in docs/RESULTS.md.
#
# Usage: scripts/bench_render.sh [DATA_DIR]     (default ../shared/data)
#   SCANS="bunny dragon_scans autzen"   SIZE=1024x1024   THREADS=2   LEVELS="0 5 9"   BUDGETS="512 64" (MiB)
#   DISC_RADIUS=1.5 (point spacings)   PARTS="speed lod path"   LODS="0 0.5 1"   LOD_LEVEL=5
#   PATH_SCAN=autzen   PATH_FRAMES=30   PATH_SIZE=512x512   PATH_LEVEL=5
#   WORK=/tmp/sspc_bench_render (encoded models and normals are kept there between runs)
# Installs what it needs (a release build, Debian's time package, python3).
set -euo pipefail
cd "$(dirname "$0")/.."
data="${1:-../shared/data}"
SCANS="${SCANS:-bunny dragon_scans autzen}"
SIZE="${SIZE:-1024x1024}"
THREADS="${THREADS:-2}"
LEVELS="${LEVELS:-0 5 9}"
BUDGETS="${BUDGETS:-512 64}"
DISC_RADIUS="${DISC_RADIUS:-1.5}"
PARTS="${PARTS:-speed lod path}"
PATH_SCAN="${PATH_SCAN:-autzen}"
PATH_FRAMES="${PATH_FRAMES:-30}"
PATH_SIZE="${PATH_SIZE:-512x512}"
PATH_LEVEL="${PATH_LEVEL:-5}"
LODS="${LODS:-0 0.5 1}"
LOD_LEVEL="${LOD_LEVEL:-5}"
WORK="${WORK:-/tmp/sspc_bench_render}"
if [ ! -d "$data" ]; then
  echo "bench_render: no data directory $data; nothing to measure" >&2
  exit 0
fi

bash scripts/install_deps.sh time
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
targets=(sspc_cli)
# The Embree reference is built when CMake found Embree 3 and the benchmarks are on.
if grep -q '^embree_discs_bench:' <<<"$(cmake --build build --target help)"; then targets+=(embree_discs_bench); fi
cmake --build build --target "${targets[@]}" >/dev/null
sspc="$PWD/build/sspc"
discs=""
if [[ " ${targets[*]} " == *" embree_discs_bench "* ]]; then
  discs="$PWD/build/bench/embree_discs_bench"
else
  echo "bench_render: no Embree 3 in the build; the embree-discs rows are skipped" >&2
fi
mkdir -p "$WORK" docs/results
columns="scan,model,points,size,threads,build_s,render_s,mrays_s,mrays_cpu_s,warm_render_s,mrays_s_warm,hits,evaluations_per_hit,scene_bytes_per_point,resident_growth_per_point,peak_rss_mib,psnr_hit_db,hit_one_only_percent"
speed_csv=docs/results/render_bench.csv
lod_csv=docs/results/render_lod.csv
if [[ " $PARTS " == *" speed "* ]]; then echo "$columns" > "$speed_csv"; fi
if [[ " $PARTS " == *" lod "* ]]; then echo "$columns" > "$lod_csv"; fi
path_csv=docs/results/render_path.csv
csv="$speed_csv"  # where measure() writes

# One configuration: three renders, each a process of its own (a compressed scene builds its
# bricks as the frame's rays reach them), the median render time; build time and memory of the
# first. Then the warm frame: one process renders the view twice (a camera path of two equal
# lines), and the second frame's time is the scene's once built (a compressed model's bricks
# cached, as along a camera path).
measure() {  # scan model-label input [render options]
  local scan="$1" label="$2" input="$3" runs=() warm=()
  shift 3
  for r in 1 2 3; do
    /usr/bin/time -f "%M" -o "$WORK/rss" "$sspc" --quiet --threads "$THREADS" render "$input" \
      -o "$WORK/frame_$label.png" -f --size "$SIZE" --json "$@" > "$WORK/run$r.json"
    runs+=("$WORK/run$r.json")
    rss_kib[$r]=$(tail -1 "$WORK/rss")
  done
  # The camera comes from the path; --compare does not go with a sequence.
  while [ $# -gt 0 ]; do
    case "$1" in
      --eye|--target|--compare) shift 2 ;;
      *) warm+=("$1"); shift ;;
    esac
  done
  "$sspc" --quiet --threads "$THREADS" render "$input" -o "$WORK/warm.png" -f --size "$SIZE" \
    --camera-path "$same_view" --times "$WORK/warm.csv" ${warm[@]+"${warm[@]}"} > /dev/null
  python3 - "$scan" "$label" "$SIZE" "$THREADS" "${rss_kib[1]}" "$WORK/warm.csv" "${runs[@]}" >> "$csv" <<'EOF'
import csv, json, sys
scan, label, size, threads, rss, warm_csv = sys.argv[1:7]
runs = [json.load(open(p)) for p in sys.argv[7:]]
runs.sort(key=lambda r: r["render_seconds"])
m = runs[len(runs) // 2]
warm = float(list(csv.DictReader(open(warm_csv)))[1]["render_seconds"])
psnr = "inf" if m.get("psnr_hit_db") is None else f'{m["psnr_hit_db"]:.2f}'
print(f'{scan},{label},{m["points"]},{size},{threads},{runs[0]["build_seconds"]:.3f},{m["render_seconds"]:.3f},'
      f'{m["rays"] / m["render_seconds"] / 1e6:.3f},{m["rays"] / m["render_cpu_seconds"] / 1e6:.3f},'
      f'{warm:.3f},{m["rays"] / warm / 1e6:.3f},'
      f'{m["hits"]},{m["evaluations_per_hit"]:.1f},'
      f'{m["scene_bytes_per_point"]:.2f},{runs[0]["resident_growth_bytes"] / m["points"]:.2f},{int(rss) / 1024:.0f},'
      + (f'{psnr},{100 * m["hit_one_only_fraction"]:.3f}'
         if "psnr_hit_db" in m else ","))
EOF
  tail -1 "$csv"
}

# Embree's discs: one process renders the view 3 times and reports the median (embree_discs_bench
# --repeat); scene bytes are Embree's peak allocation (BVH and buffers), the image is compared
# with the uncompressed render.
measure_discs() {  # scan model-label cloud packet [camera options]
  local scan="$1" label="$2" input="$3" packet="$4"
  shift 4
  /usr/bin/time -f "%M" -o "$WORK/rss" "$discs" "$input" --threads "$THREADS" --size "$SIZE" --repeat 3 \
    --radius "$DISC_RADIUS" --packet "$packet" -o "$WORK/frame_$label.png" --compare "$WORK/frame_uncompressed.png" \
    "$@" > "$WORK/discs.json"
  python3 - "$scan" "$label" "$SIZE" "$THREADS" "$(tail -1 "$WORK/rss")" "$WORK/discs.json" >> "$csv" <<'EOF'
import json, sys
scan, label, size, threads, rss, path = sys.argv[1:7]
m = json.load(open(path))
psnr = m["psnr_hit_db"] if m["psnr_hit_db"] is not None else "inf"
print(f'{scan},{label},{m["points"]},{size},{threads},{m["build_seconds"]:.3f},{m["render_seconds"]:.3f},'
      f'{m["rays"] / m["render_seconds"] / 1e6:.3f},{m["rays"] / m["render_cpu_seconds"] / 1e6:.3f},,,{m["hits"]},,'
      f'{m["scene_bytes"] / m["points"]:.2f},,{int(rss) / 1024:.0f},{psnr},{100 * m["hit_one_only_fraction"]:.3f}')
EOF
  tail -1 "$csv"
}

declare -a rss_kib
for scan in $SCANS; do
  src="$data/$scan.ply"
  [ -f "$src" ] || { echo "bench_render: $src missing, skipped" >&2; continue; }
  # One camera for every render of a scan: the automatic framing of the source's bounds (a
  # decoded cloud's bounds differ by the codec's error, and so would its automatic camera).
  read -r eye target < <("$sspc" --quiet info "$src" --json | python3 -c '
import json, math, sys
info = json.load(sys.stdin)
lo, hi = info["bbox_min"], info["bbox_max"]
c = [(a + b) / 2 for a, b in zip(lo, hi)]
r = 0.5 * math.dist(lo, hi)
d = 1.05 * r / math.sin(math.atan(math.tan(math.radians(20))))
print(f"{c[0]},{c[1]},{c[2] + d} {c[0]},{c[1]},{c[2]}")')
  camera=(--eye "$eye" --target "$target")
  same_view="$WORK/$scan.same_view.txt"
  printf '%s %s\n%s %s\n' "$eye" "$target" "$eye" "$target" > "$same_view"
  # The uncompressed scene needs normals: estimated once (scans that have them keep theirs).
  plain="$WORK/$scan.normals.ply"
  [ -f "$plain" ] || "$sspc" --quiet normals "$src" "$plain" --normals auto
  for level in $LEVELS; do
    model="$WORK/$scan.l$level.sspc"
    [ -f "$model" ] || "$sspc" --quiet encode "$src" "$model" --level "$level"
    # The reference: the same model decoded, its normals estimated, rendered as a point cloud.
    decoded="$WORK/$scan.l$level.decoded.ply"
    [ -f "$decoded" ] || { "$sspc" --quiet decode "$model" "$WORK/d.ply" -f &&
                           "$sspc" --quiet normals "$WORK/d.ply" "$decoded" --normals auto; }
  done
  if [[ " $PARTS " == *" speed "* ]]; then
    csv="$speed_csv"
    measure "$scan" uncompressed "$plain" "${camera[@]}"
    if [ -n "$discs" ]; then
      measure_discs "$scan" embree-discs "$plain" 1 "${camera[@]}"
      measure_discs "$scan" embree-discs-packet16 "$plain" 16 "${camera[@]}"
    fi
    for level in $LEVELS; do
      measure "$scan" "decoded-l$level" "$WORK/$scan.l$level.decoded.ply" "${camera[@]}"
      for budget in $BUDGETS; do
        measure "$scan" "compressed-l$level-${budget}MiB" "$WORK/$scan.l$level.sspc" "${camera[@]}" \
          --memory-budget "$budget" --compare "$WORK/frame_decoded-l$level.png"
      done
    done
  fi
  if [[ " $PARTS " == *" lod "* ]]; then
    csv="$lod_csv"
    model="$WORK/$scan.l$LOD_LEVEL.sspc"
    decoded="$WORK/$scan.l$LOD_LEVEL.decoded.ply"
    [ -f "$model" ] || "$sspc" --quiet encode "$src" "$model" --level "$LOD_LEVEL"
    [ -f "$decoded" ] || { "$sspc" --quiet decode "$model" "$WORK/d.ply" -f &&
                           "$sspc" --quiet normals "$WORK/d.ply" "$decoded" --normals auto; }
    width="${SIZE%x*}" height="${SIZE#*x}"
    reference="$WORK/$scan.l$LOD_LEVEL.supersampled.png"
    "$sspc" --quiet --threads "$THREADS" render "$decoded" -o "$reference" -f \
      --size "$((2 * width))x$((2 * height))" "${camera[@]}"
    measure "$scan" "decoded-l$LOD_LEVEL" "$decoded" "${camera[@]}" --compare "$reference"
    for lod in $LODS; do
      measure "$scan" "compressed-l$LOD_LEVEL-lod$lod" "$model" "${camera[@]}" --lod "$lod" --compare "$reference"
    done
  fi
done

# Figure 5: one process a configuration over the whole path.
measure_path() {  # label budget-MiB-or-empty input [render options]
  local label="$1" budget="$2" input="$3"
  shift 3
  local budget_args=()
  [ -n "$budget" ] && budget_args=(--memory-budget "$budget")
  /usr/bin/time -f "%M" -o "$WORK/rss" "$sspc" --quiet --threads "$THREADS" render "$input" -o "$WORK/path.png" -f \
    --size "$PATH_SIZE" --camera-path "$WORK/path.txt" --times "$WORK/path_times.csv" --page-dir "$WORK" \
    ${budget_args[@]+"${budget_args[@]}"} "$@" --json > "$WORK/path.json"
  python3 - "$PATH_SCAN" "$label" "$budget" "$(tail -1 "$WORK/rss")" "$WORK/path.json" "$WORK/path_times.csv" \
    >> "$path_csv" <<'EOF'
import csv, json, statistics, sys
scan, label, budget, rss, path, times = sys.argv[1:]
j = json.load(open(path))
rows = list(csv.DictReader(open(times)))
seconds = [float(r["render_seconds"]) for r in rows]
pages = [int(r["pages_read"]) for r in rows]
read = sum(int(r["bytes_read"]) for r in rows) / 2**20
print(f'{scan},{label},{budget},{len(rows)},{statistics.median(seconds):.3f},{seconds[0]:.3f},{max(seconds):.3f},'
      f'{statistics.median(pages):.0f},{read:.0f},{j["scene_bytes"] / 2**20:.0f},{int(rss) / 1024:.0f}')
EOF
  tail -1 "$path_csv"
}
if [[ " $PARTS " == *" path "* ]] && [ -f "$data/$PATH_SCAN.ply" ]; then
  echo "scan,model,budget_mib,frames,median_frame_s,first_frame_s,max_frame_s,median_pages,read_mib,scene_mib,peak_rss_mib" > "$path_csv"
  plain="$WORK/$PATH_SCAN.normals.ply"
  [ -f "$plain" ] || "$sspc" --quiet normals "$data/$PATH_SCAN.ply" "$plain" --normals auto
  model="$WORK/$PATH_SCAN.l$PATH_LEVEL.sspc"
  [ -f "$model" ] || "$sspc" --quiet encode "$data/$PATH_SCAN.ply" "$model" --level "$PATH_LEVEL"
  "$sspc" --quiet info "$data/$PATH_SCAN.ply" --json | python3 scripts/fig5_path.py "$PATH_FRAMES" > "$WORK/path.txt"
  # The budget: a quarter of what the uncompressed scene holds in memory (one small frame).
  "$sspc" --quiet --threads "$THREADS" render "$plain" -o "$WORK/full.png" -f --size 64x64 --json > "$WORK/full.json"
  quarter=$(python3 -c 'import json, sys; print(max(1, round(json.load(open(sys.argv[1]))["scene_bytes"] / 4 / 2**20)))' "$WORK/full.json")
  measure_path uncompressed-in-memory "" "$plain"
  measure_path uncompressed-paged "$quarter" "$plain"
  measure_path "compressed-l$PATH_LEVEL" "$quarter" "$model"
  measure_path "compressed-l$PATH_LEVEL-lod0.5" "$quarter" "$model" --lod 0.5
  measure_path "compressed-l$PATH_LEVEL" 512 "$model"
  if [ -n "$discs" ]; then
    /usr/bin/time -f "%M" -o "$WORK/rss" "$discs" "$plain" --threads "$THREADS" --size "$PATH_SIZE" --repeat 1 \
      --radius "$DISC_RADIUS" --camera-path "$WORK/path.txt" > "$WORK/discs.json"
    python3 - "$PATH_SCAN" "$(tail -1 "$WORK/rss")" "$WORK/discs.json" >> "$path_csv" <<'EOF'
import json, sys
scan, rss, path = sys.argv[1:]
m = json.load(open(path))
print(f'{scan},embree-discs,,{m["frames"]},{m["render_seconds"] / m["frames"]:.3f},,,,,'
      f'{m["scene_bytes"] / 2**20:.0f},{int(rss) / 1024:.0f}')
EOF
    tail -1 "$path_csv"
  fi
fi

echo
# The tables: RESULTS.md sections from the CSVs.
table() {  # csv section-id title intro
  python3 - "$1" docs/RESULTS.md "$(git rev-parse --short HEAD)" "$(nproc)" "$2" "$3" "$4" <<'EOF'
import csv, datetime, sys
sys.path.insert(0, "scripts")
from results_section import replace_section
path, results, commit, cores, section, title, intro = sys.argv[1:]
rows = list(csv.DictReader(open(path)))
lines = [f"Measured {datetime.date.today()} at commit {commit} on {cores} cores by `scripts/bench_render.sh`; "
         f"raw figures in `{path}`. " + intro, "",
         "| scan | model | build s | Mrays/s | Mrays/CPU-s | Mrays/s warm | rays hit | MLS evaluations per hit "
         "| scene bytes/point | resident growth bytes/point | peak MiB | PSNR hit dB | hit in one only % |",
         "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
for r in rows:
    lines.append(f'| {r["scan"]} | {r["model"]} | {r["build_s"]} | {r["mrays_s"]} | {r["mrays_cpu_s"]} | '
                 f'{r["mrays_s_warm"]} | {r["hits"]} | '
                 f'{r["evaluations_per_hit"]} | {r["scene_bytes_per_point"]} | {r["resident_growth_per_point"]} | '
                 f'{r["peak_rss_mib"]} | '
                 f'{r["psnr_hit_db"]} | {r["hit_one_only_percent"]} |')
print("\n".join(lines))
replace_section(results, section, title, lines)
EOF
}
if [[ " $PARTS " == *" speed "* ]]; then
  table "$speed_csv" render-bench "Renderer: speed and memory" \
    "Primary rays from the automatic camera of the source (its bounding box seen from +z), the same for every \
model of a scan, Mrays/s over all rays (median of 3 frames, each a process of its own: a compressed model builds \
its bricks as the rays reach them), and warm: the second frame of the same view in one process (bricks built, as \
along a camera path); scene bytes per original point as the scene counts them (points, normals and grids; a \
compressed model's bricks and decoded blocks at their peaks under the budget named) and as measured (the process's \
resident growth from before the scene to after the frame), peak memory of the whole process; a compressed model's \
image PSNR over the pixels hit and the pixels hit in one image only, against the render of its own decode \
(\`decoded-lN\`). Mrays per CPU-second: rays over the CPU time of every thread while rendering. \`embree-discs\`: \
the reference a fast raw-point renderer gives, Embree 3's oriented discs on the source points and the uncompressed \
scene's normals, of radius $DISC_RADIUS point spacings, through the same camera, pixels and shading \
(\`bench/embree_discs.cpp\`; one \`rtcIntersect1\` a ray, or packets of 16 rays on 4×4 tiles), median of 3 frames \
in one process, scene bytes Embree's peak allocation, and its image against the uncompressed render."
fi
if [[ " $PARTS " == *" lod "* ]]; then
  table "$lod_csv" render-lod "Renderer: level of detail" \
    "Each scan's level-$LOD_LEVEL model at $SIZE from the automatic camera, rendered directly with \`--lod\` at \
$LODS (\`lod0\`: every point; the default 512 MiB budget), and its decode rendered with one ray a pixel \
(\`decoded-l$LOD_LEVEL\`). Columns as in the table above, but the PSNR and the pixels hit in one only are against the \
decode rendered with 2 × 2 rays a pixel and box-filtered (a supersampled reference, docs/METRICS.md, \"Images\"): \
how close each image comes to what its pixels cover."
fi
if [[ " $PARTS " == *" path "* ]] && [ -f "$path_csv" ]; then
  python3 - "$path_csv" docs/RESULTS.md "$(git rev-parse --short HEAD)" "$(nproc)" "$PATH_SIZE" "$THREADS" <<'EOF'
import csv, datetime, sys
sys.path.insert(0, "scripts")
from results_section import replace_section
path, results, commit, cores, size, threads = sys.argv[1:]
rows = list(csv.DictReader(open(path)))
paged = next((float(r["median_frame_s"]) for r in rows if r["model"] == "uncompressed-paged"), None)
budget = next((r["budget_mib"] for r in rows if r["model"] == "uncompressed-paged"), "")
lines = [f"Measured {datetime.date.today()} at commit {commit} on {cores} cores by `scripts/bench_render.sh`; "
         f"raw figures in `{path}`. The paper's Figure 5 on this renderer: {rows[0]['frames'] if rows else 0} frames "
         f"of {size} on {threads} threads along a camera path circling above {rows[0]['scan'] if rows else ''} "
         f"(scripts/reproduce.sh's), each configuration one process over the whole path. The uncompressed cloud "
         f"is paged from a file under {budget} MiB, a quarter of what its scene holds in memory (the file in the "
         "system's page cache: pages arrive as fast as memory gives them), and rendered in memory; the compressed "
         "model under the same budget and under its default 512 MiB; Embree's discs on the same views (the whole "
         "path's time over its frames). Pages: each frame's pages read from the page file (paged) or bricks "
         "built (compressed), median over the path. × paged: the paged render's median frame over this one's.",
         "",
         "| scan | model | budget MiB | median frame s | first frame s | slowest frame s | pages a frame | read MiB | "
         "scene MiB | peak MiB | × paged |",
         "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
for r in rows:
    speed = f'{paged / float(r["median_frame_s"]):.2f}' if paged and float(r["median_frame_s"]) > 0 else ""
    lines.append(f'| {r["scan"]} | {r["model"]} | {r["budget_mib"]} | {r["median_frame_s"]} | {r["first_frame_s"]} | '
                 f'{r["max_frame_s"]} | {r["median_pages"]} | {r["read_mib"]} | {r["scene_mib"]} | '
                 f'{r["peak_rss_mib"]} | {speed} |')
print("\n".join(lines))
replace_section(results, "render-path", "Renderer: Figure 5, a camera path within a memory budget", lines)
EOF
fi

