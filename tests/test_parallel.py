"""femcal.parallel: one executor interface for threads, processes and serial work."""

from __future__ import annotations

import multiprocessing
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from femcal.parallel import SerialExecutor, executor, message_queue, ordered
from femcal.parallel.executors import ForkedCall

from .processes import alive, children


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


def _blas_threads_and_pid(values: list) -> tuple[int, int, float]:
    from threadpoolctl import threadpool_info

    blas = [p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"]
    return max(blas or [1]), os.getpid(), float(sum(values))


@pytest.mark.skipif(os.name != "posix", reason="forked workers only where the OS forks")
def test_a_forked_call_inherits_its_inputs_and_returns_its_result():
    """The call runs in another process with one BLAS thread; its inputs are inherited at the
    fork, so even one that cannot be pickled (a lambda) gets there; an error comes back."""
    values = [1.5, 2.5, lambda: None]  # the lambda: pickling the inputs would fail
    with ForkedCall(lambda v: _blas_threads_and_pid(v[:2]), values) as call:
        threads, pid, total = call.future.result(timeout=60)
    assert (threads, total) == (1, 4.0)
    assert pid != os.getpid()
    with ForkedCall(lambda: 1 / 0) as call:
        assert isinstance(call.future.exception(timeout=60), ZeroDivisionError)


def test_beside_runs_here_where_a_process_of_its_own_would_not_help(monkeypatch):
    """With one usable core the call runs in this process, at once, behind the same
    interface; with more (where the OS forks) in a worker of its own."""
    import femcal.parallel.executors as executors

    monkeypatch.setattr(executors, "usable_cores", lambda: 1)
    with executors.beside(os.getpid) as call:
        assert call.future.done() and call.future.result() == os.getpid()
    if os.name == "posix":
        monkeypatch.setattr(executors, "usable_cores", lambda: 2)
        with executors.beside(os.getpid) as call:
            assert call.future.result(timeout=60) != os.getpid()


def test_bad_requests_are_named():
    with pytest.raises(ValueError, match="kind 'gpu': expected one of serial, threads, processes"):
        executor("gpu", 2)
    with pytest.raises(ValueError, match="workers = 0: expected at least 1"):
        executor("threads", 0)


def _wait_gone(pids: list[int], seconds: float) -> list[int]:
    """The processes of ``pids`` still alive after waiting up to ``seconds`` for them."""
    deadline = time.monotonic() + seconds
    while any(alive(p) for p in pids) and time.monotonic() < deadline:
        time.sleep(0.05)
    return [p for p in pids if alive(p)]


#: A calibration-like pool (two worker processes, a progress queue, an initializer) whose
#: tasks sleep; it prints "ready" once they run.
POOL_SCRIPT = """
import sys, time
from femcal.parallel import executor, message_queue

_QUEUE = None

def init(q):
    global _QUEUE
    _QUEUE = q

def nap(k):
    _QUEUE.put(k)
    time.sleep(60)

if __name__ == "__main__":
    if sys.argv[1:] == ["watchdog"]:  # as where the kernel cannot be asked
        import femcal.parallel.executors as executors
        executors._kernel_kills_orphan = lambda: False
    q = message_queue("processes")
    with executor("processes", 2, initializer=init, initargs=(q,)) as pool:
        futures = [pool.submit(nap, k) for k in range(4)]
        q.get(), q.get()
        print("ready", flush=True)
        time.sleep(60)
"""


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")
@pytest.mark.parametrize("how", ["kernel", "watchdog"])
def test_workers_die_with_their_parent_when_it_is_killed(tmp_path, how):
    """SIGKILL gives the parent no chance to end its pool: the workers end by themselves,
    killed by the kernel (Linux) or by their own watchdog thread (other POSIX systems)."""
    script = tmp_path / "pool.py"
    script.write_text(POOL_SCRIPT)
    proc = subprocess.Popen([sys.executable, str(script), how], stdout=subprocess.PIPE,
                            text=True)  # fmt: skip
    try:
        assert proc.stdout.readline().strip() == "ready"
        workers = children(proc.pid)
        assert len(workers) == 2
        proc.kill()
        proc.wait(timeout=10)
        assert _wait_gone(workers, 5.0) == []
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        for p in children(proc.pid):
            os.kill(p, signal.SIGKILL)


def test_leaving_the_block_by_an_exception_ends_the_workers_at_once():
    """Ctrl-C (KeyboardInterrupt) in the parent, or any error, does not wait for the running
    and waiting tasks: they are cancelled and the workers ended."""
    before = {p.pid for p in multiprocessing.active_children()}  # earlier tests' stragglers
    t0 = time.perf_counter()
    with pytest.raises(KeyboardInterrupt), executor("processes", 2) as pool:
        futures = [pool.submit(time.sleep, 30) for _ in range(4)]
        time.sleep(0.2)
        workers = [p.pid for p in multiprocessing.active_children() if p.pid not in before]
        raise KeyboardInterrupt
    assert time.perf_counter() - t0 < 10
    assert all(f.done() for f in futures)
    # none ran its 30 s: each was cancelled or ended with the pool (which of the two depends
    # on how many tasks the executor had already handed to the workers)
    assert not [f for f in futures if not f.cancelled() and f.exception() is None]
    if Path("/proc/self/stat").exists():
        assert _wait_gone(workers, 5.0) == []


def test_workers_ignore_ctrl_c_and_take_sigterm_as_it_comes():
    """Ctrl-C reaches every process of the terminal's group: the workers leave it to the
    parent (no KeyboardInterrupt traceback from each); SIGTERM ends them (no handler of the
    parent's inherited)."""
    with executor("processes", 2) as pool:
        assert pool.submit(signal.getsignal, signal.SIGINT).result() == signal.SIG_IGN
        assert pool.submit(signal.getsignal, signal.SIGTERM).result() == signal.SIG_DFL


def test_a_process_whose_parent_is_gone_ends_at_once():
    """die_with_parent in a process whose parent is not the one named: it ends (exit 1) rather
    than running on as an orphan."""
    code = ("from femcal.parallel import die_with_parent; die_with_parent(1 << 30); "
            "print('ran on')")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    if os.name == "posix":
        assert done.returncode == 1 and "ran on" not in done.stdout


_FORK_FACTOR = r"""
import os, sys
from femcal.parallel.executors import ForkedCall, limit_openmp, openmp_forks_safely
limit_openmp()
import numpy as np
import scipy.sparse as sp
from femcal.solve.factor import HAVE_CHOLMOD, factorize
m = 36  # a 3-D Laplacian: supernodal, so CHOLMOD opens OpenMP regions
T = sp.diags([-np.ones(m - 1), 2.0 * np.ones(m), -np.ones(m - 1)], [-1, 0, 1])
I = sp.identity(m)
A = (sp.kron(sp.kron(T, I), I) + sp.kron(sp.kron(I, T), I) + sp.kron(sp.kron(I, I), T)
     + 0.1 * sp.identity(m ** 3)).tocsc()
n = A.shape[0]
solve, name = factorize(A)  # this process's OpenMP runtime has run a factorisation
b = np.ones(n)
safe = openmp_forks_safely()
print(os.environ.get("OMP_THREAD_LIMIT"), safe, name)
if safe:
    with ForkedCall(lambda: float(np.abs(A @ factorize(A)[0](b) - b).max())) as call:
        print(call.future.result(timeout=60) < 1e-10)
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="GNU OpenMP on Linux")
def test_openmp_capped_at_one_thread_lets_a_forked_process_factorise():
    """The command line's cap on OpenMP (unless the user set one): with it, a process that
    has factorised may fork a worker that factorises too (without it the worker would wait
    forever in CHOLMOD's first parallel region); a cap the user set is kept, and the forked
    path is then not offered."""
    from femcal.solve.factor import HAVE_CHOLMOD

    env = {k: v for k, v in os.environ.items() if k != "OMP_THREAD_LIMIT"}
    run = subprocess.run([sys.executable, "-c", _FORK_FACTOR], env=env, capture_output=True,
                         text=True, timeout=120)  # fmt: skip
    assert run.returncode == 0, run.stderr
    limit, safe, name = run.stdout.split()[:3]
    assert (limit, safe) == ("1", "True")
    assert run.stdout.split()[3] == "True"  # the worker's factor solves A x = b
    if HAVE_CHOLMOD:
        assert name == "cholmod"
        run = subprocess.run([sys.executable, "-c", _FORK_FACTOR],
                             env={**env, "OMP_THREAD_LIMIT": "2"}, capture_output=True,
                             text=True, timeout=120)  # fmt: skip
        assert run.returncode == 0, run.stderr
        assert run.stdout.split() == ["2", "False", "cholmod"]


def _talk(outbox, n: int, fail: bool) -> str:
    for k in range(n):
        outbox.send(("line", k))
    if fail:
        raise ValueError("the worker's own error")
    time.sleep(60 if n == 0 else 0)  # (a worker with nothing to say goes on working)
    return "done"


def _big_then_die(outbox, size: int) -> None:
    import numpy as np

    outbox.send(("big", np.arange(size, dtype=float)))
    os.kill(os.getpid(), signal.SIGKILL)  # (as the kernel's out-of-memory killer would)


@pytest.mark.skipif(os.name != "posix", reason="forked workers only where the OS forks")
def test_a_forked_peer_sends_in_order_raises_its_error_and_stops_when_asked():
    from femcal.parallel.executors import ForkedPeer

    with ForkedPeer(_talk, 3, False) as peer:
        assert [peer.receive() for _ in range(3)] == [("line", 0), ("line", 1), ("line", 2)]
        assert peer.future.result(timeout=60) == "done"
        with pytest.raises(RuntimeError, match="ended without the message expected"):
            peer.receive()
    with ForkedPeer(_talk, 1, True) as peer:
        assert peer.receive() == ("line", 0)
        with pytest.raises(ValueError, match="the worker's own error"):
            peer.receive()
    with ForkedPeer(_talk, 0, False) as peer:
        pids = [p.pid for p in peer.call.pool._processes.values()]
        start = time.monotonic()
        peer.stop()
    assert time.monotonic() - start < 30
    assert _wait_gone(pids, 10) == []
    with ForkedPeer(_talk, 0, False) as peer:  # leaving the block ends a worker still busy
        pids = [p.pid for p in peer.call.pool._processes.values()]
    assert _wait_gone(pids, 10) == []


@pytest.mark.skipif(os.name != "posix", reason="forked workers only where the OS forks")
def test_a_forked_peers_large_message_arrives_whole_and_its_end_is_seen():
    """A message of 64 MB arrives whole; a worker killed after it is seen to have ended (an
    error, not a wait for ever)."""
    from femcal.parallel.executors import ForkedPeer

    size = 8 * 1024 * 1024
    with ForkedPeer(_big_then_die, size) as peer:
        kind, values = peer.receive()
        assert kind == "big" and len(values) == size and values[-1] == size - 1
        start = time.monotonic()
        with pytest.raises(Exception, match=r"terminated abruptly|ended without the message"):
            peer.receive()
        assert time.monotonic() - start < 30


def _may_fork() -> bool:
    from femcal.parallel.executors import may_fork_beside

    return may_fork_beside()


@pytest.mark.skipif(os.name != "posix", reason="forked workers only where the OS forks")
def test_a_pools_worker_forks_no_worker_of_its_own(monkeypatch):
    """The pool shares the cores out already: its workers, forked or spawned, do not fork
    beside themselves, where this process would."""
    import femcal.parallel.executors as executors

    monkeypatch.setattr(executors, "usable_cores", lambda: 2)
    assert executors.may_fork_beside()
    for fresh in (False, True):
        with executor("processes", 2, fresh=fresh) as pool:
            assert pool.submit(_may_fork).result(timeout=120) is False
