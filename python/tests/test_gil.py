"""The GIL is released while the library works.

Neither check measures speed (speed is for benchmarks: a timed test on a
shared machine fails with the machine, not the code; the two-thread
speed-up is measured by scripts/compare_python.py). Calls made from two
Python threads overlap in time, which they cannot if a call holds the GIL
(the second thread could not even take its start time); and the main
thread keeps running Python while another is inside a long call."""

import threading
import time

import pytest

import voxkit
from conftest import BUNNY


@pytest.fixture(scope="module")
def bunny():
    return voxkit.load_mesh(BUNNY)


def timed_pair(bunny, threads, parallel):
    v, f = bunny
    spans = [None, None]

    def one(i):
        t0 = time.perf_counter()
        voxkit.voxelize(v, f, resolution=512, mode="thick", threads=threads)
        spans[i] = (t0, time.perf_counter())

    if parallel:
        ts = [threading.Thread(target=one, args=(i,)) for i in range(2)]
        t0 = time.perf_counter()
        for t in ts:
            t.start()
        for t in ts:
            t.join()
    else:
        t0 = time.perf_counter()
        one(0)
        one(1)
    return time.perf_counter() - t0, spans


def test_calls_from_two_threads_overlap(bunny):
    _, spans = timed_pair(bunny, threads=None, parallel=True)
    (a0, a1), (b0, b1) = spans
    overlap = min(a1, b1) - max(a0, b0)
    assert overlap > 0.5 * min(a1 - a0, b1 - b0), spans


def test_python_runs_during_a_call(bunny):
    """The main thread keeps running Python while another thread is inside a
    long call: no gap between its loop iterations near the call's length."""
    v, f = bunny
    span = []

    def work():
        t0 = time.perf_counter()
        voxkit.voxelize(v, f, resolution=1024, mode="thick")
        span.extend([t0, time.perf_counter()])

    t = threading.Thread(target=work)
    ticks = []
    t.start()
    while t.is_alive():
        ticks.append(time.perf_counter())
        time.sleep(0.001)
    t.join()
    t0, t1 = span
    inside = [x for x in ticks if t0 <= x <= t1]
    gaps = [b - a for a, b in zip([t0] + inside, inside + [t1])]
    assert max(gaps) < 0.5 * (t1 - t0), (max(gaps), t1 - t0)
