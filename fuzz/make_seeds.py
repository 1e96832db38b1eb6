#!/usr/bin/env python3
"""Writes the hand-made seed files of fuzz/corpus/ (the .sspc seeds are encoder output, see
docs/FUZZING.md). Small on purpose: libFuzzer mutates small inputs fastest. Run from anywhere."""
import math
import os
import struct

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "corpus")


def write(target, name, data):
    os.makedirs(os.path.join(ROOT, target), exist_ok=True)
    if isinstance(data, str):
        data = data.encode()
    with open(os.path.join(ROOT, target, name), "wb") as f:
        f.write(data)


def points(n=12):
    """A small curved sheet with normals and colours."""
    out = []
    for i in range(n):
        x, y = (i % 4) * 0.5, (i // 4) * 0.5
        z = 0.1 * math.sin(x + y)
        out.append(((x, y, z), (0.0, 0.0, 1.0), (i * 20 % 256, 255 - i * 20 % 256, 7)))
    return out


def ply_header(fmt, n, normals, colours, extra=""):
    h = "ply\nformat %s 1.0\ncomment seed\nelement vertex %d\n" % (fmt, n)
    h += "property float x\nproperty float y\nproperty float z\n"
    if normals:
        h += "property float nx\nproperty float ny\nproperty float nz\n"
    if colours:
        h += "property uchar red\nproperty uchar green\nproperty uchar blue\n"
    return h + extra + "end_header\n"


def ply_seeds():
    pts = points()
    body = "".join("%g %g %g %g %g %g %d %d %d\n" % (*p, *n, *c) for p, n, c in pts)
    write("ply_reader", "ascii_full.ply", ply_header("ascii", len(pts), True, True) + body)
    body = "".join("%g %g %g\n" % p for p, _, _ in pts)
    write("ply_reader", "ascii_xyz.ply", ply_header("ascii", len(pts), False, False) + body)
    for fmt, e in (("binary_little_endian", "<"), ("binary_big_endian", ">")):
        data = b"".join(struct.pack(e + "6f3B", *p, *n, *c) for p, n, c in pts)
        write("ply_reader", fmt + ".ply",
              ply_header(fmt, len(pts), True, True).encode() + data)
    # Doubles, a face element with lists after the vertices, and an unused property.
    h = ("ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty double x\n"
         "property double y\nproperty double z\nproperty short flags\n"
         "element face 2\nproperty list uchar int vertex_indices\nend_header\n")
    data = b"".join(struct.pack("<3dh", i, i % 2, 0.5, i) for i in range(4))
    data += struct.pack("<B3i", 3, 0, 1, 2) + struct.pack("<B3i", 3, 1, 2, 3)
    write("ply_reader", "binary_faces.ply", h.encode() + data)


def pcd_header(fields, sizes, types, n, data):
    return ("# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS %s\nSIZE %s\n"
            "TYPE %s\nCOUNT %s\nWIDTH %d\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS %d\n"
            "DATA %s\n" % (" ".join(fields), " ".join(map(str, sizes)), " ".join(types),
                           " ".join("1" * len(fields)), n, n, data))


def lzf_literals(raw):
    """LZF with literal runs only (a valid stream the reader must decode)."""
    out = bytearray()
    for i in range(0, len(raw), 32):
        chunk = raw[i:i + 32]
        out.append(len(chunk) - 1)
        out += chunk
    return bytes(out)


def lzf_with_backrefs(raw):
    """LZF with a back reference wherever the next 3+ bytes repeat the ones 4 bytes back."""
    out = bytearray()
    lit = bytearray()
    i = 0

    def flush():
        for k in range(0, len(lit), 32):
            chunk = lit[k:k + 32]
            out.append(len(chunk) - 1)
            out.extend(chunk)
        lit.clear()

    while i < len(raw):
        n = 0
        while i >= 4 and i + n < len(raw) and n < 8 and raw[i + n] == raw[i + n - 4]:
            n += 1
        if n >= 3:
            flush()
            out.append(((n - 2) << 5) | 0)
            out.append(3)  # distance 4 = offset 3 + 1
            i += n
        else:
            lit.append(raw[i])
            i += 1
    flush()
    return bytes(out)


def pcd_seeds():
    pts = points()
    n = len(pts)
    fields = ["x", "y", "z", "normal_x", "normal_y", "normal_z", "rgb"]
    sizes = [4] * 7
    types = ["F"] * 7
    rgb = [struct.unpack("<f", struct.pack("<I", (c[0] << 16) | (c[1] << 8) | c[2]))[0]
           for _, _, c in pts]
    body = "".join("%g %g %g %g %g %g %.9g\n" % (*p, *nn, rgb[i])
                   for i, (p, nn, _) in enumerate(pts))
    write("pcd_reader", "ascii.pcd", pcd_header(fields, sizes, types, n, "ascii") + body)
    data = b"".join(struct.pack("<6fI", *p, *nn, (c[0] << 16) | (c[1] << 8) | c[2])
                    for p, nn, c in pts)
    write("pcd_reader", "binary.pcd",
          pcd_header(fields, sizes, types, n, "binary").encode() + data)
    # binary_compressed: fields one after another (structure of arrays), then LZF.
    soa = b"".join(struct.pack("<%df" % n, *[p[k] for p, _, _ in pts]) for k in range(3))
    soa += b"".join(struct.pack("<%df" % n, *[nn[k] for _, nn, _ in pts]) for k in range(3))
    soa += struct.pack("<%dI" % n, *[(c[0] << 16) | (c[1] << 8) | c[2] for _, _, c in pts])
    for name, lzf in (("literals", lzf_literals(soa)), ("backrefs", lzf_with_backrefs(soa))):
        write("pcd_reader", "compressed_%s.pcd" % name,
              pcd_header(fields, sizes, types, n, "binary_compressed").encode() +
              struct.pack("<II", len(lzf), len(soa)) + lzf)
    # Mixed types: double positions, unsigned intensity, a padding field.
    fields = ["x", "y", "z", "intensity", "_"]
    data = b"".join(struct.pack("<3dHB", *p, i, 0) for i, (p, _, _) in enumerate(pts))
    write("pcd_reader", "binary_mixed.pcd",
          pcd_header(fields, [8, 8, 8, 2, 1], ["F", "F", "F", "U", "U"], n, "binary").encode()
          + data)


def xyz_seeds():
    pts = points()
    write("xyz_reader", "xyz.xyz", "".join("%g %g %g\n" % p for p, _, _ in pts))
    write("xyz_reader", "normals.xyz",
          "".join("%g %g %g %g %g %g\n" % (*p, *n) for p, n, _ in pts))
    write("xyz_reader", "colours_comma.txt",
          "# x,y,z,r,g,b\n" + "".join("%g,%g,%g,%d,%d,%d\r\n" % (*p, *c) for p, _, c in pts))
    write("xyz_reader", "pts.pts", "%d\n" % len(pts) +
          "".join("%g %g %g 0 %d %d %d\n" % (*p, *c) for p, _, c in pts))


def las_file(minor, fmt, n, vlrs=(), evlrs=(), scale=0.01, offset=(500000.0, 4500000.0, 0.0),
             extra=0):
    """LAS 1.minor, point format fmt, n points (ASPRS LAS specification R15, sections 2.4-2.16)."""
    lengths = [length + extra for length in [20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67]]
    header_size = {2: 227, 3: 235, 4: 375}[minor]
    vlr_bytes = b"".join(struct.pack("<H16sHH32s", 0, u.encode(), rid, len(d), b"") + d
                         for u, rid, d in vlrs)
    offset_to_points = header_size + len(vlr_bytes)
    recs = b""
    for i in range(n):
        x, y, z = 100 + i * 7, 200 + (i * 13) % 50, i % 5
        r = struct.pack("<iiiH", x, y, z, 1000 + i)
        if fmt < 6:
            r += struct.pack("<BBbBH", 0x09, 2 + i % 3, i % 20 - 10, 0, 1)
        else:
            r += struct.pack("<BBBBhH", 0x11, 0, 2 + i % 3, 0, 100 * i, 1)
        r += b"\0" * (lengths[fmt] - len(r))
        recs += r
    evlr_start = offset_to_points + len(recs)
    h = b"LASF" + struct.pack("<HH16sBB32s32sHHHIIBHI5I", 0, 0, b"", 1, minor, b"seed", b"make_seeds.py",
                              1, 2024, header_size, offset_to_points, len(vlrs), fmt, lengths[fmt],
                              n if fmt < 6 else 0, 0, 0, 0, 0, 0)
    h += struct.pack("<3d3d6d", scale, scale, scale, *offset, 1, 0, 1, 0, 1, 0)
    if minor >= 3:
        h += struct.pack("<Q", 0)
    if minor >= 4:
        h += struct.pack("<QIQ15Q", evlr_start if evlrs else 0, len(evlrs), n, *([0] * 15))
    tail = b"".join(struct.pack("<H16sHQ32s", 0, u.encode(), rid, len(d), b"") + d for u, rid, d in evlrs)
    return h + vlr_bytes + recs + tail


def las_seeds():
    wkt = b'PROJCS["WGS 84 / UTM zone 10N"]\0'
    keys = struct.pack("<8H", 1, 1, 0, 1, 1024, 0, 1, 1)
    write("las_reader", "las12_format1.las", las_file(2, 1, 6, [("LASF_Projection", 34735, keys)]))
    write("las_reader", "las12_format3.las", las_file(2, 3, 5))
    write("las_reader", "las13_format5.las", las_file(3, 5, 3))
    write("las_reader", "las14_format6_wkt.las", las_file(4, 6, 6, [("LASF_Projection", 2112, wkt)]))
    write("las_reader", "las14_format8_evlr.las",
          las_file(4, 8, 4, evlrs=[("LASF_Spec", 3, b"text")]))
    write("las_reader", "las12_extra_bytes.las",
          las_file(2, 0, 4, [("LASF_Spec", 4, b"\0" * 192)], extra=2))


def roundtrip_seeds():
    """Options byte, then 3 bytes per point on the 256³ grid."""
    def grid(flags, cells):
        return bytes([flags]) + b"".join(bytes(c) for c in cells)
    plane = [(x * 8, y * 8, 128) for x in range(20) for y in range(20)]
    write("encode_roundtrip", "plane", grid(0, plane))
    wave = [(x * 6, y * 6, int(128 + 40 * math.sin(x / 4) * math.cos(y / 5)))
            for x in range(30) for y in range(30)]
    write("encode_roundtrip", "wave_normals_colours", grid(0x14 | 1, wave))
    sphere = []
    for i in range(600):
        t = math.acos(1 - 2 * (i + 0.5) / 600)
        p = math.pi * (1 + 5 ** 0.5) * i
        sphere.append(tuple(int(128 + 100 * v) for v in
                            (math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t))))
    write("encode_roundtrip", "sphere_full", grid(0x08 | 2, sphere))
    write("encode_roundtrip", "line_small_patches", grid(0x20, [(i, i, i) for i in range(40)]))
    write("encode_roundtrip", "too_few", grid(0, [(1, 2, 3)] * 10))
    write("encode_roundtrip", "coincident", grid(0, [(9, 9, 9)] * 30))


if __name__ == "__main__":
    ply_seeds()
    pcd_seeds()
    xyz_seeds()
    las_seeds()
    roundtrip_seeds()
