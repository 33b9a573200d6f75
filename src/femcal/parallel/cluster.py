"""Where a job's independent tasks run: this machine's process pool (the default, no
server), or a Dask ``distributed`` cluster, local or reached at a scheduler's address.

The tasks are the calibration's Levenberg-Marquardt starts (every search of every cycle),
the surrogates of several test configurations, and the points of a design study. Each is a
pure function of its arguments, so where it runs does not change its result: a Dask worker
runs it with one BLAS thread, as a local worker process does, and gives the same numbers
to rounding (on one machine, in practice bit for bit).

Dask is used through its :class:`concurrent.futures.Executor` (``Client.get_executor``), so
the code that submits the tasks is the same for both engines. What Dask adds:

- **A cluster.** ``Engine("dask", workers=N)`` starts a ``LocalCluster`` of N worker
  processes with one thread each and no dashboard, and closes it when the block ends.
  ``Engine("dask", scheduler="tcp://host:8786")`` connects to a running scheduler (started
  with ``dask scheduler`` and ``dask worker ADDRESS --nthreads 1`` on each machine, each
  with femcal installed; ``DASK_DISTRIBUTED__WORKER__PROFILE__ENABLED=False`` in the
  workers' environment spares the tasks Dask's profiler, as the LocalCluster does) and
  leaves it running.
- **Lost workers.** When a worker dies mid-task (killed, out of memory, its machine gone),
  the scheduler runs the task again on another worker (up to
  ``distributed.scheduler.allowed-failures`` times, 3 by default; then the task fails with
  ``KilledWorker``). A large argument shared by many tasks (:meth:`DaskExecutor.share`) is
  held as a task of its own, so that it too is recomputed, not lost, with its worker.

Dask is optional at run time: ``make setup`` installs it (the ``dask`` extra), and a missing
installation is a :class:`~femcal.errors.FemcalError` that says how to install it.
"""

from __future__ import annotations

import contextlib
import logging
import signal
import threading
import warnings
from collections.abc import Callable
from concurrent.futures import CancelledError, Executor, Future
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from typing import Any, Literal, TypeVar

from threadpoolctl import threadpool_limits

from ..errors import FemcalError, ResourceError
from .executors import ProcessPool, executor

R = TypeVar("R")

EngineKind = Literal["local", "dask"]
ENGINES: tuple[str, ...] = ("local", "dask")

#: Seconds to wait for a scheduler given by its address before giving up.
CONNECT_TIMEOUT = 20.0


@dataclass(frozen=True)
class Engine:
    """Where a job's independent tasks run.

    Attributes
    ----------
    kind : ``"local"``: this machine, in ``workers`` processes (one worker: in this
        process); ``"dask"``: a Dask cluster.
    workers : worker processes of the local pool or of the ``LocalCluster`` (at least 1);
        ignored with ``scheduler``, whose cluster has its own.
    scheduler : address of a running Dask scheduler (``tcp://host:port``), or None for a
        ``LocalCluster`` of ``workers`` processes; only with ``kind = "dask"``.
    """

    kind: EngineKind = "local"
    workers: int = 1
    scheduler: str | None = None

    def __post_init__(self) -> None:
        if self.kind not in ENGINES:
            raise ValueError(f"engine {self.kind!r}: expected one of {', '.join(ENGINES)}")
        if isinstance(self.workers, bool) or not isinstance(self.workers, int) \
                or self.workers < 1:  # fmt: skip
            raise ValueError(f"workers = {self.workers!r}: expected a whole number, at least 1")
        if self.scheduler is not None and self.kind != "dask":
            raise ValueError("a scheduler address needs the Dask engine (kind 'dask')")

    @property
    def parallel(self) -> bool:
        """Whether tasks run elsewhere than in this process, one after another."""
        return self.kind == "dask" or self.workers > 1

    def describe(self) -> str:
        """One phrase for the console: where the tasks run."""
        if self.kind == "dask":
            return (f"the Dask scheduler at {self.scheduler}" if self.scheduler else
                    f"a Dask LocalCluster of {self.workers} worker"
                    f"{'s' if self.workers > 1 else ''}")  # fmt: skip
        return (f"{self.workers} local worker processes" if self.workers > 1 else
                "this process")  # fmt: skip

    def session(self) -> Session:
        """A :class:`Session` on this engine: its executor opened at the first task and
        kept for the whole job (a Dask cluster starts once, not per search)."""
        return Session(self)

    def open(self) -> Executor:
        """An executor on this engine, to be used as a context manager: the local pool
        (:func:`femcal.parallel.executor`, serial for one worker; its processes spawned,
        not forked, so that tasks may factorise) or a :class:`DaskExecutor`.

        Raises
        ------
        FemcalError
            When Dask is not installed, or its scheduler cannot be reached.
        """
        if self.kind == "local":  # spawned: the tasks solve, and CHOLMOD's OpenMP cannot fork
            return executor("processes", self.workers, fresh=True)
        return DaskExecutor.start(self.workers, self.scheduler)


class Session:
    """An engine held open for a job: :meth:`pool` opens its executor the first time it is
    asked for and :meth:`close` (or the end of a ``with`` block) closes it. Values shared
    with :meth:`share_once` are sent to the cluster once per session."""

    def __init__(self, engine: Engine) -> None:
        self.engine = engine
        self._pool: Executor | None = None
        self._shared: dict[int, tuple[object, object]] = {}

    def pool(self) -> Executor:
        """The engine's executor, opened now if it is not yet."""
        if self._pool is None:
            self._pool = self.engine.open()
        return self._pool

    def share_once(self, obj: R) -> R:
        """``obj`` as tasks on this session's executor should receive it (:func:`share`),
        sent once however often it is asked for (the object is kept alive meanwhile)."""
        key = id(obj)
        if key not in self._shared:
            self._shared[key] = (obj, share(self.pool(), obj))
        return self._shared[key][1]  # type: ignore[return-value]

    def close(self, failed: bool = False) -> None:
        """Close the executor if it was opened; ``failed`` cancels the tasks not finished
        rather than waiting for them (and ends a local pool's workers at once)."""
        pool, self._pool = self._pool, None
        self._shared.clear()
        if pool is None:
            return
        if failed and isinstance(pool, ProcessPool):
            pool.terminate()
        else:
            pool.shutdown(wait=not failed, cancel_futures=failed)

    def __enter__(self) -> Session:
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        self.close(failed=exc_type is not None)
        return False


def result_of(future: Future[R], what: str, kept: str = "") -> R:
    """The result of a task on an engine, with the ways an engine fails as one-line femcal
    errors about ``what`` (e.g. "a Levenberg-Marquardt start"), ``kept`` added (what is
    kept, what to do): a local worker process that ended without its result
    (``BrokenProcessPool``), a task whose Dask workers died more often than the scheduler
    allows (``KilledWorker``), a task cancelled or a connection lost because the scheduler
    went away. An error of the task itself is raised as it is.

    Raises
    ------
    ResourceError
        For a lost worker (killed from outside, or for want of memory).
    FemcalError
        For a lost scheduler or cluster.
    """
    tail = f"; {kept}" if kept else ""
    try:
        return future.result()
    except BrokenProcessPool:
        raise ResourceError(f"a worker process ended without the result of {what} (killed "
                            f"from outside, or by the system for want of memory){tail}"
                            ) from None  # fmt: skip
    except killed_worker_error() as e:
        raise ResourceError(f"{what} failed on every Dask worker that took it: they died "
                            f"(killed, or for want of memory) ({e}){tail}") from None  # fmt: skip
    except CancelledError:
        raise FemcalError(f"{what} was cancelled: the Dask scheduler or its workers went "
                          f"away{tail}") from None  # fmt: skip
    except _comm_closed_error() as e:
        raise FemcalError(f"the connection to the Dask cluster was lost during {what} ({e})"
                          f"{tail}") from None  # fmt: skip


def _closed_client_error() -> type[BaseException] | tuple[()]:
    try:
        from distributed.client import ClosedClientError
    except ImportError:
        return ()
    return ClosedClientError


def _comm_closed_error() -> type[BaseException] | tuple[()]:
    try:
        from distributed.comm.core import CommClosedError
    except ImportError:
        return ()
    return CommClosedError


def one_blas_thread(fn: Callable[..., R], *args: Any) -> R:
    """``fn(*args)`` with one BLAS thread: the workers are the parallelism, and one thread
    gives the same rounding as a local worker process."""
    with threadpool_limits(1):
        return fn(*args)


def _same(obj: R) -> R:
    return obj


def _import_distributed():
    try:
        import distributed
    except ImportError as e:
        raise FemcalError(
            "the Dask engine needs dask.distributed, which is not installed: `make setup` "
            "installs it, or `pip install 'dask[distributed]'` in femcal's environment "
            f"({e})") from None  # fmt: skip
    return distributed


class _Quiet:
    """Dask's loggers in this process held at CRITICAL until :meth:`restore` (it logs a
    worker's failure, a lost connection and its own shutdown on standard error, where femcal
    reports them itself, in one line)."""

    ROOTS = ("distributed", "tornado")

    def __init__(self) -> None:
        names = {*self.ROOTS, *(n for n in logging.root.manager.loggerDict
                                if n.split(".", 1)[0] in self.ROOTS)}  # fmt: skip
        # Dask's configuration gives some of its loggers levels of their own
        # (distributed.client: warning), which their parent's level does not override
        self._levels = {n: logging.getLogger(n).level for n in names}
        for n in names:
            logging.getLogger(n).setLevel(logging.CRITICAL)

    def restore(self) -> None:
        for n, level in self._levels.items():
            logging.getLogger(n).setLevel(level)
        self._levels = {}


@contextlib.contextmanager
def _children_ignore_ctrl_c():
    """SIGINT ignored in this process while the block runs, so that the processes it starts
    (a LocalCluster's workers: spawned, and an ignored signal stays ignored across exec)
    ignore it too. Ctrl-C in a terminal goes to the whole process group; the workers are
    this process's to end (the CLI reports the interruption in one line), and a worker that
    took the KeyboardInterrupt itself printed its traceback. A Ctrl-C during the cluster's
    start-up (a few seconds) is therefore not seen; a worker the nanny restarts later takes
    the signal as Python does by default. Outside the main thread, where signal handlers
    cannot be set, nothing changes."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


class DaskExecutor(Executor):
    """A :class:`concurrent.futures.Executor` on a Dask cluster: ``submit`` returns a
    ``concurrent.futures.Future`` (Dask's own ``ClientExecutor`` underneath); ``shutdown``
    closes the client, and the ``LocalCluster`` if this executor started it.

    Make it with :meth:`start`. Each task runs with one BLAS thread (see the module
    docstring).
    """

    def __init__(self, client: Any, cluster: Any | None = None, *,
                 quiet: _Quiet | None = None) -> None:  # fmt: skip
        self.client = client
        self.cluster = cluster
        self._quiet = quiet
        self._executor = client.get_executor(pure=False)

    @classmethod
    def start(cls, workers: int = 1, scheduler: str | None = None) -> DaskExecutor:
        """A ``LocalCluster`` of ``workers`` single-threaded worker processes (no dashboard,
        its logs below errors silenced), or a client of the scheduler at ``scheduler``.

        Raises
        ------
        FemcalError
            When Dask is not installed or the scheduler does not answer in
            :data:`CONNECT_TIMEOUT` seconds.
        """
        distributed = _import_distributed()
        quiet = _Quiet()  # the library never prints: Dask's logs stay below critical
        try:
            if scheduler is not None:
                try:
                    client = distributed.Client(scheduler, timeout=CONNECT_TIMEOUT)
                except (OSError, TimeoutError, ValueError) as e:
                    raise FemcalError(f"cannot reach the Dask scheduler at {scheduler!r} "
                                      f"within {CONNECT_TIMEOUT:g} s: {e}") from None  # fmt: skip
                return cls(client, quiet=quiet)
            import dask

            # no statistical profiler in the workers: it samples the task's thread every
            # 10 ms, which costs a Python-heavy task (a Levenberg-Marquardt start) a fifth of
            # its time; no memory limit: femcal checks the memory its arrays need itself, and
            # the nanny would kill a worker at 95 % of an equal share of the machine's
            with dask.config.set({"distributed.worker.profile.enabled": False}), \
                    _children_ignore_ctrl_c():  # fmt: skip
                cluster = distributed.LocalCluster(
                    n_workers=workers, threads_per_worker=1, processes=True,
                    dashboard_address=None, silence_logs=logging.CRITICAL,
                    memory_limit=0)  # fmt: skip
            try:
                client = distributed.Client(cluster)
            except BaseException:
                cluster.close()
                raise
            return cls(client, cluster, quiet=quiet)
        except BaseException:
            quiet.restore()
            raise

    def submit(self, fn: Callable[..., R], /, *args: Any, **kwargs: Any) -> Future[R]:
        if kwargs:
            raise TypeError("DaskExecutor.submit takes positional arguments only")
        if fn is not one_blas_thread:
            fn, args = one_blas_thread, (fn, *args)
        with warnings.catch_warnings():  # Dask's "large object in task graph" note
            warnings.simplefilter("ignore", UserWarning)
            return self._executor.submit(fn, *args)

    def share(self, obj: R) -> R:
        """``obj`` held once on the cluster, for many tasks: pass what this returns in its
        place to :meth:`submit`, and each task receives ``obj``. It is a task of its own
        (not scattered data), so the scheduler recomputes it if its worker is lost."""
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            return self.client.submit(_same, obj, pure=False)

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        try:
            # a client whose scheduler is gone is closed already: nothing left to cancel
            with contextlib.suppress(_closed_client_error()):
                self._executor.shutdown(wait=wait and not cancel_futures)
            self.client.close()
        finally:
            try:
                if self.cluster is not None:
                    self.cluster.close()
            finally:
                if self._quiet is not None:
                    self._quiet.restore()

    def __exit__(self, exc_type, exc, tb) -> bool:
        self.shutdown(wait=exc_type is None, cancel_futures=exc_type is not None)
        return False


def share(pool: Executor, obj: R) -> R:
    """``obj`` as the tasks of ``pool`` should receive it: held once on a Dask cluster
    (:meth:`DaskExecutor.share`), itself elsewhere (a local pool pickles it per task)."""
    return pool.share(obj) if isinstance(pool, DaskExecutor) else obj


def killed_worker_error() -> type[BaseException] | tuple[()]:
    """Dask's exception for a task whose workers died too often (``KilledWorker``), or an
    empty tuple (matching nothing) when Dask is not installed."""
    try:
        from distributed.scheduler import KilledWorker
    except ImportError:
        return ()
    return KilledWorker
