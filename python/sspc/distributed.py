"""Distributed encoding on Dask: the tiles of a tiled encode (sspc.TiledEncoder) run as tasks on a
Dask cluster's workers, and the client joins their results into one .sspc file, byte for byte the
file `sspc.encode(cloud, path, tile_points=N, ...)` writes on one machine.

    python3 -m sspc.distributed encode IN.ply OUT.sspc --tile-points 2000000 --scheduler tcp://host:8786
    python3 -m sspc.distributed encode IN.ply /nfs/OUT.sspc --tile-points 2000000 --scheduler tcp://host:8786 \
        --shared-dir /nfs/scratch        # a folder every machine mounts at the same path
    python3 -m sspc.distributed encode IN.ply OUT.sspc --tile-points 500000 --workers 2   # a local cluster
    python3 -m sspc.distributed encode IN.las OUT.sspc --memory-limit 2G --workers 2   # never held whole

or from Python:

    from dask.distributed import Client
    import sspc.distributed
    stats = sspc.distributed.encode("scan.ply", "scan.sspc", client=Client("tcp://host:8786"),
                                    tile_points=2_000_000, level=5)

How it divides the work: the client reads the cloud (a file in passes, spilling each tile's points
to a file of its own, when given a path), plans the tiles (octree cells of at most tile_points
points, src/encoder/tiling.hpp) and measures the spacing and patch radius they share;
each task gets one tile's job, which carries the tile's points with a margin of its neighbours'
(about 24 bytes a point and a third more for the margin), and returns the tile's model (normals,
patches and code book are the worker's work, nearly all of an encode's time). The client adds
the results as they come, in tile order, then trims the code books, codes the attributes and
writes the file, holding a few jobs and results at a time. On a real cluster every worker needs
the same sspc build and nothing else: without --shared-dir jobs and results travel through the
scheduler, so no shared storage is needed; with a folder every machine mounts at the same path
(NFS, a cluster file system) they travel as files there, copied far fewer times (a local
cluster's default, its folder the output's). What limits the speed-up is the client's reading
and planning and the final write, both serial (on autzen about a tenth of a one-machine encode),
and the results' transfer (a code book of about 50 bytes per point of the tile).
"""

import argparse
import json
import os
import shutil
import sys
import tempfile
import time

from . import TiledEncoder, keep_freed_memory, read

__all__ = ["encode", "main"]


def _run_job(job, threads, result=None):
    """One tile's job on a worker: its bytes, or a job file's path and the result file's (shared
    storage). The extension's functions do not pickle, so the task is this module function, which
    imports it where it runs."""
    # pylint: disable-next=import-outside-toplevel
    from sspc import keep_freed_memory, release_freed_memory, resident_bytes, run_tile_job as run

    keep_freed_memory()  # this worker's allocator (memory_limit bounds the client, not the workers)
    out = run(job, threads=threads, result=result)
    # What the job freed stays kept for the next one until the worker holds 70% of its Dask memory
    # limit (Dask counts kept memory too: it pauses a worker at 80% and restarts it at 95%); the
    # CLI does the same between tiles at 7/8 of its limit (sspc/allocator.hpp).
    limit = _worker_memory_limit()
    if limit and resident_bytes() > limit * 7 // 10:
        release_freed_memory()
    return result if result is not None else out


def _worker_memory_limit():
    """The memory limit of the Dask worker running this task, in bytes; None outside a worker or
    without a limit."""
    from dask.distributed import get_worker  # pylint: disable=import-outside-toplevel

    try:
        return get_worker().memory_manager.memory_limit
    except ValueError:  # not in a worker's task
        return None


def encode(cloud, path, *, client=None, scheduler=None, workers=None, job_threads=None, tile_points=0,
           memory_limit=0, work_dir=None, shared_dir=None, **options):
    """Encodes `cloud` (a PointCloud, or a file's path, which is then read in passes and never held
    whole) into `path` with its tiles run on Dask. Give a `client` (dask.distributed.Client), or a
    `scheduler` address, or neither for a local cluster of `workers` processes (default: one per
    core, one thread each). `job_threads` caps the threads of one job (default: 1 on a local
    cluster, whose workers share the cores; all of a worker's cores otherwise). tile_points bounds a
    tile's points; with a path, memory_limit (bytes) may size them instead, and the tiles wait in
    files of a hidden folder in work_dir (default: the system's temporary folder). The other keyword
    options are sspc.encode's; returns its statistics plus `tiles`, `dask_workers` and the seconds of
    the three stages (plan, tiles, write).

    shared_dir: a folder that the client and every worker see at the same path (a local cluster's
    default: the output's folder). Jobs and results then travel as files in a hidden folder made
    there, and only their paths through the scheduler; without it (a remote cluster's default)
    their bytes travel through the scheduler, which copies them several times. On autzen's 16
    tiles of 1M points (a result about 49 MB) files cut the local client's CPU time from 38-44 s
    to 34 s, most of the difference system time."""
    from dask.distributed import Client, LocalCluster, as_completed

    if not tile_points and not memory_limit:
        raise ValueError("a distributed encode needs tile_points or memory_limit")
    if not (isinstance(cloud, (str, bytes)) or hasattr(cloud, "__fspath__")) and memory_limit:
        raise ValueError("memory_limit needs the cloud as a file's path")
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
    if shared_dir is None and own_cluster is not None:
        shared_dir = os.path.dirname(os.path.abspath(os.fspath(path)))
    keep_freed_memory()  # the tiles are sized with what it keeps (tile_points_for_memory)
    files = tempfile.mkdtemp(prefix=".sspc-dask-", dir=shared_dir) if shared_dir is not None else None
    try:
        start = time.perf_counter()
        tiled = TiledEncoder(cloud, tile_points=tile_points, memory_limit=memory_limit, work_dir=work_dir,
                             **options)
        planned = time.perf_counter()
        tiled.begin(path)
        # Jobs in tile order, no more in flight than two a worker: a job holds its tile's points
        # and a result its code book, and results are written in tile order, so the client holds
        # a few of each at a time whatever the cloud's size.
        in_flight = max(2, 2 * len(client.scheduler_info()["workers"]))
        pending = as_completed()
        owner = {}

        def collect(done):
            t = owner.pop(done.key)
            tiled.add(t, done.result())
            if files is not None:
                os.remove(os.path.join(files, f"{t}.job"))

        for t in range(tiled.tile_count):
            if pending.count() >= in_flight:
                collect(next(pending))
            if files is not None:
                job = os.path.join(files, f"{t}.job")
                tiled.write_job(t, job)
                args = (job, job_threads, os.path.join(files, f"{t}.result"))
            else:
                args = (tiled.job(t), job_threads)
            future = client.submit(_run_job, *args, pure=False, key=f"sspc-tile-{t}")
            owner[future.key] = t
            pending.add(future)
        for done in pending:
            collect(done)
        ran = time.perf_counter()
        stats = tiled.finish()
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
        if files is not None:
            shutil.rmtree(files, ignore_errors=True)


def _size(text):
    """'2G', '512M', '1.5G' or bytes, as sspc encode --memory-limit reads them (powers of 1024)."""
    units = {"": 1, "K": 1 << 10, "k": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40}
    text = text.removesuffix("iB").removesuffix("B") if len(text) > 1 else text
    number = text.rstrip("KkMGT")
    try:
        return int(float(number) * units[text[len(number):]])
    except (KeyError, ValueError):
        raise ValueError(f"--memory-limit: {text!r} is not a size (bytes, or a number with K, M, G or T)") from None


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python3 -m sspc.distributed",
                                     description="Encode a point cloud with its tiles on a Dask cluster.")
    sub = parser.add_subparsers(dest="command", required=True)
    enc = sub.add_parser("encode", help="compress IN into OUT.sspc")
    enc.add_argument("input")
    enc.add_argument("output")
    enc.add_argument("--tile-points", type=int, default=0, help="at most this many points a tile")
    enc.add_argument("--memory-limit", default="0",
                     help="bytes the client may hold (e.g. 2G): the input is read in passes and the tiles sized to it")
    enc.add_argument("--scheduler", help="a Dask scheduler's address (default: a local cluster)")
    enc.add_argument("--workers", type=int, help="local cluster: worker processes (default: one per core)")
    enc.add_argument("--shared-dir",
                     help="a folder the client and every worker see at the same path: jobs and results travel "
                          "as files there (default: the output's folder on a local cluster, none otherwise)")
    enc.add_argument("-l", "--level", type=int, default=5)
    enc.add_argument("--json", action="store_true", help="statistics as JSON on stdout")
    args = parser.parse_args(argv)
    try:
        stats = encode(args.input, args.output, scheduler=args.scheduler, workers=args.workers,
                       tile_points=args.tile_points, memory_limit=_size(args.memory_limit),
                       shared_dir=args.shared_dir, level=args.level)
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
