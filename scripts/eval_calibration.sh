#!/usr/bin/env bash
# Calibrates `sspc eval`: a cloud against itself, against a copy with Gaussian noise of 1% of
# its spacing, and against a random half of its points. Usage: eval_calibration.sh [CLOUD]
# (default ../shared/data/bunny.ply, else data/bunny.ply). Needs a release build in build/.
set -euo pipefail
cd "$(dirname "$0")/.."
cloud="${1:-../shared/data/bunny.ply}"
[ -f "$cloud" ] || cloud=data/bunny.ply
build="${BUILD_DIR:-build}"
cmake --build "$build" --target sspc_cli make_variants >/dev/null
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
"$build/bench/make_variants" "$cloud" "$tmp" 0.01
for variant in self noisy half; do
  test_cloud="$cloud"
  [ "$variant" = self ] || test_cloud="$tmp/$variant.ply"
  echo "== $cloud vs $variant"
  "$build/sspc" eval "$cloud" "$test_cloud"
done
