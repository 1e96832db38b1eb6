"""Distributed encoding on Dask: the tiles of a tiled encode (sspc.TiledEncoder) run as tasks on a
Dask cluster's workers, and the client joins their results into one .sspc file, byte for byte the
file `sspc.encode(cloud, path, tile_points=N, ...)` writes on one machine.

    python3 -m sspc.distributed encode IN.ply OUT.sspc --tile-points 2000000 --scheduler tcp://host:8786
    python3 -m sspc.distributed encode IN.ply /nfs/OUT.sspc --tile-points 2000000 --scheduler tcp://host:8786 \
        --shared-dir /nfs/scratch        # a folder every machine mounts at the same path
    python3 -m sspc.distributed encode IN.ply OUT.sspc --tile-points 500000 --workers 2   # a local cluster
    python3 -m sspc.distributed encode tiles/ OUT.sspc --memory-limit 2G --workers 2   # a folder of tiles as one cloud
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
patches and code book are the worker's work, nearly all of an encode's time). The client keeps
each result as it comes in the staging folder (below), adds them in tile order, then trims the
code books, codes the attributes and writes the file, holding a job and a result or two at a
time. On a real cluster every worker needs the same sspc build and nothing else: without
--shared-dir jobs and results travel through the scheduler, so no shared storage is needed; with
a folder every machine mounts at the same path (NFS, a cluster file system) they travel as files
there, copied far fewer times (a local cluster's default, its folder the output's). What limits
the speed-up is the client's reading and planning and the final write, both serial (on autzen
about a tenth of a one-machine encode), and the results' transfer (a code book of about 50 bytes
per point of the tile).

Options are checked before a cluster starts or the input is read (ValueError; the command exits
with status 2). The output may not be the input, nor exist unless force=True (--force).

Resuming: the finished tiles' results are kept in a hidden staging folder beside the output,
`.<output name>.sspc-tiles/`, one file `<t>.result` a tile, each written whole or not at all; the
folder goes once the output is written. A run that stops early (the client killed, the Dask
cluster lost: then the command says so in one line and exits with status 1) leaves no output and
keeps the folder, and the same command run again, on any cluster, adds the kept results instead
of running their tiles again: a result is deterministic, so the output is byte for byte the one
an uninterrupted run writes. A kept result of another input, options or sspc build, or damaged,
is refused where its turn comes and its tile run again.
"""

import argparse
import asyncio
import concurrent.futures
import contextlib
import errno
import json
import logging
import operator
import os
import shutil
import sys
import tempfile
import time
import uuid

from . import TiledEncoder, keep_freed_memory

__all__ = ["ClusterLost", "UsageError", "encode", "main"]


class UsageError(ValueError):
    """An option out of range, found before anything starts (the command's exit status 2)."""


class ClusterLost(RuntimeError):
    """The Dask cluster (scheduler or workers) went away during an encode; the finished tiles are
    kept in the staging folder, for the same encode run again to resume."""


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


def _cluster_errors():
    """The exceptions by which Dask reports a lost scheduler or workers: a connection's
    (CommClosedError and TimeoutError are OSErrors), the futures a client cancels when it loses
    its scheduler (newer Dask's FutureCancelledError derives from concurrent.futures'), and
    KilledWorker, a task whose workers kept dying."""
    from distributed import KilledWorker  # pylint: disable=import-outside-toplevel

    return (OSError, asyncio.CancelledError, concurrent.futures.CancelledError, KilledWorker)


class _Tiles:
    """A tiled encode's results on their way from the workers into the model. Each is kept in the
    staging folder as it comes, and added to the model in tile order only: TiledEncoder.add checks
    a result once every tile before it is written, so a result kept from an earlier run is
    checked when it is added, and its tile run again if it is refused."""

    def __init__(self, tiled, client, staging, files, job_threads):
        from dask.distributed import as_completed  # pylint: disable=import-outside-toplevel

        self.tiled = tiled
        self.client = client
        self.staging = staging
        self.files = files  # the shared folder of jobs and results as files, or None: as bytes
        self.job_threads = job_threads
        self.kept = {t for t in range(tiled.tile_count) if os.path.exists(self.result(t))}
        self.ready = set(self.kept)  # tiles whose result is in the staging folder, not yet added
        self.next_tile = 0  # the next tile to add
        self.resumed = 0
        self.pending = as_completed()
        self.owner = {}  # a future's key: its tile
        # Keys of this run's own: an earlier run's task may linger on the scheduler.
        self.run_id = uuid.uuid4().hex[:12]
        self.errors = _cluster_errors()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        # The encoder dropped now, not when a traceback that holds this object goes: a failed
        # encode's temporary output file goes with it.
        self.tiled = None

    def result(self, t):
        return os.path.join(self.staging, f"{t}.result")

    def run(self, in_flight):
        """Runs the tiles without a kept result, in tile order, no more than in_flight at a time,
        and adds every result."""
        to_run = [t for t in range(self.tiled.tile_count) if t not in self.kept]
        self.add_ready()
        for t in to_run:
            while self.pending.count() >= in_flight:
                self.collect()
            self.submit(t)
        while self.pending.count():
            self.collect()

    def submit(self, t):
        if self.files is None:
            args = (self.tiled.job(t), self.job_threads)
        else:
            job = os.path.join(self.files, f"{t}.job")
            self.tiled.write_job(t, job)
            args = (job, self.job_threads, os.path.join(self.files, f"{t}.result"))
        future = self.dask(self.client.submit, _run_job, *args, pure=False, key=f"sspc-tile-{t}-{self.run_id}")
        self.owner[future.key] = t
        self.pending.add(future)

    def collect(self):
        """Waits for a result, keeps it, and adds the results that are then in tile order."""
        done = self.dask(next, self.pending)
        t = self.owner.pop(done.key)
        result = self.dask(done.result)
        if self.files is None:
            _write_atomically(self.result(t), result)
        else:
            _move(result, self.result(t))
            os.remove(os.path.join(self.files, f"{t}.job"))
        self.ready.add(t)
        self.add_ready()

    def add_ready(self):
        while self.next_tile in self.ready:
            t = self.next_tile
            with open(self.result(t), "rb") as file:
                result = file.read()  # bytes: a path would be removed once added
            try:
                self.tiled.add(t, result)
            except ValueError:
                if t not in self.kept:
                    raise
                # Kept from a run of another input, options or build, or damaged: run it again.
                self.kept.discard(t)
                self.ready.discard(t)
                os.remove(self.result(t))
                self.submit(t)
                return
            self.ready.discard(t)
            self.resumed += t in self.kept
            self.next_tile += 1

    def dask(self, call, *args, **kwargs):
        """call(*args, **kwargs), a call to Dask, with a lost cluster raised as ClusterLost."""
        try:
            return call(*args, **kwargs)
        except self.errors as e:
            raise ClusterLost(self.lost(e)) from e

    def lost(self, error):
        finished = self.next_tile + len(self.ready)  # the result files in the staging folder
        what = f"{type(error).__name__}: {error}" if str(error) else type(error).__name__
        text = f"the Dask cluster was lost after {finished} of {self.tiled.tile_count} tiles ({what})"
        if finished:
            text += f"; the {finished} finished tiles are kept in {self.staging}"
        return text + ": run the same command again to resume"


def _write_atomically(path, data):
    """data in a file of its own at `path`, renamed there once written whole: a client killed
    meanwhile leaves a temporary file, never a short result."""
    fd, temporary = tempfile.mkstemp(prefix=".", suffix=".tmp", dir=os.path.dirname(path))
    try:
        with os.fdopen(fd, "wb") as file:
            file.write(data)
        os.replace(temporary, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.remove(temporary)
        raise


def _move(source, path):
    """A worker's result file moved to `path`: renamed, or copied from another file system."""
    try:
        os.replace(source, path)
    except OSError as e:
        if e.errno != errno.EXDEV:
            raise
        with open(source, "rb") as file:
            _write_atomically(path, file.read())
        os.remove(source)


def _staging_folder(path):
    """Where the finished tiles' results wait: hidden beside the output, on its file system."""
    out = os.path.abspath(os.fsdecode(os.fspath(path)))
    return os.path.join(os.path.dirname(out), f".{os.path.basename(out)}.sspc-tiles")


def _is_path(cloud):
    return isinstance(cloud, (str, bytes)) or hasattr(cloud, "__fspath__")


def _input_paths(cloud):
    """The paths `cloud` names: one path, or a list or tuple of them (files, folders, patterns read
    as one cloud); None for a cloud in memory."""
    if _is_path(cloud):
        return [cloud]
    if isinstance(cloud, (list, tuple)) and cloud and all(_is_path(c) for c in cloud):
        return list(cloud)
    return None


def _check_integer(name, value, least, most=None):
    try:
        if isinstance(value, bool):
            raise TypeError
        number = operator.index(value)
    except TypeError:
        number = None
    if number is None or number < least or (most is not None and number > most):
        bounds = f"from {least} to {most}" if most is not None else f"of at least {least}"
        raise UsageError(f"{name} must be an integer {bounds}, not {value!r}")


def _same_file(a, b):
    a, b = os.fsdecode(os.fspath(a)), os.fsdecode(os.fspath(b))
    if os.path.exists(a) and os.path.exists(b):
        return os.path.samefile(a, b)
    return os.path.normcase(os.path.abspath(a)) == os.path.normcase(os.path.abspath(b))


def _check_output(source, path, force):
    """The output's folder must exist; the output may not be the input (a file's path, or None),
    nor exist unless forced."""
    out = os.path.abspath(os.fsdecode(os.fspath(path)))
    folder = os.path.dirname(out)
    if not os.path.isdir(folder):
        raise UsageError(f"{path}: no folder {folder}")
    if source is not None and _same_file(source, out):
        raise UsageError(f"{path} is the input: give another output")
    if os.path.isdir(out):
        raise UsageError(f"{path} is a folder")
    if os.path.lexists(out) and not force:
        raise UsageError(f"{path} exists (force=True, or --force, overwrites it)")


def _check(cloud, path, *, workers, job_threads, tile_points, memory_limit, level, force):
    """Every option checked before a cluster starts or anything is read: UsageError for the first
    one out of range, FileNotFoundError for a missing input."""
    if workers is not None:
        _check_integer("workers", workers, 1)
    if job_threads is not None:
        _check_integer("job_threads", job_threads, 0)
    _check_integer("tile_points", tile_points, 0)
    _check_integer("memory_limit", memory_limit, 0)
    _check_integer("level", level, 0, 9)
    if not tile_points and not memory_limit:
        raise UsageError("a distributed encode needs tile_points or memory_limit")
    inputs = _input_paths(cloud)
    if memory_limit and inputs is None:
        raise UsageError("memory_limit needs the cloud as a file's path")
    for source in inputs or [None]:
        _check_output(source, path, force)
    for source in inputs or []:
        name = os.fsdecode(os.fspath(source))
        if not os.path.exists(name) and not any(c in name for c in "*?["):  # a pattern is expanded later
            raise FileNotFoundError(errno.ENOENT, os.strerror(errno.ENOENT), name)


@contextlib.contextmanager
def _logs_muted():
    """Logging silenced: closing a client whose scheduler is gone logs the reconnection it cancels
    as errors, tracebacks and all, some under the name of whatever module Dask's frame is in
    (asyncio's), when the one line that says so is enough. All loggers, for the moment it takes."""
    was = logging.root.manager.disable
    logging.disable(logging.CRITICAL)
    try:
        yield
    finally:
        logging.disable(was)


def encode(cloud, path, *, client=None, scheduler=None, workers=None, job_threads=None, tile_points=0,
           memory_limit=0, work_dir=None, shared_dir=None, force=False, **options):
    """Encodes `cloud` (a PointCloud, or a file's path or a list of paths, which are then read in
    passes as one cloud and never held whole) into `path` with its tiles run on Dask. Give a `client` (dask.distributed.Client), or a
    `scheduler` address, or neither for a local cluster of `workers` processes (default: one per
    core, one thread each). `job_threads` caps the threads of one job (default: 1 on a local
    cluster, whose workers share the cores; all of a worker's cores otherwise). tile_points bounds a
    tile's points; with a path, memory_limit (bytes) may size them instead, and the tiles wait in
    files of a hidden folder in work_dir (default: the system's temporary folder). `path` may not
    exist unless `force`. The other keyword options are sspc.encode's; returns its statistics plus
    `tiles`, `resumed_tiles` (kept from an earlier run), `dask_workers` and the seconds of the
    three stages (plan, tiles, write).

    Raises UsageError (a ValueError) for an option out of range before a cluster starts or the
    input is read, and ClusterLost (a RuntimeError) when the cluster goes away: the finished
    tiles are then kept in the staging folder (see the module's documentation) for the same call
    to resume.

    shared_dir: a folder that the client and every worker see at the same path (a local cluster's
    default: the output's folder). Jobs and results then travel as files in a hidden folder made
    there, and only their paths through the scheduler; without it (a remote cluster's default)
    their bytes travel through the scheduler, which copies them several times. On autzen's 16
    tiles of 1M points (a result about 49 MB) files cut the local client's CPU time from 38-44 s
    to 34 s, most of the difference system time."""
    _check(cloud, path, workers=workers, job_threads=job_threads, tile_points=tile_points,
           memory_limit=memory_limit, level=options.get("level", 5), force=force)
    from dask.distributed import Client, LocalCluster  # pylint: disable=import-outside-toplevel

    own_client = client is None
    own_cluster = None
    if own_client:
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
    lost = False
    try:
        return _encode(client, cloud, path, job_threads=job_threads, tile_points=tile_points,
                       memory_limit=memory_limit, work_dir=work_dir, shared_dir=shared_dir, options=options)
    except ClusterLost:
        lost = True
        raise
    finally:
        if own_client:
            with _logs_muted() if lost else contextlib.nullcontext():
                client.close()
                if own_cluster is not None:
                    own_cluster.close()


def _encode(client, cloud, path, *, job_threads, tile_points, memory_limit, work_dir, shared_dir, options):
    keep_freed_memory()  # the tiles are sized with what it keeps (tile_points_for_memory)
    staging = _staging_folder(path)
    os.makedirs(staging, exist_ok=True)
    files = tempfile.mkdtemp(prefix=".sspc-dask-", dir=shared_dir) if shared_dir is not None else None
    try:
        start = time.perf_counter()
        tiled = TiledEncoder(cloud, tile_points=tile_points, memory_limit=memory_limit, work_dir=work_dir, **options)
        with _Tiles(tiled, client, staging, files, job_threads) as tiles:
            del tiled  # held by tiles alone, which drops it on a failure
            planned = time.perf_counter()
            tiles.tiled.begin(path)
            # Jobs in tile order, no more in flight than two a worker: a job holds its tile's
            # points and a result its code book, and the results wait in the staging folder, so
            # the client holds a few of each at a time whatever the cloud's size.
            tiles.run(max(2, 2 * len(client.scheduler_info()["workers"])))
            ran = time.perf_counter()
            stats = tiles.tiled.finish()
            stats["resumed_tiles"] = tiles.resumed
        shutil.rmtree(staging)  # only once the output is written: until then a rerun resumes
        stats["seconds"] = time.perf_counter() - start
        stats["plan_seconds"] = planned - start
        stats["tiles_seconds"] = ran - planned
        stats["write_seconds"] = stats["seconds"] - (ran - start)
        stats["dask_workers"] = len(client.scheduler_info()["workers"])
        return stats
    finally:
        if files is not None:
            shutil.rmtree(files, ignore_errors=True)
        with contextlib.suppress(OSError):  # only when empty: nothing to resume
            os.rmdir(staging)


def _size(text):
    """'2G', '512M', '1.5G' or bytes, as sspc encode --memory-limit reads them (powers of 1024)."""
    units = {"": 1, "K": 1 << 10, "k": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40}
    text = text.removesuffix("iB").removesuffix("B") if len(text) > 1 else text
    number = text.rstrip("KkMGT")
    try:
        return int(float(number) * units[text[len(number):]])
    except (KeyError, ValueError):
        raise UsageError(f"--memory-limit: {text!r} is not a size (bytes, or a number with K, M, G or T)") from None


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python3 -m sspc.distributed",
                                     description="Encode a point cloud with its tiles on a Dask cluster.")
    sub = parser.add_subparsers(dest="command", required=True)
    enc = sub.add_parser("encode", help="compress IN into OUT.sspc")
    enc.add_argument("input", nargs="+",
                     help="point clouds read as one (several files, a folder, or a quoted pattern such as 'tiles/*.las')")
    enc.add_argument("output")
    enc.add_argument("-f", "--force", action="store_true", help="overwrite OUT if it exists")
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
    # Dask's information lines are not this command's output (a local cluster silences them too):
    # when the scheduler goes, its client logs the closed connection with a traceback.
    logging.getLogger("distributed").setLevel(logging.WARNING)
    try:
        source = args.input[0] if len(args.input) == 1 else args.input
        stats = encode(source, args.output, scheduler=args.scheduler, workers=args.workers,
                       tile_points=args.tile_points, memory_limit=_size(args.memory_limit),
                       shared_dir=args.shared_dir, force=args.force, level=args.level)
    except UsageError as e:
        print(f"sspc.distributed: {e}", file=sys.stderr)
        return 2
    except (OSError, ValueError, RuntimeError) as e:
        print(f"sspc.distributed: {e}", file=sys.stderr)
        return 1
    if args.json:
        print(json.dumps(stats, indent=2))
    else:
        resumed = f", {stats['resumed_tiles']} kept from an earlier run" if stats["resumed_tiles"] else ""
        print(f"{' '.join(args.input)}: {stats['points']} points -> {args.output}: {stats['file_bytes']} bytes "
              f"({stats['bits_per_point']:.3f} bits per point), {stats['tiles']} tiles{resumed} on "
              f"{stats['dask_workers']} workers, {stats['seconds']:.2f} s (plan {stats['plan_seconds']:.2f}, "
              f"tiles {stats['tiles_seconds']:.2f}, write {stats['write_seconds']:.2f})")
    return 0


if __name__ == "__main__":
    # Run as the installed module, not as __main__, so that tasks pickle by reference.
    from sspc.distributed import main as _main  # pylint: disable=import-self

    sys.exit(_main())
