"""Levenberg-Marquardt starts on a surrogate, in parallel processes or on a Dask cluster,
with their results kept on disk so that a stopped run resumes from the starts it finished."""

from __future__ import annotations

import json
import queue as queue_mod
import time
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, wait
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from ..atomic import write_atomic
from ..parallel import executor, message_queue
from ..parallel.cluster import Engine, Session, result_of, share
from ..parallel.progress import Detail, Step
from .lm import levenberg_marquardt
from .problem import Problem
from .result import StartResult


def run_one(problem: Problem, start: int, p0: np.ndarray,
            report: Callable[[int, int, float], None] | None = None) -> StartResult:  # fmt: skip
    """One LM run from ``p0``; ``report(start, iteration, cost)`` after each accepted step."""
    t = time.perf_counter()
    res = levenberg_marquardt(
        problem.fun, p0, problem.lower, problem.upper, max_iter=problem.max_iter,
        callback=(lambda it, p, cost: report(start, it, cost)) if report else None,
    )  # fmt: skip
    return StartResult(start, np.asarray(p0, float).copy(), np.asarray(res.p, float),
                       float(res.cost), problem.deviation(res.p), res.iterations,
                       res.evaluations, tuple(2 * h for h in res.history), res.converged,
                       res.message, time.perf_counter() - t)  # fmt: skip


#: A local worker process's message queue and problem, set when the worker starts.
_QUEUE = None
_PROBLEM: Problem | None = None


def _init_worker(q, problem: Problem) -> None:
    """Prepare a local worker: its queue and the problem (inherited at the fork, not
    pickled: the demo's is 57 MB, which per start cost more than half a start's time)."""
    global _QUEUE, _PROBLEM
    _QUEUE, _PROBLEM = q, problem
    threadpool_limits(1)  # one BLAS thread per worker: the workers are the parallelism


def _worker(start: int, p0: np.ndarray) -> StartResult:
    def report(s: int, it: int, cost: float) -> None:
        if _QUEUE is not None:
            _QUEUE.put((s, it, 2 * cost))

    assert _PROBLEM is not None, "a start submitted to a pool without its problem"
    return run_one(_PROBLEM, start, p0, report)


def _finished(folder: Path, k: int, p0: np.ndarray, fingerprint: str) -> StartResult | None:
    """Start k's result written by an earlier run with the same fingerprint and start point,
    or None (none, another run's, or a file that does not read)."""
    f = folder / f"start_{k + 1:03d}.json"
    if not f.is_file():
        return None
    try:
        saved = json.loads(f.read_text())
        if saved.get("fingerprint") != fingerprint or not np.allclose(
                saved.get("p0", []), p0, rtol=0, atol=1e-12):  # fmt: skip
            return None
        return StartResult.from_dict(saved)
    except (json.JSONDecodeError, KeyError, TypeError, ValueError):
        return None


def kept(finished: int) -> str:
    """What an engine's failure leaves of a search: the finished starts, for a resume."""
    return f"the {finished} starts finished are kept: run again to resume"


def run_starts(problem: Problem, starts: list[np.ndarray], *, session: Session | None = None,
               folder: Path | None = None,
               fingerprint: str = "",
               progress: Callable[[str], None] | None = None,
               task: str = "Levenberg-Marquardt starts") -> list[StartResult]:  # fmt: skip
    """Run LM from every start point; results in start order.

    ``progress`` gets each finished start as a :class:`~femcal.parallel.progress.Step` of
    ``task`` and each iteration as a :class:`~femcal.parallel.progress.Detail`.

    With ``folder``, each finished start is written there (``start_NNN.json``, atomically,
    with ``fingerprint``) and starts already there with the same fingerprint are read
    instead of run again.

    Where they run is ``session``'s engine (:class:`~femcal.parallel.cluster.Session`; none:
    one after another in this process). On the local engine with more than one worker they
    run in that many processes (:func:`femcal.parallel.executor`), which inherit the problem
    at the fork and send their progress back through a queue; the workers ignore Ctrl-C and
    die with this process, and an exception here (Ctrl-C's KeyboardInterrupt among them)
    ends them at once, the starts finished being kept. On a Dask engine they run on the
    session's cluster, which is left open: the problem is sent once, a start whose worker
    is lost runs again elsewhere, and each finished start is reported and kept as it
    arrives (its iterations are not reported from there). The results do not depend on
    where the starts ran: each runs with one BLAS thread wherever it runs (its matrices are
    small, and threads only contend for the cores), so the same start gives the same
    numbers, to rounding, in this process, a local worker or a Dask worker.

    Raises
    ------
    FemcalError
        When a local worker process ends without its result (killed from outside, or for
        want of memory), a start's Dask workers died more often than the scheduler allows,
        or the Dask scheduler went away (:func:`~femcal.parallel.cluster.result_of`).
    """
    say = progress or (lambda _m: None)
    results: dict[int, StartResult] = {}
    if folder is not None:
        folder.mkdir(parents=True, exist_ok=True)
        for k in range(len(starts)):
            saved = _finished(folder, k, starts[k], fingerprint)
            if saved is not None:
                results[k] = saved
                say(Step(f"start {k + 1}/{len(starts)}: finished earlier, deviation "
                         f"{saved.deviation:.5g}", task=task, done=len(results),
                         total=len(starts)))  # fmt: skip

    def keep(res: StartResult) -> None:
        k = res.start
        results[k] = res
        say(Step(f"start {k + 1}/{len(starts)} done: deviation {res.history[0]:.5g} -> "
                 f"{res.deviation:.5g} in {res.iterations} iterations, "
                 f"{res.seconds:.1f} s ({res.message})", task=task, done=len(results),
                 total=len(starts)))  # fmt: skip
        if folder is not None:
            text = json.dumps({**res.to_dict(), "fingerprint": fingerprint}, indent=1)
            write_atomic(folder / f"start_{k + 1:03d}.json",
                         lambda tmp: Path(tmp).write_text(text))  # fmt: skip

    todo = [k for k in range(len(starts)) if k not in results]
    if todo:  # the task's clock starts here, not at its first finished start
        say(Step(f"{len(todo)} of {len(starts)} starts to run", task=task, done=len(results),
                 total=len(starts)))  # fmt: skip
    engine = session.engine if session is not None else Engine()
    if engine.kind == "dask" and todo:
        pool = session.pool()
        shared = share(pool, problem)
        pending = {pool.submit(run_one, shared, k, starts[k]) for k in todo}
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for fut in done:
                keep(result_of(fut, "a Levenberg-Marquardt start", kept(len(results))))
    elif engine.workers <= 1 or len(todo) <= 1:
        for k in todo:
            def report(s, it, cost, k=k):
                say(Detail(f"start {k + 1}/{len(starts)} iteration {it}: deviation "
                           f"{2 * cost:.5g}"))  # fmt: skip

            with threadpool_limits(1):  # as in a worker: the same rounding, and faster
                keep(run_one(problem, k, starts[k], report))
    elif todo:
        q = message_queue("processes")
        with executor("processes", min(engine.workers, len(todo)), initializer=_init_worker,
                      initargs=(q, problem)) as pool:  # fmt: skip
            pending = {pool.submit(_worker, k, starts[k]) for k in todo}
            while pending:
                done, pending = wait(pending, timeout=0.5, return_when=FIRST_COMPLETED)
                while True:
                    try:
                        s, it, dev = q.get_nowait()
                    except queue_mod.Empty:
                        break
                    say(Detail(f"start {s + 1}/{len(starts)} iteration {it}: deviation "
                               f"{dev:.5g}"))  # fmt: skip
                for fut in done:
                    keep(result_of(fut, "a Levenberg-Marquardt start",
                                   kept(len(results)) + ", with fewer workers if memory is "
                                   "short"))  # fmt: skip
    return [results[k] for k in range(len(starts))]
