"""The GIL is released during library calls, and progress reaches Python from worker threads."""

import math
import threading
import time

import pytest

import sspc


def test_other_python_threads_run_while_encoding(bunny):
    # While the encoder runs in one thread, this one keeps running Python: the largest pause it
    # sees is a scheduling slice, not the encoder's whole run as it would be under a held GIL.
    window = {}

    def work():
        window["start"] = time.perf_counter()
        sspc.encode(bunny, None, level=3, threads=1)
        window["end"] = time.perf_counter()

    worker = threading.Thread(target=work)
    ticks = []
    worker.start()
    while worker.is_alive():
        ticks.append(time.perf_counter())
    worker.join()
    duration = window["end"] - window["start"]
    inside = [t for t in ticks if window["start"] <= t <= window["end"]]
    assert duration > 0.1, "the encode is too short to tell"
    gaps = [b - a for a, b in zip([window["start"]] + inside, inside + [window["end"]])]
    assert max(gaps) < duration / 2, f"largest pause {max(gaps):.3f} s of {duration:.3f} s"


def test_two_threads_decode_one_model_at_once(bunny_model):
    expected = bunny_model.decode_all().positions
    results = [None, None]

    def work(i):
        results[i] = bunny_model.decode_all(threads=1).positions

    threads = [threading.Thread(target=work, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for r in results:
        assert (r == expected).all()


def test_progress_reports_stages_and_fractions(bumps):
    calls = []
    sspc.encode(bumps, None, progress=lambda stage, fraction: calls.append((stage, fraction)))
    assert calls, "the callback was never called"
    stages = [stage for stage, _ in calls]
    assert any(s.startswith("centres") for s in stages) and "writing" in stages
    for stage, fraction in calls:
        assert isinstance(stage, str)
        assert math.isnan(fraction) or 0.0 <= fraction <= 1.0
    assert calls[-1] == ("writing", 1.0)


def test_an_exception_in_the_callback_is_raised(bunny_model):
    def fail(stage, fraction):
        raise KeyError("stop here")

    with pytest.raises(KeyError, match="stop here"):
        bunny_model.decode_all(progress=fail)
    with pytest.raises(TypeError, match="progress must be callable"):
        bunny_model.decode_all(progress=42)
