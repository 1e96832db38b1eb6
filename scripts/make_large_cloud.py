#!/usr/bin/env python3
"""A large, realistic point cloud for the scale benchmark (scripts/bench_scale.sh): copies of a
real scan (autzen's airborne LiDAR by default) laid side by side on a square grid, each copy
turned by a multiple of 90 degrees, mirrored or not, thinned to a random 85-100% of its points and
jittered by a quarter of the scan's spacing, so that no two copies are the same points (the codec
must not find copies it can instance exactly, which real data would not have). Written as binary
little-endian PLY with float32 x, y, z, in chunks: memory stays about one copy of the source.

    python3 scripts/make_large_cloud.py ../shared/data/autzen.ply /tmp/big100m.ply --points 100000000
"""

import argparse
import math
import sys

import numpy as np

try:
    import sspc
except ImportError:  # run from a build tree: PYTHONPATH=build/python
    sys.exit("make_large_cloud: the sspc Python module is needed (PYTHONPATH=build/python)")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("source")
    parser.add_argument("output")
    parser.add_argument("--points", type=float, required=True, help="points to write (1e8 = 100M)")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args(argv)
    total = int(args.points)
    source = np.asarray(sspc.read(args.source).positions, dtype=np.float64)
    lo, hi = source.min(axis=0), source.max(axis=0)
    centred = source - (lo + hi) / 2
    # The source's spacing, from a sample's nearest neighbours (scipy's tree).
    from scipy.spatial import cKDTree  # pylint: disable=import-outside-toplevel

    rng = np.random.default_rng(args.seed)
    sample = centred[rng.choice(len(centred), size=min(len(centred), 200_000), replace=False)]
    spacing = float(np.median(cKDTree(sample).query(sample, k=2)[0][:, 1])) * math.sqrt(len(sample) / len(centred))
    side = float(max(hi[0] - lo[0], hi[1] - lo[1]))
    # Enough copies however the thinning falls: each keeps at least 85% of the points but for
    # chance (0.925 on average ran 1B points 0.03% short).
    copies = math.ceil(total / (0.84 * len(source)))
    grid = math.ceil(math.sqrt(copies))
    with open(args.output, "wb") as out:
        out.write((f"ply\nformat binary_little_endian 1.0\ncomment jittered copies of {args.source} on a {grid}x{grid} grid\n"
                   f"element vertex {total}\nproperty float x\nproperty float y\nproperty float z\nend_header\n")
                  .encode())
        written = made = 0
        for c in range(copies):
            if written == total:
                break
            turn = rng.integers(4)
            xy = centred[:, :2].copy()
            for _ in range(turn):
                xy = np.stack([-xy[:, 1], xy[:, 0]], axis=1)
            if rng.integers(2):
                xy[:, 0] = -xy[:, 0]
            keep = rng.random(len(centred)) < rng.uniform(0.85, 1.0)
            points = np.concatenate([xy, centred[:, 2:3]], axis=1)[keep]
            points += rng.normal(scale=0.25 * spacing, size=points.shape)
            points[:, 0] += (c % grid) * side * 1.01
            points[:, 1] += (c // grid) * side * 1.01
            points = points[: total - written].astype("<f4")
            out.write(points.tobytes())
            written += len(points)
            made += 1
        if written < total:
            sys.exit(f"make_large_cloud: wrote {written} of {total} points")
    print(f"{args.output}: {total} points, {made} copies of {len(source)} on a {grid}x{grid} grid, "
          f"jitter {0.25 * spacing:.4g}")


if __name__ == "__main__":
    main()
