"""One way to run work in parallel: :class:`concurrent.futures.Executor`.

Every parallel step of femcal goes through this module: the element kernels run on threads
(:func:`ordered`, the scatter stays in order so sums do not depend on the thread count), the
sparsity pattern's column indices on a background thread (:func:`in_background`), the
calibration's Levenberg-Marquardt starts in processes. :func:`executor` makes the executor
of a kind; a distributed engine offers the same interface (dask.distributed's
``Client.get_executor()`` returns a ``concurrent.futures.Executor``), so work written against
it runs there unchanged.
"""

from __future__ import annotations

import multiprocessing
import os
import queue
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Executor, Future, ProcessPoolExecutor, ThreadPoolExecutor
from typing import Literal, TypeVar

T = TypeVar("T")
R = TypeVar("R")

#: Where work runs: here, one task after another; on threads of this process (for NumPy work,
#: which releases the GIL); in worker processes (for Python-heavy work).
Kind = Literal["serial", "threads", "processes"]
KINDS: tuple[str, ...] = ("serial", "threads", "processes")
_END = object()


class SerialExecutor(Executor):
    """Runs each task when it is submitted, in the calling thread: the executor of one worker,
    with the same interface as the others (its futures are done when returned)."""

    def submit(self, fn: Callable[..., R], /, *args, **kwargs) -> Future[R]:
        future: Future[R] = Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except BaseException as e:  # the future carries it, as a pool's would
            future.set_exception(e)
        return future


def usable_cores() -> int:
    """Cores this process may run on (its affinity where the OS tells it)."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def _process_context() -> multiprocessing.context.BaseContext:
    """Forked workers where the OS can fork (they inherit the parent's arrays without
    pickling them), spawned ones elsewhere."""
    return multiprocessing.get_context("fork" if os.name == "posix" else "spawn")


def executor(kind: Kind, workers: int = 1, *, name: str = "femcal",
             initializer: Callable[..., object] | None = None,
             initargs: tuple = ()) -> Executor:  # fmt: skip
    """An executor of ``kind`` with ``workers`` workers; one worker, or ``"serial"``, gives a
    :class:`SerialExecutor`. ``initializer(*initargs)`` prepares each worker thread or
    process; a serial executor has none, so it is not run. ``name`` prefixes the threads'
    names. Use it as a context manager, or call ``shutdown``.

    Raises
    ------
    ValueError
        For an unknown kind or fewer than one worker.
    """
    if kind not in KINDS:
        raise ValueError(f"kind {kind!r}: expected one of {', '.join(KINDS)}")
    if workers < 1:
        raise ValueError(f"workers = {workers}: expected at least 1")
    if kind == "serial" or workers == 1:
        return SerialExecutor()
    if kind == "threads":
        return ThreadPoolExecutor(workers, thread_name_prefix=name, initializer=initializer,
                                  initargs=initargs)  # fmt: skip
    return ProcessPoolExecutor(workers, mp_context=_process_context(), initializer=initializer,
                               initargs=initargs)  # fmt: skip


def message_queue(kind: Kind) -> queue.Queue:
    """A queue that the workers of an executor of ``kind`` can put messages on and the caller
    read (progress from worker processes goes through a manager's queue)."""
    if kind == "processes":
        return _process_context().Manager().Queue()
    return queue.Queue()


def ordered(pool: Executor, fn: Callable[[T], R], items: Iterable[T], *,
            ahead: int) -> Iterator[R]:  # fmt: skip
    """``fn(item)`` for every item, computed on ``pool`` and yielded in the items' order, with
    at most ``ahead`` tasks submitted and not yet yielded (bounding the memory of results
    waiting their turn). The first failing task, in order, raises; tasks not started when the
    caller stops are cancelled. On a :class:`SerialExecutor` each item is computed when the
    caller asks for it, so no result waits its turn."""
    if isinstance(pool, SerialExecutor):
        for item in items:
            yield fn(item)
        return
    todo = iter(items)
    pending: deque[Future[R]] = deque()
    try:
        for item in todo:
            pending.append(pool.submit(fn, item))
            if len(pending) >= ahead:
                break
        while pending:
            result = pending.popleft().result()
            nxt = next(todo, _END)
            if nxt is not _END:
                pending.append(pool.submit(fn, nxt))
            yield result
    finally:
        for f in pending:
            f.cancel()


def in_background(fn: Callable[..., R], *args) -> Future[R]:
    """Run ``fn(*args)`` on a thread of its own while the caller goes on; the future holds
    its result."""
    pool = ThreadPoolExecutor(1, thread_name_prefix="femcal-background")
    future = pool.submit(fn, *args)
    pool.shutdown(wait=False)
    return future
