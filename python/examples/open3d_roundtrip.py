#!/usr/bin/env python3
"""Compress an Open3D point cloud with sspc, report its rate and distortion, and render it.

    python3 open3d_roundtrip.py data/bunny.ply [--level 5] [--png bunny.png] [--sspc bunny.sspc]

With open3d importable, the file is read by Open3D and its arrays handed to sspc, as a program
holding an open3d.geometry.PointCloud would; without it, sspc reads the file itself and says so.
The rendered image is the compressed model ray-traced directly (the paper's §5), its bricks
decoded as rays reach them, and is written with sspc's own PNG writer.
"""

import argparse
import pathlib
import sys
import tempfile
import time

import numpy as np

import sspc


def load(path):
    """An sspc.PointCloud from Open3D's reader when open3d is there, else from sspc's."""
    try:
        import open3d as o3d
    except ImportError:
        print("open3d is not installed: reading the file with sspc.read instead")
        return sspc.read(path)
    o3d_cloud = o3d.io.read_point_cloud(str(path))
    normals = np.asarray(o3d_cloud.normals) if o3d_cloud.has_normals() else None
    colours = (np.asarray(o3d_cloud.colors) * 255).round().astype(np.uint8) if o3d_cloud.has_colors() else None
    print(f"read by open3d {o3d.__version__}")
    return sspc.PointCloud(np.asarray(o3d_cloud.points), normals, colours)  # float64 -> float32, one copy


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("cloud", type=pathlib.Path)
    parser.add_argument("--level", type=int, default=5, help="0 (most detail) .. 9 (smallest)")
    parser.add_argument("--png", type=pathlib.Path, default=pathlib.Path("roundtrip.png"))
    parser.add_argument("--sspc", type=pathlib.Path, help="keep the compressed file here")
    parser.add_argument("--size", type=int, default=512, help="image width and height")
    args = parser.parse_args()

    cloud = load(args.cloud)
    print(f"{args.cloud}: {len(cloud)} points, normals: {cloud.normals is not None}")

    with tempfile.TemporaryDirectory() as scratch:
        path = args.sspc or pathlib.Path(scratch) / "model.sspc"
        stats = sspc.encode(cloud, path, level=args.level)
        model = sspc.CompressedModel.open(path)
        start = time.perf_counter()
        decoded = model.decode_all()
        decode_seconds = time.perf_counter() - start
        report = sspc.eval(cloud, decoded)
        print(f"level {args.level}: {stats['file_bytes']} bytes, {stats['bits_per_point']:.3f} bits per point, "
              f"{stats['patches']} patches, {stats['codewords']} code words, encoded in {stats['seconds']:.2f} s")
        print(f"decoded {len(decoded)} points in {decode_seconds * 1e3:.1f} ms: "
              f"PSNR {report['psnr']:.2f} dB (paper), D1 {report['d1_psnr']:.2f} dB")
        image = sspc.render(model, width=args.size, height=args.size)
    sspc.write_png(image, args.png)
    print(f"rendered the compressed model to {args.png} ({image.shape[1]}x{image.shape[0]})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
