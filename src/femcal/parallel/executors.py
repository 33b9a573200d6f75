"""One way to run work in parallel: :class:`concurrent.futures.Executor`.

Every parallel step of femcal goes through this module: the element kernels run on threads
(:func:`ordered`, the scatter stays in order so sums do not depend on the thread count), the
sparsity pattern's column indices on a background thread (:func:`in_background`), the
calibration's Levenberg-Marquardt starts in processes. :func:`executor` makes the executor
of a kind; a distributed engine offers the same interface (dask.distributed's
``Client.get_executor()`` returns a ``concurrent.futures.Executor``), so work written against
it runs there unchanged.

Worker processes belong to the process that made them: each ignores Ctrl-C (SIGINT goes to
the whole foreground process group; the parent decides), takes SIGTERM's default action, and
dies with its parent, however the parent ends (SIGKILL included): on Linux the kernel sends
it SIGKILL when the parent goes (``prctl(PR_SET_PDEATHSIG)``), elsewhere on POSIX a thread
in the worker watches its parent's pid; on other systems nothing watches. When the block of
a process pool is left by an exception (Ctrl-C's KeyboardInterrupt among them), the tasks
not started are cancelled and the workers are ended at once instead of finishing their
tasks.
"""

from __future__ import annotations

import contextlib
import ctypes
import multiprocessing
import multiprocessing.connection
import os
import queue
import signal
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Executor, Future, ProcessPoolExecutor, ThreadPoolExecutor
from types import TracebackType
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


#: The environment variable that caps the threads of GNU's OpenMP runtime (libgomp), read
#: once, when the runtime is loaded.
OPENMP_LIMIT = "OMP_THREAD_LIMIT"


def limit_openmp() -> None:
    """Cap the OpenMP runtime at one thread unless the environment already sets a cap
    (:data:`OPENMP_LIMIT`) or the BLAS runs its own threads on OpenMP
    (:func:`_blas_on_openmp`): for a program's entry point, before anything loads the
    runtime (CHOLMOD does, when scikit-sparse is imported). CHOLMOD's OpenMP regions (the
    supernodal factorisation's assembly of updates) gain nothing on top of its BLAS's own
    threads: on two cores they oversubscribe them and slow a factor down. And a runtime
    that never started a pool of threads leaves a forked child free to run parallel regions
    (:func:`openmp_forks_safely`)."""
    if OPENMP_LIMIT not in os.environ and not _blas_on_openmp():
        os.environ[OPENMP_LIMIT] = "1"


def _blas_on_openmp() -> bool:
    """Whether the BLAS that CHOLMOD takes on Linux distributions (``libblas.so.3``) runs its
    threads on OpenMP (an OpenMP build of OpenBLAS, or MKL): a cap on OpenMP would then
    leave it one thread."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        blas = ctypes.CDLL("libblas.so.3")
    except OSError:
        return False
    parallel = getattr(blas, "openblas_get_parallel", None)
    if parallel is not None:
        return int(parallel()) == 2  # 0 sequential, 1 its own threads, 2 OpenMP
    return hasattr(blas, "MKL_Get_Max_Threads")


def openmp_forks_safely() -> bool:
    """Whether a forked child of this process may run OpenMP parallel regions (CHOLMOD's
    factorisation does). A child inherits the parent's GNU OpenMP runtime with the pool of
    threads its parallel regions started, but not the threads, and waits for them forever
    at its first region. It is safe when no OpenMP runtime is loaded, or every one loaded
    is a GNU runtime capped at one thread (:func:`limit_openmp`), which never starts a pool;
    any other runtime, or one that cannot be asked, counts as unsafe."""
    if not sys.platform.startswith("linux"):
        return False
    from threadpoolctl import threadpool_info

    for lib in threadpool_info():
        if lib.get("user_api") != "openmp":
            continue
        if lib.get("prefix") != "libgomp":
            return False
        try:
            gomp = ctypes.CDLL(lib["filepath"], mode=os.RTLD_NOLOAD)
            if int(gomp.omp_get_thread_limit()) != 1:
                return False
        except (OSError, AttributeError, KeyError):
            return False
    return True


#: Set in a worker process of this module's pools (:func:`_start_worker`): its pool already
#: shares the cores out, so it forks no worker of its own beside.
_IN_POOL = False


def may_fork_beside() -> bool:
    """Whether a worker forked beside this process can help: the OS forks, this process
    may use more than one core, and it is not a pool's worker (the pool already shares the
    cores out; a daemonic process may not have children at all)."""
    return (os.name == "posix" and usable_cores() > 1 and not _IN_POOL
            and not multiprocessing.current_process().daemon)  # fmt: skip


def _process_context(fresh: bool = False) -> multiprocessing.context.BaseContext:
    """Forked workers where the OS can fork (they inherit the parent's arrays without
    pickling them), spawned ones elsewhere or when ``fresh``: unless the OpenMP runtime is
    capped at one thread (:func:`openmp_forks_safely`), a forked child inherits it
    (GNU libgomp, which CHOLMOD's factorisation runs on) in a state it cannot use, and hangs
    at its first parallel region; work that factorises then needs workers started afresh."""
    return multiprocessing.get_context("fork" if os.name == "posix" and not fresh
                                       else "spawn")  # fmt: skip


#: Linux's prctl option that has the kernel signal a process when its parent ends.
_PR_SET_PDEATHSIG = 1

#: Seconds between a watchdog's looks at its parent (where the kernel cannot be asked).
WATCH_INTERVAL = 0.5


def _kernel_kills_orphan() -> bool:
    """Ask the kernel to SIGKILL this process when its parent ends (Linux); False where it
    cannot be asked."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)  # the C library the interpreter runs on
        return libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0
    except (OSError, AttributeError):  # no prctl in it (another C library)
        return False


def _watch_parent(parent: int) -> None:
    """End this process as soon as its parent is no longer ``parent`` (the orphan is
    adopted by another process)."""
    while os.getppid() == parent:
        time.sleep(WATCH_INTERVAL)
    os._exit(1)


def die_with_parent(parent: int) -> None:
    """Make this process end when the process ``parent`` ends: by the kernel on Linux, by a
    watchdog thread elsewhere on POSIX, not at all where neither is possible (Windows).
    A process whose parent has already gone ends now."""
    if not _kernel_kills_orphan() and os.name == "posix":
        threading.Thread(target=_watch_parent, args=(parent,), name="femcal-parent-watch",
                         daemon=True).start()  # fmt: skip
    if os.name == "posix" and os.getppid() != parent:  # the parent went before the request
        os._exit(1)


def _start_worker(parent: int, initializer: Callable[..., object] | None,
                  initargs: tuple) -> None:  # fmt: skip
    """Prepare a worker process: Ctrl-C ignored (the parent handles it), SIGTERM's default
    action (not a handler inherited from the parent), death with the parent; then the
    caller's ``initializer(*initargs)``."""
    global _IN_POOL
    _IN_POOL = True
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    die_with_parent(parent)
    if initializer is not None:
        initializer(*initargs)


class ProcessPool(ProcessPoolExecutor):
    """A :class:`ProcessPoolExecutor` whose workers die with this process and ignore Ctrl-C,
    and whose ``with`` block, left by an exception, cancels the waiting tasks and ends the
    workers at once (:meth:`terminate`) rather than waiting for every task to finish."""

    def __init__(self, workers: int, *, mp_context: multiprocessing.context.BaseContext,
                 initializer: Callable[..., object] | None = None,
                 initargs: tuple = ()) -> None:  # fmt: skip
        super().__init__(workers, mp_context=mp_context, initializer=_start_worker,
                         initargs=(os.getpid(), initializer, initargs))  # fmt: skip

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> bool:  # fmt: skip
        if exc_type is None:
            self.shutdown(wait=True)
        else:
            self.terminate()
        return False

    def terminate(self, timeout: float = 5.0) -> None:
        """Cancel the tasks not started, end the workers (SIGTERM, then SIGKILL after
        ``timeout`` seconds) and wait for them; the pool is shut down after it. The workers
        and the thread that feeds them are the executor's own attributes (``_processes``,
        ``_executor_manager_thread``, as CPython has kept them since 3.9)."""
        processes = list((getattr(self, "_processes", None) or {}).values())
        manager = getattr(self, "_executor_manager_thread", None)
        self.shutdown(wait=False, cancel_futures=True)
        for proc in processes:
            if proc.is_alive():
                proc.terminate()
        for proc in processes:
            proc.join(timeout)
            if proc.is_alive():
                proc.kill()
                proc.join(timeout)
        if manager is not None:
            manager.join(timeout)


def executor(kind: Kind, workers: int = 1, *, name: str = "femcal",
             initializer: Callable[..., object] | None = None,
             initargs: tuple = (), fresh: bool = False) -> Executor:  # fmt: skip
    """An executor of ``kind`` with ``workers`` workers; one worker, or ``"serial"``, gives a
    :class:`SerialExecutor`. ``initializer(*initargs)`` prepares each worker thread or
    process; a serial executor has none, so it is not run. ``name`` prefixes the threads'
    names. Use it as a context manager, or call ``shutdown``. Processes come as a
    :class:`ProcessPool` (see the module docstring), forked where the OS can fork, or
    spawned (a fresh interpreter that imports what the tasks need) with ``fresh``, which
    work that factorises sparse matrices needs (see :func:`_process_context`).

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
    return ProcessPool(workers, mp_context=_process_context(fresh), initializer=initializer,
                       initargs=initargs)  # fmt: skip


#: A forked call's function and arguments, set in its worker when the worker starts.
_INHERITED: tuple | None = None


def _inherit(call: tuple, blas_threads: int | None) -> None:
    global _INHERITED
    _INHERITED = call
    if blas_threads is not None:
        from threadpoolctl import threadpool_limits

        threadpool_limits(blas_threads)


def _run_inherited() -> object:
    assert _INHERITED is not None, "a forked call's worker started without its call"
    fn, args = _INHERITED
    return fn(*args)


class ForkedCall:
    """``fn(*args)`` in a worker process of its own while the caller goes on: ``future``
    holds its result. Where the OS can fork, the worker inherits ``fn`` and its arguments
    at the fork (nothing is pickled on the way in, only the result on the way back), so it
    suits work on large inputs the caller already holds; elsewhere they are pickled. The
    worker runs with ``blas_threads`` BLAS threads (None: the library's default), dies with
    this process and ignores Ctrl-C (:class:`ProcessPool`). Work that factorises sparse
    matrices belongs here only where :func:`openmp_forks_safely` says so (a forked worker
    cannot run CHOLMOD's OpenMP otherwise). Use it as a context manager: leaving the block
    waits for the call, or, left by an exception, ends the worker at once."""

    def __init__(self, fn: Callable[..., R], *args, blas_threads: int | None = 1) -> None:
        self.pool = ProcessPool(1, mp_context=_process_context(), initializer=_inherit,
                                initargs=((fn, args), blas_threads))  # fmt: skip
        try:
            self.future: Future = self.pool.submit(_run_inherited)
        except BaseException:  # (the fork failed: no worker to wait for)
            self.pool.shutdown(wait=False, cancel_futures=True)
            raise

    def __enter__(self) -> ForkedCall:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> bool:  # fmt: skip
        return self.pool.__exit__(exc_type, exc, tb)


#: Seconds between a :class:`ForkedPeer`'s looks at whether its worker has ended, while it
#: waits for the worker's next message.
PEER_POLL = 0.2


def _tell(outbox: multiprocessing.connection.Connection, fn: Callable[..., R], *args) -> R:
    """``fn(outbox, *args)`` in a :class:`ForkedPeer`'s worker, its end of the pipe closed
    when it returns or raises."""
    try:
        return fn(outbox, *args)
    finally:
        outbox.close()


class ForkedPeer:
    """``fn(outbox, *args)`` in a :class:`ForkedCall` of its own that tells the caller how
    it gets on while it runs: what the worker sends on ``outbox`` (``outbox.send(obj)``, the
    write end of a one-way pipe inherited at the fork, so this needs an OS that forks:
    :func:`may_fork_beside`) the caller :meth:`receive` s, in order. A message is whole in
    the pipe when ``send`` returns (a large one waits for the caller to read it), and only
    the worker holds the write end, so a worker that ends, even in the middle of a message,
    is seen as such. ``future`` holds ``fn``'s result. Use it as a context manager: leaving
    the block ends the worker if it is still running (the caller has what it wanted, or
    left by an exception) and closes the pipe.

    Raises
    ------
    OSError
        When the fork fails (a limit on processes or memory).
    """

    def __init__(self, fn: Callable[..., R], *args, blas_threads: int | None = None) -> None:
        self.inbox, outbox = multiprocessing.Pipe(duplex=False)
        try:
            self.call = ForkedCall(_tell, outbox, fn, *args, blas_threads=blas_threads)
        except BaseException:
            self.inbox.close()
            raise
        finally:
            outbox.close()  # the worker's copy is the only write end left
        self.future = self.call.future

    def receive(self) -> object:
        """The worker's next message, waiting for it.

        Raises
        ------
        Exception
            The worker's own, when it ended with one before sending the message.
        RuntimeError
            When it ended without sending it.
        """
        while not self.inbox.poll(PEER_POLL):
            if self.future.done() and not self.inbox.poll(0):
                break
        else:
            try:
                return self.inbox.recv()
            except (EOFError, OSError):  # the worker ended (in the middle of a message)
                pass
        # (the pool notices a worker that died a moment after its pipe closes)
        with contextlib.suppress(TimeoutError):
            self.future.exception(timeout=10 * PEER_POLL)
        if self.future.done():
            self.future.result()  # its exception, if it ended with one
        raise RuntimeError("the forked worker ended without the message expected")

    def stop(self) -> None:
        """End the worker now, whatever it is doing, and wait until it has ended."""
        self.call.pool.terminate()

    def __enter__(self) -> ForkedPeer:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> bool:  # fmt: skip
        try:
            if not self.future.done():
                self.stop()
            return self.call.__exit__(exc_type, exc, tb)
        finally:
            self.inbox.close()


class _CallHere:
    """``fn(*args)`` run here, at once: a :class:`ForkedCall`'s interface (``future``, a
    context manager) where no worker of its own would help."""

    def __init__(self, fn: Callable[..., R], *args) -> None:
        self.future: Future = SerialExecutor().submit(fn, *args)

    def __enter__(self) -> _CallHere:
        return self

    def __exit__(self, *exc: object) -> bool:
        return False


def beside(fn: Callable[..., R], *args, blas_threads: int | None = 1
           ) -> ForkedCall | _CallHere:  # fmt: skip
    """``fn(*args)`` in a :class:`ForkedCall` while the caller goes on, where the OS forks,
    this process may use more than one core and may have children (:func:`may_fork_beside`);
    else, or when the fork fails (a limit on processes or memory), run here, now (the same
    interface)."""
    if may_fork_beside():
        try:
            return ForkedCall(fn, *args, blas_threads=blas_threads)
        except OSError:
            pass
    return _CallHere(fn, *args)


def message_queue(kind: Kind) -> queue.Queue:
    """A queue that the workers of an executor of ``kind`` can put messages on and the caller
    read (``put``, ``get``, ``get_nowait`` raising :class:`queue.Empty`). For processes a
    :func:`multiprocessing.Queue`, handed to the workers through the executor's
    ``initargs`` (a pipe: no server process that could outlive the caller)."""
    if kind == "processes":
        return _process_context().Queue()
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
