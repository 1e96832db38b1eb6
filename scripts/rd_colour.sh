#!/usr/bin/env bash
# Colour rate and distortion of sspc and Draco on a painted scan: DATA_DIR/bunny.ply with the
# procedural statue texture of scripts/colour_cloud.py (the repository's scans have no colour).
# Writes docs/results/colour_rd.csv and the table in docs/RESULTS.md between its markers.
#
# Usage: scripts/rd_colour.sh [DATA_DIR]     (default ../shared/data)
#   QUALITIES="50 70 80 90 100"    sspc --colour-quality values
#   DRACO_SETTINGS="default"   draco_encoder options, '|' between settings (Debian's draco_encoder
#   codes 8-bit colours losslessly and has no colour quantisation option: -qc is ignored)
#
# Colour bits per point: Draco's are 8·(bytes with colours − bytes without)/N, the same cloud
# encoded twice with the same options; sspc's are 8·colour_bytes/N from `sspc encode --json`.
# Colour PSNR is `sspc eval ORIGINAL DECODED --json`'s colour_psnr (docs/METRICS.md, "Colour").
# Both count positions besides colours: Draco with `--skip NORMAL`, as scripts/rd_codec.sh runs
# it, and sspc without --store-normals. When build/sspc's encoder has no --colour-quality, the
# sspc rows are skipped with a message and Draco's are still measured.
# Installs what it needs (a release build, Debian's draco package, python3 with numpy).
set -euo pipefail
cd "$(dirname "$0")/.."
data="${1:-../shared/data}"
QUALITIES="${QUALITIES:-50 70 80 90 100}"
DRACO_SETTINGS="${DRACO_SETTINGS:-default}"
src="$data/bunny.ply"
if [ ! -f "$src" ]; then
  echo "rd_colour: no $src; nothing to measure" >&2
  exit 0
fi

# Progress only for a person watching; a pipe or a log gets the results alone.
say() { if [ -t 2 ]; then echo "$*" >&2; fi; }

bash scripts/install_deps.sh draco python3-numpy
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build --target sspc_cli >/dev/null
sspc=build/sspc

tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
say "== painting $src"
/usr/bin/python3 scripts/colour_cloud.py "$src" "$tmp/coloured.ply"
/usr/bin/python3 scripts/colour_cloud.py "$src" "$tmp/plain.ply" --no-colour
points=$("$sspc" --quiet info "$tmp/coloured.ply" --json | python3 -c 'import json,sys; print(json.load(sys.stdin)["points"])')

csv=docs/results/colour_rd.csv
mkdir -p docs/results
echo "scan,points,codec,setting,bytes,colour_bytes,colour_bpp,colour_mse,colour_psnr,geometry_bpp,geometry_psnr,note" > "$csv.tmp"

# Appends one CSV row: codec setting total_bytes colour_bytes note, with the decoded cloud's
# eval in $tmp/eval.json. A colour PSNR of +inf (JSON null) is written as inf.
row() {
  python3 - "$points" "$@" >> "$csv.tmp" <<'PY'
import json, os, sys
points, codec, setting, size, colour, note = sys.argv[1:]
e = json.load(open(os.environ["EVAL_JSON"]))
if "colour_psnr" not in e:
    raise SystemExit(f"rd_colour: {codec} {setting}: the decoded cloud has no colours")
points, size, colour = int(points), int(size), int(colour)
psnr = "inf" if e["colour_psnr"] is None else round(e["colour_psnr"], 3)
geometry_psnr = "inf" if e["psnr"] is None else round(e["psnr"], 3)
print(",".join(str(v) for v in [
    "bunny", points, codec, setting, size, colour, round(8 * colour / points, 4),
    round(e["colour_mse"], 4), psnr, round(8 * (size - colour) / points, 4), geometry_psnr, note]))
PY
}

# Draco: each setting on the coloured cloud and on the same cloud without colours.
IFS='|' read -r -a draco_settings <<< "$DRACO_SETTINGS"
for setting in "${draco_settings[@]}"; do
  say "== draco $setting"
  options=()
  [ "$setting" != default ] && read -r -a options <<< "$setting"
  draco_encoder -point_cloud -i "$tmp/coloured.ply" -o "$tmp/with.drc" --skip NORMAL ${options[@]+"${options[@]}"} > /dev/null
  draco_encoder -point_cloud -i "$tmp/plain.ply" -o "$tmp/without.drc" --skip NORMAL ${options[@]+"${options[@]}"} > /dev/null
  draco_decoder -i "$tmp/with.drc" -o "$tmp/d.ply" > /dev/null
  "$sspc" --quiet eval "$tmp/coloured.ply" "$tmp/d.ply" --json > "$tmp/eval.json"
  with=$(stat -c %s "$tmp/with.drc")
  without=$(stat -c %s "$tmp/without.drc")
  note=""
  # draco_encoder skips options it does not know without a word: say so when a setting changed
  # nothing.
  if [ "$setting" = default ]; then
    cp "$tmp/with.drc" "$tmp/default.drc"
  elif [ -f "$tmp/default.drc" ] && cmp -s "$tmp/with.drc" "$tmp/default.drc"; then
    note="same bytes as the default"
  fi
  EVAL_JSON="$tmp/eval.json" row draco "$setting" "$with" "$((with - without))" "$note"
done

# sspc: --colour-quality is new in the encoder; an older build measures Draco alone.
sspc_note=""
if "$sspc" encode --help 2>&1 | grep -q -- '--colour-quality'; then
  for quality in $QUALITIES; do
    say "== sspc --colour-quality $quality"
    "$sspc" --quiet encode "$tmp/coloured.ply" "$tmp/m.sspc" --colour-quality "$quality" --force --json > "$tmp/encode.json"
    colour=$(python3 -c 'import json,sys
e = json.load(open(sys.argv[1]))
if "colour_bytes" not in e:
    raise SystemExit("rd_colour: sspc encode --json has no colour_bytes")
print(e["colour_bytes"])' "$tmp/encode.json")
    "$sspc" --quiet decode "$tmp/m.sspc" "$tmp/d.ply" --force
    "$sspc" --quiet eval "$tmp/coloured.ply" "$tmp/d.ply" --json > "$tmp/eval.json"
    EVAL_JSON="$tmp/eval.json" row sspc "quality $quality" "$(stat -c %s "$tmp/m.sspc")" "$colour" ""
  done
else
  sspc_note="$sspc encode has no --colour-quality option (an sspc older than per-point colours), so the sspc rows are missing; rebuild and rerun."
  echo "rd_colour: $sspc_note" >&2
fi
mv "$csv.tmp" "$csv"

draco_version=$(dpkg-query -W -f='${Version}' draco 2>/dev/null || echo "unknown version")
python3 - "$csv" docs/RESULTS.md "$(git rev-parse --short HEAD)" "$draco_version" "$sspc_note" <<'PY'
import csv, datetime, sys
sys.path.insert(0, "scripts")
from results_section import replace_section
path, results, commit, draco_version, sspc_note = sys.argv[1:]
rows = list(csv.DictReader(open(path)))
lines = [f"Measured {datetime.date.today()} at commit {commit} by `scripts/rd_colour.sh`; raw figures in "
         "`docs/results/colour_rd.csv`. The cloud is the bunny painted by `scripts/colour_cloud.py` (a smooth "
         "stone texture, sharp-edged bands and blotches, noise of σ = 2 levels), since the scans have no colour. "
         "Colour bpp: Draco's 8·(bytes with colours − bytes without)/N, the same cloud encoded twice; sspc's "
         "8·`colour_bytes`/N. Colour PSNR: RGB, 10·log10(255²/MSE), the larger direction's MSE "
         "(docs/METRICS.md, \"Colour\"); inf when every colour comes back exact. Geometry bpp is the rest of the "
         f"file; geometry PSNR is the paper's. Draco is Debian's draco_encoder {draco_version} with `--skip NORMAL` "
         "(positions at its default -qp 11 -cl 7).", ""]
if sspc_note:
    lines += [f"Not measured: {sspc_note}", ""]
table = ["| codec | setting | colour bpp | colour PSNR dB | geometry bpp | geometry PSNR dB | note |",
         "|---|---|---:|---:|---:|---:|---|"]
for r in rows:
    table.append("| " + " | ".join([r["codec"], r["setting"], r["colour_bpp"], r["colour_psnr"],
                                     r["geometry_bpp"], r["geometry_psnr"], r["note"]]) + " |")
lines += table
if any(r["codec"] == "draco" and r["note"] for r in rows):
    lines += ["", "\"Same bytes as the default\": the setting changed nothing. Debian's draco_encoder has no "
              "`-qc` option (`draco_encoder -h` lists none; draco_transcoder has one) and ignores options it "
              "does not know."]
replace_section(results, "colour-rd", "Colour: rate and distortion against Draco", lines)
print("\n".join(table))
if sys.stderr.isatty():
    print(f"wrote {path} and the table in {results}", file=sys.stderr)
PY
