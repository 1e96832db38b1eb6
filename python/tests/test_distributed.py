"""sspc.distributed: a tiled encode whose tiles run as tasks on a local Dask cluster of worker
processes writes the same bytes as sspc.encode with the same tiles on one machine."""

import json
import os
import socket
import subprocess
import sys
import time

import pytest

import sspc

distributed = pytest.importorskip("dask.distributed")


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       dashboard_address=None)
    with distributed.Client(cluster) as c:
        yield c
    cluster.close()


def test_tiles_on_dask_give_the_bytes_of_a_local_tiled_encode(bunny, client, tmp_path):
    import sspc.distributed  # pylint: disable=import-outside-toplevel

    local = tmp_path / "local.sspc"
    on_dask = tmp_path / "dask.sspc"
    expected = sspc.encode(bunny, local, tile_points=9000, level=6)
    stats = sspc.distributed.encode(bunny, on_dask, client=client, tile_points=9000, level=6)
    assert stats["tiles"] == expected["tiles"] > 1
    assert stats["dask_workers"] == 2
    assert on_dask.read_bytes() == local.read_bytes()


def test_tiled_encoder_jobs_run_anywhere_in_any_order(bunny, tmp_path):
    tiled = sspc.TiledEncoder(bunny, tile_points=9000, level=6)
    jobs = [tiled.job(t) for t in range(tiled.tile_count)]
    results = [None] * len(jobs)
    for t in reversed(range(len(jobs))):  # finishing order does not matter
        results[t] = sspc.run_tile_job(jobs[t])
    assert sspc.run_tile_job(jobs[0]) == results[0]  # deterministic
    tiled.write(tmp_path / "a.sspc", results)
    sspc.encode(bunny, tmp_path / "b.sspc", tile_points=9000, level=6)
    assert (tmp_path / "a.sspc").read_bytes() == (tmp_path / "b.sspc").read_bytes()
    with pytest.raises(ValueError, match="results for"):
        tiled.write(tmp_path / "c.sspc", results[:-1])
    with pytest.raises(ValueError, match="tile 0"):
        tiled.write(tmp_path / "c.sspc", [b"junk"] + results[1:])
    # A mis-routed or replayed result names its tile and its job: refused for another tile, and
    # a result of another plan (another level) refused for its own tile number.
    with pytest.raises(ValueError, match="the result of tile 1 given for tile 0"):
        tiled.write(tmp_path / "c.sspc", [results[1]] + results[1:])
    other = sspc.TiledEncoder(bunny, tile_points=9000, level=5)
    with pytest.raises(ValueError, match="another job"):
        tiled.write(tmp_path / "c.sspc", [sspc.run_tile_job(other.job(0))] + results[1:])
    assert not (tmp_path / "c.sspc").exists()
    with pytest.raises(RuntimeError):
        sspc.run_tile_job(b"SSPCTJ02" + b"\0" * 10)


def test_jobs_and_results_as_files_give_the_same_bytes(bunny, tmp_path):
    tiled = sspc.TiledEncoder(bunny, tile_points=9000, level=6)
    expected = tmp_path / "bytes.sspc"
    tiled.write(expected, [sspc.run_tile_job(tiled.job(t)) for t in range(tiled.tile_count)])
    tiled.begin(tmp_path / "files.sspc")
    for t in reversed(range(tiled.tile_count)):
        job, result = tmp_path / f"{t}.job", tmp_path / f"{t}.result"
        tiled.write_job(t, job)
        assert job.read_bytes() == tiled.job(t)
        assert sspc.run_tile_job(job, result=result, threads=1) is None
        tiled.add(t, result)  # held as a path until its turn
    tiled.finish()
    assert (tmp_path / "files.sspc").read_bytes() == expected.read_bytes()
    assert not list(tmp_path.glob("*.result"))  # each removed once added
    tiled.begin(tmp_path / "bad.sspc")
    (tmp_path / "junk.result").write_bytes(b"junk")
    with pytest.raises(ValueError, match="junk.result"):
        tiled.add(0, tmp_path / "junk.result")
    with pytest.raises(ValueError, match="missing.result"):
        tiled.add(0, tmp_path / "missing.result")
    with pytest.raises(ValueError, match="result path"):
        sspc.run_tile_job(tmp_path / "0.job")
    with pytest.raises(OSError, match="no.job"):
        sspc.run_tile_job(tmp_path / "no.job", result=tmp_path / "x.result")


def test_a_file_read_in_passes_gives_the_bytes_of_the_cloud_in_memory(bunny, bunny_path, tmp_path):
    # The input never held whole: three passes over the file, one file per tile in work_dir.
    in_memory = sspc.encode(bunny, tmp_path / "memory.sspc", tile_points=9000, level=6)
    work = tmp_path / "work"
    work.mkdir()
    tiled = sspc.TiledEncoder(bunny_path, tile_points=9000, level=6, work_dir=work)
    assert tiled.tile_count == in_memory["tiles"] and tiled.points == len(bunny)
    assert len(list(work.iterdir())) == 1  # the tiles' hidden folder
    tiled.begin(tmp_path / "file.sspc")
    for t in reversed(range(tiled.tile_count)):  # held until their turn, then written in order
        tiled.add(t, sspc.run_tile_job(tiled.job(t)))
        with pytest.raises(ValueError, match="given twice"):
            tiled.add(t, b"")
    stats = tiled.finish()
    assert stats["points"] == len(bunny)
    assert (tmp_path / "file.sspc").read_bytes() == (tmp_path / "memory.sspc").read_bytes()
    del tiled
    assert not list(work.iterdir())  # removed with the encoder
    # sspc.encode from the path under a memory limit: the same bytes again.
    sspc.encode(bunny_path, tmp_path / "limit.sspc", tile_points=9000, memory_limit=1 << 30, level=6)
    assert (tmp_path / "limit.sspc").read_bytes() == (tmp_path / "memory.sspc").read_bytes()


def test_dask_from_a_file_under_a_memory_limit(bunny_path, client, tmp_path):
    import sspc.distributed  # pylint: disable=import-outside-toplevel

    sspc.encode(bunny_path, tmp_path / "local.sspc", tile_points=9000, memory_limit=1 << 30, level=6)
    # Jobs and results as files in a folder the workers share (the paths alone through the scheduler).
    stats = sspc.distributed.encode(bunny_path, tmp_path / "dask.sspc", client=client, tile_points=9000,
                                    memory_limit=1 << 30, work_dir=tmp_path, shared_dir=tmp_path, level=6)
    assert stats["tiles"] > 1
    assert (tmp_path / "dask.sspc").read_bytes() == (tmp_path / "local.sspc").read_bytes()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dask.sspc", "local.sspc"]  # nothing left behind
    with pytest.raises(ValueError, match="file's path"):
        sspc.distributed.encode(sspc.read(bunny_path), tmp_path / "x.sspc", client=client, memory_limit=1 << 30)


def test_a_worker_knows_its_memory_limit_and_its_resident_size(client):
    import sspc.distributed  # pylint: disable=import-outside-toplevel

    assert sspc.distributed._worker_memory_limit() is None  # pylint: disable=protected-access
    limits = client.run(lambda: sspc.distributed._worker_memory_limit())  # pylint: disable=protected-access
    expected = {address: info["memory_limit"] for address, info in client.scheduler_info()["workers"].items()}
    assert limits == expected and all(limit > 0 for limit in limits.values())


def test_resident_bytes_is_the_processs_and_release_gives_back_what_was_freed():
    with open("/proc/self/status", encoding="ascii") as status:
        rss = next(int(line.split()[1]) * 1024 for line in status if line.startswith("VmRSS:"))
    assert abs(sspc.resident_bytes() - rss) < rss // 10
    sspc.keep_freed_memory()
    held = bytearray(64 << 20)  # touched: zero-filled
    held[::4096] = b"\1" * len(held[::4096])
    before = sspc.resident_bytes()
    del held
    sspc.release_freed_memory()
    assert sspc.resident_bytes() < before - (32 << 20)


# Checks before anything starts, resumable runs, and a lost cluster.


def _refuse_to_start(monkeypatch):
    """Makes starting a cluster or reading the input fail the test."""
    import sspc.distributed  # pylint: disable=import-outside-toplevel

    def started(*args, **kwargs):
        raise AssertionError("a cluster started or the input was read before the options were checked")

    monkeypatch.setattr(distributed, "Client", started)
    monkeypatch.setattr(distributed, "LocalCluster", started)
    monkeypatch.setattr(sspc.distributed, "TiledEncoder", started)


@pytest.mark.parametrize("options, message", [
    ({"workers": 0}, "workers must be an integer of at least 1, not 0"),
    ({"workers": -1}, "workers must be an integer of at least 1, not -1"),
    ({"workers": 1.5}, "workers must be an integer"),
    ({"workers": True}, "workers must be an integer"),
    ({"tile_points": -1}, "tile_points must be an integer of at least 0"),
    ({"tile_points": "9000"}, "tile_points must be an integer"),
    ({"level": 10}, "level must be an integer from 0 to 9, not 10"),
    ({"level": -1}, "level must be an integer from 0 to 9"),
    ({"job_threads": -1}, "job_threads must be an integer of at least 0"),
    ({"memory_limit": -1}, "memory_limit must be an integer of at least 0"),
    ({"tile_points": 0}, "needs tile_points or memory_limit"),
])
def test_options_are_checked_before_a_cluster_starts(bunny_path, tmp_path, monkeypatch, options, message):
    import sspc.distributed  # pylint: disable=import-outside-toplevel

    _refuse_to_start(monkeypatch)
    options = {"tile_points": 9000, **options}
    with pytest.raises(sspc.distributed.UsageError, match=message):
        sspc.distributed.encode(bunny_path, tmp_path / "out.sspc", **options)
    assert issubclass(sspc.distributed.UsageError, ValueError)
    assert not list(tmp_path.iterdir())


def test_the_output_is_checked_before_a_cluster_starts(bunny_path, tmp_path, monkeypatch):
    import sspc.distributed  # pylint: disable=import-outside-toplevel

    _refuse_to_start(monkeypatch)
    encode = sspc.distributed.encode
    with pytest.raises(ValueError, match="is the input"):
        encode(bunny_path, bunny_path, tile_points=9000, force=True)
    (tmp_path / "link.ply").symlink_to(bunny_path)
    with pytest.raises(ValueError, match="is the input"):
        encode(tmp_path / "link.ply", bunny_path, tile_points=9000, force=True)  # the same file by another name
    with pytest.raises(ValueError, match="is the input"):  # neither exists: the same path
        encode(tmp_path / "a" / ".." / "x.ply", tmp_path / "x.ply", tile_points=9000)
    (tmp_path / "old.sspc").write_bytes(b"old")
    with pytest.raises(ValueError, match="old.sspc exists"):
        encode(bunny_path, tmp_path / "old.sspc", tile_points=9000)
    with pytest.raises(ValueError, match="no folder"):
        encode(bunny_path, tmp_path / "missing" / "out.sspc", tile_points=9000)
    with pytest.raises(ValueError, match="is a folder"):
        encode(bunny_path, tmp_path, tile_points=9000, force=True)
    with pytest.raises(FileNotFoundError, match="missing.ply"):
        encode(tmp_path / "missing.ply", tmp_path / "out.sspc", tile_points=9000)
    assert (tmp_path / "old.sspc").read_bytes() == b"old"


@pytest.mark.parametrize("arguments, status", [
    (["--workers", "0"], 2),
    (["--workers", "-1"], 2),
    (["-l", "10"], 2),
    (["--tile-points", "-5"], 2),
    (["--memory-limit", "2X"], 2),
    (["--memory-limit", "-1"], 2),
    (["--exists"], 2),
    (["--missing-input"], 1),
])
def test_the_command_refuses_bad_values_in_one_line(bunny_path, tmp_path, monkeypatch, capsys, arguments, status):
    import sspc.distributed  # pylint: disable=import-outside-toplevel

    _refuse_to_start(monkeypatch)
    source, output = str(bunny_path), tmp_path / "out.sspc"
    if arguments == ["--exists"]:
        output.write_bytes(b"old")
        arguments = []
    if arguments == ["--missing-input"]:
        source = str(tmp_path / "missing.ply")
        arguments = []
    assert sspc.distributed.main(["encode", source, str(output), "--tile-points", "9000", *arguments]) == status
    err = capsys.readouterr().err
    assert err.startswith("sspc.distributed: ") and err.count("\n") == 1 and "Traceback" not in err


def test_the_command_exits_with_status_2_for_zero_workers(bunny_path, tmp_path):
    process = subprocess.run([sys.executable, "-m", "sspc.distributed", "encode", str(bunny_path),
                              str(tmp_path / "out.sspc"), "--tile-points", "9000", "--workers", "0"],
                             capture_output=True, text=True, timeout=60, env=_environment(), check=False)
    assert process.returncode == 2
    assert process.stderr == "sspc.distributed: workers must be an integer of at least 1, not 0\n"


def test_force_overwrites_the_output(bunny, client, tmp_path):
    import sspc.distributed  # pylint: disable=import-outside-toplevel

    sspc.encode(bunny, tmp_path / "local.sspc", tile_points=9000, level=6)
    (tmp_path / "dask.sspc").write_bytes(b"old")
    sspc.distributed.encode(bunny, tmp_path / "dask.sspc", client=client, tile_points=9000, level=6, force=True)
    assert (tmp_path / "dask.sspc").read_bytes() == (tmp_path / "local.sspc").read_bytes()


def test_a_refused_plan_leaves_nothing_beside_the_output(bunny, client, tmp_path):
    import sspc.distributed  # pylint: disable=import-outside-toplevel

    with pytest.raises(ValueError, match="smaller than half a patch"):
        sspc.distributed.encode(bunny, tmp_path / "out.sspc", client=client, tile_points=100, level=6)
    assert not list(tmp_path.iterdir())  # nor an empty staging folder


def _count_submissions(client, monkeypatch):
    submitted = []
    submit = client.submit

    def counted(*args, **kwargs):
        submitted.append(kwargs["key"])
        return submit(*args, **kwargs)

    monkeypatch.setattr(client, "submit", counted)
    return submitted


def test_an_interrupted_encode_resumes_with_the_finished_tiles(bunny, client, tmp_path, monkeypatch):
    import sspc.distributed  # pylint: disable=import-outside-toplevel

    expected = sspc.encode(bunny, tmp_path / "local.sspc", tile_points=9000, level=6)
    out = tmp_path / "out"
    out.mkdir()
    staging = out / ".bunny.sspc.sspc-tiles"
    kept = 3
    write = sspc.distributed._write_atomically  # pylint: disable=protected-access
    written = []

    def fail_after_three(path, data):
        if len(written) == kept:
            raise RuntimeError("the client failed")
        written.append(path)
        write(path, data)

    monkeypatch.setattr(sspc.distributed, "_write_atomically", fail_after_three)
    with pytest.raises(RuntimeError, match="the client failed"):
        sspc.distributed.encode(bunny, out / "bunny.sspc", client=client, tile_points=9000, level=6)
    # No output, its temporary file gone with the encoder; the finished tiles kept.
    assert [p.name for p in out.iterdir()] == [staging.name]
    assert len(list(staging.glob("*.result"))) == len(list(staging.iterdir())) == kept

    monkeypatch.setattr(sspc.distributed, "_write_atomically", write)
    submitted = _count_submissions(client, monkeypatch)
    stats = sspc.distributed.encode(bunny, out / "bunny.sspc", client=client, tile_points=9000, level=6)
    assert stats["resumed_tiles"] == kept and len(submitted) == expected["tiles"] - kept
    assert (out / "bunny.sspc").read_bytes() == (tmp_path / "local.sspc").read_bytes()
    assert [p.name for p in out.iterdir()] == ["bunny.sspc"]  # the staging folder gone


def test_kept_results_of_another_plan_or_damaged_are_run_again(bunny_path, client, tmp_path, monkeypatch):
    import sspc.distributed  # pylint: disable=import-outside-toplevel

    sspc.encode(bunny_path, tmp_path / "local.sspc", tile_points=9000, level=6)
    out = tmp_path / "out"
    out.mkdir()
    staging = out / ".bunny.sspc.sspc-tiles"
    staging.mkdir()
    other = sspc.TiledEncoder(bunny_path, tile_points=9000, level=5)
    same = sspc.TiledEncoder(bunny_path, tile_points=9000, level=6)
    for t in (0, 2):  # another level's: refused as another job's
        (staging / f"{t}.result").write_bytes(sspc.run_tile_job(other.job(t)))
    damaged = bytearray(sspc.run_tile_job(same.job(1)))
    damaged[len(damaged) // 2] ^= 0xFF
    (staging / "1.result").write_bytes(bytes(damaged))
    (staging / "3.result").write_bytes(sspc.run_tile_job(same.job(3)))  # good: kept
    submitted = _count_submissions(client, monkeypatch)
    # Jobs and results as files in the output's folder: each result moved into the staging folder.
    stats = sspc.distributed.encode(bunny_path, out / "bunny.sspc", client=client, tile_points=9000, level=6,
                                    shared_dir=out)
    assert stats["resumed_tiles"] == 1 and len(submitted) == stats["tiles"] - 1
    assert (out / "bunny.sspc").read_bytes() == (tmp_path / "local.sspc").read_bytes()
    assert [p.name for p in out.iterdir()] == ["bunny.sspc"]


def _environment():
    """This process's environment, with the sspc it imports importable from any folder."""
    package = os.path.dirname(os.path.dirname(os.path.abspath(sspc.__file__)))
    return dict(os.environ, PYTHONPATH=os.pathsep.join([package, os.environ.get("PYTHONPATH", "")]))


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _wait_for(condition, seconds, what):
    deadline = time.monotonic() + seconds
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.02)


def test_a_lost_scheduler_keeps_the_finished_tiles_for_a_rerun(bunny, bunny_path, tmp_path):
    sspc.encode(bunny, tmp_path / "local.sspc", tile_points=9000, level=6)
    out = tmp_path / "out"
    out.mkdir()
    staging = out / ".bunny.sspc.sspc-tiles"
    # Tiles of half a second on the worker, so that the scheduler goes with most of them to run
    # (Dask may load a preload module more than once: it wraps the original function only).
    slow = tmp_path / "slow_tiles.py"
    slow.write_text("import time\nimport sspc\n_run = getattr(sspc, '_fast_run_tile_job', sspc.run_tile_job)\n"
                    "sspc._fast_run_tile_job = _run\n\n\n"
                    "def _slow(*args, **kwargs):\n    time.sleep(0.5)\n    return _run(*args, **kwargs)\n\n\n"
                    "sspc.run_tile_job = _slow\n")
    address = f"tcp://127.0.0.1:{_free_port()}"
    env = _environment()
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL, "env": env, "cwd": tmp_path}
    processes = []
    try:
        scheduler = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                                      "--port", address.rsplit(":", 1)[1], "--no-dashboard"], **quiet)
        processes.append(scheduler)
        processes.append(subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address,
                                           "--nthreads", "1", "--no-nanny", "--no-dashboard", "--preload", str(slow),
                                           "--local-directory", str(tmp_path / "worker")], **quiet))
        encode = subprocess.Popen([sys.executable, "-m", "sspc.distributed", "encode", str(bunny_path),
                                   str(out / "bunny.sspc"), "--tile-points", "9000", "-l", "6", "--scheduler", address],
                                  stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
        processes.append(encode)
        _wait_for(lambda: encode.poll() is not None or list(staging.glob("*.result")), 60, "a tile's result")
        assert encode.poll() is None, encode.stderr.read()
        scheduler.kill()
        _, err = encode.communicate(timeout=60)
    finally:
        for process in processes:
            process.kill()
            process.wait(timeout=30)
    kept = len(list(staging.glob("*.result")))
    assert encode.returncode == 1
    assert err.startswith(f"sspc.distributed: the Dask cluster was lost after {kept} of 7 tiles ("), err
    assert err.endswith(f"the {kept} finished tiles are kept in {staging}: run the same command again to resume\n")
    assert err.count("\n") == 1 and "Traceback" not in err
    assert 1 <= kept < 7 and [p.name for p in out.iterdir()] == [staging.name]

    # Again on a fresh local cluster: the kept tiles added, the others run, the same bytes.
    again = subprocess.run([sys.executable, "-m", "sspc.distributed", "encode", str(bunny_path),
                            str(out / "bunny.sspc"), "--tile-points", "9000", "-l", "6", "--workers", "1", "--json"],
                           capture_output=True, text=True, timeout=120, env=env, check=False)
    assert again.returncode == 0, again.stderr
    assert json.loads(again.stdout)["resumed_tiles"] == kept
    assert (out / "bunny.sspc").read_bytes() == (tmp_path / "local.sspc").read_bytes()
    assert [p.name for p in out.iterdir()] == ["bunny.sspc"]


def test_several_files_on_dask_give_the_bytes_of_their_concatenation(bunny, bunny_path, tmp_path):
    import numpy as np  # pylint: disable=import-outside-toplevel

    import sspc.distributed  # pylint: disable=import-outside-toplevel

    tiles = tmp_path / "tiles"
    tiles.mkdir()
    for k, part in enumerate(np.array_split(np.asarray(bunny.positions), 3)):
        sspc.write(sspc.PointCloud(part), tiles / f"t{k}.ply")
    sspc.write(sspc.PointCloud(np.asarray(bunny.positions)), tmp_path / "whole.ply")
    expected = sspc.encode(tmp_path / "whole.ply", None, tile_points=9000, memory_limit=1 << 30, level=6)
    out = tmp_path / "out.sspc"
    code = sspc.distributed.main(["encode", str(tiles / "t0.ply"), str(tiles / "t1.ply"), str(tiles / "t2.ply"),
                                  str(out), "--tile-points", "9000", "--memory-limit", "1G", "--workers", "1",
                                  "-l", "6"])
    assert code == 0
    assert out.read_bytes() == expected
