#!/usr/bin/env python3
"""Paints a scan with a procedural "photographed statue" texture: the fixture for colour measurements.

Usage: scripts/colour_cloud.py IN.ply OUT.ply [--no-colour]

The repository's scans (data/bunny.ply, ../shared/data) have no colour, so colour rates
(scripts/rd_colour.sh) are measured on a scan painted by this script. IN is a binary
little-endian PLY whose one element, `vertex`, has `float x y z` and optionally `float nx ny nz`;
OUT has the same points in the same order, the same properties and comments, and `uchar red
green blue` appended. With --no-colour OUT is the same copy without the colours, the reference a
codec's colour bits are measured against (bytes with colours minus bytes without).

The texture imitates a photographed stone statue, which is what a codec's colour coder meets in
a scan: mostly smooth shading, a few sharp edges, and sensor noise. Every number below is fixed,
so the same IN gives the same OUT byte for byte (numpy's PCG64 generator, seed 20240611).

With D the bounding-box diagonal, c the box's centre and p a point:

1. Smooth field. s(p) = 0.5 sin(2π u1·(p−c) / (D/3) + 0.4)
                      + 0.3 sin(2π u2·(p−c) / (D/5) + 1.3)
                      + 0.2 sin(2π u3·(p−c) / (D/8) + 2.1),
   u1, u2, u3 the unit vectors along (1, 0.6, 0.3), (−0.4, 1, 0.5), (0.3, −0.2, 1): three waves
   at 1/3, 1/5 and 1/8 of the diagonal. t = (s + 1) / 2 in [0, 1] picks a colour on a warm stone
   palette, piecewise linear through (96, 80, 64), (168, 142, 112) and (222, 204, 176) at t = 0,
   0.5 and 1; a fourth wave, w = sin(2π u2·(p−c) / (D/4)), adds w·(10, 3, −8): ochre where w > 0,
   greyer where w < 0.
2. Sharp features, each a step of 40-80 levels on its strongest channel:
   - a weathering band: points whose u3·(p−c) lies in [0.05 D, 0.11 D) darken by (−70, −62, −50);
   - four blotches, balls of radius D/14, D/12, D/10 and D/9 about points drawn from the cloud
     with the seed, shifted by rust (+55, +5, −45), lichen (−50, −25, −58), pale stone
     (+45, +48, +50) and soot (−66, −60, −54).
   A point inside several features takes the step of the last in this list: steps never add up.
3. Noise: Gaussian, σ = 2 levels, independent per point and channel, from the same seed.

The result is rounded to the nearest level and clipped to 0..255.
"""
import argparse
import os
import sys

import numpy as np

SEED = 20240611
FIELDS = ("x", "y", "z", "nx", "ny", "nz")


def read_ply(path):
    """Returns (comments, property names, structured array of float32 fields) of a PLY file."""
    with open(path, "rb") as f:
        if f.readline().rstrip(b"\r\n") != b"ply":
            raise SystemExit(f"{path}: not a PLY file")
        comments, names, count, elements = [], [], None, 0
        while True:
            line = f.readline()
            if not line:
                raise SystemExit(f"{path}: the header has no end_header")
            words = line.decode("latin-1").split()
            if not words:
                continue
            if words[0] == "end_header":
                break
            if words[0] == "format" and words[1:2] != ["binary_little_endian"]:
                raise SystemExit(f"{path}: format {' '.join(words[1:])}; only binary_little_endian is read")
            elif words[0] in ("comment", "obj_info"):
                comments.append(line.decode("latin-1").rstrip("\r\n"))
            elif words[0] == "element":
                elements += 1
                if words[1] != "vertex" or elements > 1:
                    raise SystemExit(f"{path}: element {words[1]}; only one element, vertex, is read")
                count = int(words[2])
            elif words[0] == "property":
                if words[1] not in ("float", "float32") or words[2] not in FIELDS:
                    raise SystemExit(f"{path}: property {' '.join(words[1:])}; only float {' '.join(FIELDS)} are read")
                names.append(words[2])
        if count is None or names[:3] != ["x", "y", "z"] or len(set(names)) != len(names):
            raise SystemExit(f"{path}: needs float x y z first, each property once")
        dtype = np.dtype([(n, "<f4") for n in names])
        data = np.fromfile(f, dtype=dtype, count=count)
        if len(data) != count:
            raise SystemExit(f"{path}: {count} vertices in the header, {len(data)} in the file")
    return comments, names, data


def unit(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v)


def statue_colours(positions):
    """The texture of the module's docstring for (N, 3) positions: (N, 3) uint8."""
    rng = np.random.default_rng(SEED)
    p = positions.astype(np.float64)
    lo, hi = p.min(axis=0), p.max(axis=0)
    d = float(np.linalg.norm(hi - lo))
    if not d > 0:
        raise SystemExit("all points coincide: no texture to lay out")
    q = p - (lo + hi) / 2
    u1, u2, u3 = unit([1, 0.6, 0.3]), unit([-0.4, 1, 0.5]), unit([0.3, -0.2, 1])

    def wave(u, wavelength, phase):
        return np.sin(2 * np.pi * (q @ u) / wavelength + phase)

    s = 0.5 * wave(u1, d / 3, 0.4) + 0.3 * wave(u2, d / 5, 1.3) + 0.2 * wave(u3, d / 8, 2.1)
    t = (s + 1) / 2
    stops = np.array([[96, 80, 64], [168, 142, 112], [222, 204, 176]], dtype=np.float64)
    colour = np.stack([np.interp(t, [0, 0.5, 1], stops[:, k]) for k in range(3)], axis=1)
    colour += np.outer(wave(u2, d / 4, 0.0), [10, 3, -8])

    # Each feature replaces the shift of those before it, so a jump is the feature's own step.
    shift = np.zeros_like(colour)
    along = q @ u3
    shift[(along >= 0.05 * d) & (along < 0.11 * d)] = [-70, -62, -50]
    centres = p[rng.choice(len(p), size=4, replace=False)]
    blotches = ((d / 14, [55, 5, -45]), (d / 12, [-50, -25, -58]), (d / 10, [45, 48, 50]),
                (d / 9, [-66, -60, -54]))
    for centre, (radius, step) in zip(centres, blotches):
        shift[np.sum((p - centre) ** 2, axis=1) < radius * radius] = step
    colour += shift
    colour += rng.normal(0.0, 2.0, size=colour.shape)
    return np.clip(np.rint(colour), 0, 255).astype(np.uint8)


def write_ply(path, comments, names, data, colours):
    if colours is not None:
        comments = comments + ["comment colours: procedural statue texture by scripts/colour_cloud.py"]
    header = ["ply", "format binary_little_endian 1.0", *comments,
              f"element vertex {len(data)}", *(f"property float {n}" for n in names)]
    fields = [(n, "<f4") for n in names]
    if colours is not None:
        header += ["property uchar red", "property uchar green", "property uchar blue"]
        fields += [("red", "u1"), ("green", "u1"), ("blue", "u1")]
    header.append("end_header")
    out = np.empty(len(data), dtype=np.dtype(fields))
    for n in names:
        out[n] = data[n]
    if colours is not None:
        out["red"], out["green"], out["blue"] = colours[:, 0], colours[:, 1], colours[:, 2]
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        f.write(("\n".join(header) + "\n").encode("latin-1"))
        out.tofile(f)
    os.replace(tmp, path)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("input")
    parser.add_argument("output")
    parser.add_argument("--no-colour", action="store_true", help="write the same copy without colours")
    args = parser.parse_args()
    comments, names, data = read_ply(args.input)
    colours = None
    if not args.no_colour:
        colours = statue_colours(np.stack([data["x"], data["y"], data["z"]], axis=1))
    write_ply(args.output, comments, names, data, colours)
    return 0


if __name__ == "__main__":
    sys.exit(main())
