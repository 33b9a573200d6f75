"""femcal.parallel: one executor interface for threads, processes and serial work."""

from __future__ import annotations

import threading
import time

import pytest

from femcal.parallel import SerialExecutor, executor, message_queue, ordered


def _square(x: int) -> int:
    return x * x


def test_ordered_yields_in_order_and_keeps_at_most_ahead_pending():
    running = []
    peak = [0]
    lock = threading.Lock()

    def slow(x: int) -> int:
        with lock:
            running.append(x)
            peak[0] = max(peak[0], len(running))
        time.sleep(0.01 * (5 - x % 5))  # later items finish first
        with lock:
            running.remove(x)
        return x

    with executor("threads", 3) as pool:
        assert list(ordered(pool, slow, range(12), ahead=4)) == list(range(12))
    assert 1 < peak[0] <= 3


def test_the_first_failing_item_raises_in_order():
    def fail_on_3(x: int) -> int:
        if x in (3, 7):
            raise ValueError(f"item {x}")
        return x

    got = []
    with executor("threads", 2) as pool, pytest.raises(ValueError, match="item 3"):
        for v in ordered(pool, fail_on_3, range(10), ahead=3):
            got.append(v)
    assert got == [0, 1, 2]


def test_serial_work_is_computed_when_asked_for():
    trace = []

    def work(x: int) -> int:
        trace.append(f"compute {x}")
        return x

    pool = executor("threads", 1)
    assert isinstance(pool, SerialExecutor)
    for v in ordered(pool, work, range(3), ahead=2):
        trace.append(f"use {v}")
    assert trace == ["compute 0", "use 0", "compute 1", "use 1", "compute 2", "use 2"]
    failed = pool.submit(lambda: 1 / 0)
    assert isinstance(failed.exception(), ZeroDivisionError)


def test_processes_and_their_message_queue():
    q = message_queue("processes")
    with executor("processes", 2) as pool:
        assert [f.result() for f in [pool.submit(_square, k) for k in range(5)]] == [0, 1, 4, 9, 16]
    q.put("done")
    assert q.get() == "done"


def test_bad_requests_are_named():
    with pytest.raises(ValueError, match="kind 'gpu': expected one of serial, threads, processes"):
        executor("gpu", 2)
    with pytest.raises(ValueError, match="workers = 0: expected at least 1"):
        executor("threads", 0)
