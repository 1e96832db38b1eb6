"""sspc.distributed: a tiled encode whose tiles run as tasks on a local Dask cluster of worker
processes writes the same bytes as sspc.encode with the same tiles on one machine."""

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
