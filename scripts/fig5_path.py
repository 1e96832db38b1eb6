"""The camera path of the paper's Figure 5, for scripts/reproduce.sh and scripts/bench_render.sh.

Reads `sspc info SCAN --json` on stdin and prints FRAMES cameras in `sspc render --camera-path`'s
format: circling above the scan at half its span, looking at points a quarter span from the
centre, z up, a 50° field of view (aerial and terrestrial scans alike).

Usage: sspc info SCAN --json | python3 scripts/fig5_path.py FRAMES > path.txt
"""
import json
import math
import sys

info, frames = json.load(sys.stdin), int(sys.argv[1])
lo, hi = info["bbox_min"], info["bbox_max"]
c = [(a + b) / 2 for a, b in zip(lo, hi)]
span = max(hi[0] - lo[0], hi[1] - lo[1])
for f in range(frames):
    a = 2 * math.pi * f / frames
    eye = (c[0] + 0.35 * span * math.cos(a), c[1] + 0.35 * span * math.sin(a), hi[2] + 0.3 * span)
    target = (c[0] + 0.1 * span * math.cos(a + 1), c[1] + 0.1 * span * math.sin(a + 1), c[2])
    print(*eye, *target, 0, 0, 1, 50)
