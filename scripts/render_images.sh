#!/usr/bin/env bash
# The README's renders (docs/images/): the bunny and dragon_scans, uncompressed, compressed at the
# default level and rendered directly, and coloured by code word (the paper's Figure 6).
# Usage: scripts/render_images.sh [DATA_DIR]   (default ../shared/data; the bunny ships in data/)
set -euo pipefail
cd "$(dirname "$0")/.."
data="${1:-../shared/data}"
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build --target sspc_cli >/dev/null
sspc="$PWD/build/sspc"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
mkdir -p docs/images

render_set() {  # name input camera-options...
  local name="$1" input="$2"
  shift 2
  "$sspc" --quiet encode "$input" "$tmp/$name.sspc" -f >/dev/null
  "$sspc" --quiet render "$input" -o "docs/images/${name}_uncompressed.png" -f "$@"
  "$sspc" --quiet render "$tmp/$name.sspc" -o "docs/images/${name}_compressed.png" -f "$@"
  "$sspc" --quiet render "$tmp/$name.sspc" -o "docs/images/${name}_codewords.png" -f --shade codeword "$@"
}

render_set bunny data/bunny.ply --size 480x480 --eye -0.017,0.11,0.26 --target -0.017,0.11,0 --fov 40
if [ -f "$data/dragon_scans.ply" ]; then
  render_set dragon "$data/dragon_scans.ply" --size 640x480 --eye -0.02,0.15,0.38 --target -0.025,0.118,-0.035 --fov 30
fi
