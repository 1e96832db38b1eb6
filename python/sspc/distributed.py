"""Distributed encoding on Dask: the tiles of a tiled encode (sspc.TiledEncoder) run as tasks on a
Dask cluster's workers, and the client joins their results into one .sspc file, byte for byte the
file `sspc.encode(cloud, path, tile_points=N, ...)` writes on one machine.

    python3 -m sspc.distributed encode IN.ply OUT.sspc --tile-points 2000000 --scheduler tcp://host:8786
    python3 -m sspc.distributed encode IN.ply OUT.sspc --tile-points 500000 --workers 2   # a local cluster

or from Python:

    from dask.distributed import Client
    import sspc.distributed
    stats = sspc.distributed.encode("scan.ply", "scan.sspc", client=Client("tcp://host:8786"),
                                    tile_points=2_000_000, level=5)

How it divides the work: the client reads the cloud, plans the tiles (octree cells of at most
tile_points points, src/encoder/tiling.hpp) and measures the spacing and patch radius they share;
each task gets one tile's job, which carries the tile's points with a margin of its neighbours'
(about 24 bytes a point and a third more for the margin), and returns the tile's model (normals,
patches and code book are the worker's work, nearly all of an encode's time). The client then
joins the models, codes the attributes and writes the file. On a real cluster every worker needs
the same sspc build and nothing else: jobs travel through the scheduler, so no shared storage is
needed; what limits the speed-up is the client's reading and planning and the final write, both
serial (on autzen about a tenth of a one-machine encode), and the jobs' transfer over the network.
"""

import argparse
import json
import sys
import time

from . import TiledEncoder, read

__all__ = ["encode", "main"]


def _run_job(job, threads):
    """One tile's job on a worker. The extension's functions do not pickle, so the task is this
    module function, which imports it where it runs."""
    from sspc import run_tile_job as run  # pylint: disable=import-outside-toplevel

    return run(job, threads=threads)


def encode(cloud, path, *, client=None, scheduler=None, workers=None, job_threads=None, tile_points,
           **options):
    """Encodes `cloud` (a PointCloud or a path sspc.read reads) into `path` with its tiles run on
    Dask. Give a `client` (dask.distributed.Client), or a `scheduler` address, or neither for a
    local cluster of `workers` processes (default: one per core, one thread each). `job_threads`
    caps the threads of one job (default: 1 on a local cluster, whose workers share the cores; all
    of a worker's cores otherwise). The keyword options are sspc.encode's; returns its statistics
    plus `tiles`, `dask_workers` and the seconds of the three stages (plan, tiles, write)."""
    from dask.distributed import Client, LocalCluster, as_completed

    if isinstance(cloud, (str, bytes)) or hasattr(cloud, "__fspath__"):
        cloud = read(cloud)
    own_cluster = None
    if client is None:
        if scheduler is not None:
            client = Client(scheduler)
        else:
            own_cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                       dashboard_address=None)
            client = Client(own_cluster)
    if job_threads is None:
        job_threads = 1 if own_cluster is not None else 0
    try:
        start = time.perf_counter()
        tiled = TiledEncoder(cloud, tile_points=tile_points, **options)
        planned = time.perf_counter()
        # Largest tiles first, so that a long one does not start last, and no more jobs in flight
        # than two a worker: a job holds its tile's points, so the client never holds them all.
        order = sorted(range(tiled.tile_count), key=lambda t: -tiled.tile_points(t))
        in_flight = max(2, 2 * len(client.scheduler_info()["workers"]))
        results = [None] * tiled.tile_count
        pending = as_completed()
        owner = {}
        for t in order:
            if pending.count() >= in_flight:
                done = next(pending)
                results[owner.pop(done.key)] = done.result()
            future = client.submit(_run_job, tiled.job(t), job_threads, pure=False, key=f"sspc-tile-{t}")
            owner[future.key] = t
            pending.add(future)
        for done in pending:
            results[owner.pop(done.key)] = done.result()
        ran = time.perf_counter()
        stats = tiled.write(path, results)
        stats["seconds"] = time.perf_counter() - start
        stats["plan_seconds"] = planned - start
        stats["tiles_seconds"] = ran - planned
        stats["write_seconds"] = stats["seconds"] - (ran - start)
        stats["dask_workers"] = len(client.scheduler_info()["workers"])
        return stats
    finally:
        if own_cluster is not None:
            client.close()
            own_cluster.close()


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python3 -m sspc.distributed",
                                     description="Encode a point cloud with its tiles on a Dask cluster.")
    sub = parser.add_subparsers(dest="command", required=True)
    enc = sub.add_parser("encode", help="compress IN into OUT.sspc")
    enc.add_argument("input")
    enc.add_argument("output")
    enc.add_argument("--tile-points", type=int, required=True, help="at most this many points a tile")
    enc.add_argument("--scheduler", help="a Dask scheduler's address (default: a local cluster)")
    enc.add_argument("--workers", type=int, help="local cluster: worker processes (default: one per core)")
    enc.add_argument("-l", "--level", type=int, default=5)
    enc.add_argument("--json", action="store_true", help="statistics as JSON on stdout")
    args = parser.parse_args(argv)
    try:
        stats = encode(args.input, args.output, scheduler=args.scheduler, workers=args.workers,
                       tile_points=args.tile_points, level=args.level)
    except (OSError, ValueError, RuntimeError) as e:
        print(f"sspc.distributed: {e}", file=sys.stderr)
        return 1
    if args.json:
        print(json.dumps(stats, indent=2))
    else:
        print(f"{args.input}: {stats['points']} points -> {args.output}: {stats['file_bytes']} bytes "
              f"({stats['bits_per_point']:.3f} bits per point), {stats['tiles']} tiles on "
              f"{stats['dask_workers']} workers, {stats['seconds']:.2f} s (plan {stats['plan_seconds']:.2f}, "
              f"tiles {stats['tiles_seconds']:.2f}, write {stats['write_seconds']:.2f})")
    return 0


if __name__ == "__main__":
    # Run as the installed module, not as __main__, so that tasks pickle by reference.
    from sspc.distributed import main as _main  # pylint: disable=import-self

    sys.exit(_main())
