"""sspc: self-similarity compression of point clouds, random-access decoding, and ray tracing.

Hubo, Mertens, Haber and Bekaert, "Self-Similarity-Based Compression of Point Clouds, with
Application to Ray Tracing" (PBG 2007). Arrays go in and come out as numpy arrays:

    import sspc
    cloud = sspc.read("bunny.ply")                 # PointCloud: .positions (N, 3) float32, ...
    stats = sspc.encode(cloud, "bunny.sspc", level=5)
    model = sspc.CompressedModel.open("bunny.sspc")
    decoded = model.decode_all()
    print(stats["bits_per_point"], sspc.eval(cloud, decoded)["psnr"])
    sspc.write_png(sspc.render(model, width=512, height=512), "bunny.png")

Every long call releases the GIL. Library errors raise ValueError (invalid argument),
FileNotFoundError, OSError (I/O) or RuntimeError (malformed or corrupt input, and the rest), with
the library's message.
"""

from ._sspc import (
    CompressedModel,
    PointCloud,
    Scene,
    TiledEncoder,
    __version__,
    encode,
    estimate_normals,
    eval,
    keep_freed_memory,
    read,
    release_freed_memory,
    render,
    resident_bytes,
    run_tile_job,
    synthetic,
    use_one_arena,
    write,
    write_png,
)

__all__ = [
    "CompressedModel",
    "PointCloud",
    "Scene",
    "TiledEncoder",
    "__version__",
    "encode",
    "estimate_normals",
    "eval",
    "keep_freed_memory",
    "read",
    "release_freed_memory",
    "render",
    "resident_bytes",
    "run_tile_job",
    "synthetic",
    "use_one_arena",
    "write",
    "write_png",
]
