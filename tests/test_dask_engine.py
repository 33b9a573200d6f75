"""The calibration's starts on a Dask cluster (issue 28): the same result as on this
machine's process pool, and the same again when a worker is killed mid-run."""

from __future__ import annotations

import os
import signal
import threading
import time

import numpy as np
import pytest

from femcal.calibrate.config import read_config
from femcal.jobs.calibration import run
from femcal.parallel.cluster import Engine

from .test_calibrate_workflow import TINY, _tiny_copy, tiny  # noqa: F401 (a fixture)

distributed = pytest.importorskip("distributed", reason="the Dask engine needs distributed")

#: The tiny plate calibration with enough starts to keep two workers busy.
CONFIG = TINY.replace("starts = 2", "starts = 16").replace("workers = 1", "workers = 2")


def _calibrate(tiny, folder, engine: Engine | None):  # noqa: F811
    cfg = read_config(_tiny_copy(tiny, folder, CONFIG))
    return run(cfg, folder / "out", engine=engine)


#: Two runs of the same arithmetic with one BLAS thread each, in two processes: the same
#: numbers in practice, but which SIMD path numpy and BLAS take for a small array can depend on
#: its memory alignment, so they are compared to a few rounding errors of the converged
#: parameters and costs, not bit for bit.
SAME_RUN = 1e-12


def _same(a, b) -> None:
    """Two calibrations that agree to rounding: every start and the result."""
    assert len(a.cycles) == len(b.cycles)
    for ca, cb in zip(a.cycles, b.cycles, strict=True):
        assert [s.start for s in ca.starts] == [s.start for s in cb.starts]
        for sa, sb in zip(ca.starts, cb.starts, strict=True):
            np.testing.assert_allclose(sa.p, sb.p, rtol=SAME_RUN, atol=SAME_RUN)
            assert sa.iterations == sb.iterations
            assert sa.cost == pytest.approx(sb.cost, rel=SAME_RUN)
    np.testing.assert_allclose(a.p_final, b.p_final, rtol=SAME_RUN, atol=SAME_RUN)
    assert a.deviation_after == pytest.approx(b.deviation_after, rel=SAME_RUN)


@pytest.fixture(scope="module")
def on_the_pool(tiny, tmp_path_factory):  # noqa: F811
    """The calibration on the default engine: two local worker processes."""
    return _calibrate(tiny, tmp_path_factory.mktemp("pool"), None)


@pytest.mark.parametrize("engine", [Engine("dask", workers=2), Engine("local", workers=1)],
                         ids=["dask LocalCluster", "this process"])  # fmt: skip
def test_the_starts_give_the_pools_result_wherever_they_run(tiny, tmp_path,  # noqa: F811
                                                             on_the_pool, engine):  # fmt: skip
    """On a Dask LocalCluster of two workers, or one after another in this process: the
    same calibration as on two local worker processes, bit for bit (one BLAS thread per
    start everywhere)."""
    elsewhere = _calibrate(tiny, tmp_path, engine)
    assert len(elsewhere.cycles[0].starts) == 16
    _same(elsewhere, on_the_pool)


def test_a_worker_killed_mid_run_costs_its_start_not_the_result(tiny, tmp_path,  # noqa: F811
                                                                on_the_pool):  # fmt: skip
    """A running scheduler (here a LocalCluster of two workers started by the test, given
    to femcal by its address as ``--scheduler`` would): one worker is killed (SIGKILL) while
    it runs a start; the scheduler runs that start again on another worker (its nanny
    restarts the killed one), and the calibration ends with the pool's result."""
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       dashboard_address=None, silence_logs=50)  # fmt: skip
    client = distributed.Client(cluster)
    killed: list[tuple[str, int, int]] = []  # (worker, pid, tasks it was running)

    def kill_a_busy_worker() -> None:
        pids = client.run(os.getpid)
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:
            busy = {w: keys for w, keys in client.processing().items()
                    if any("one_blas_thread" in str(k) for k in keys)}  # fmt: skip
            if busy:
                worker, keys = next(iter(busy.items()))
                os.kill(pids[worker], signal.SIGKILL)
                killed.append((worker, pids[worker], len(keys)))
                return
            time.sleep(0.005)

    try:
        killer = threading.Thread(target=kill_a_busy_worker, daemon=True)
        killer.start()
        on_dask = _calibrate(tiny, tmp_path, Engine("dask", scheduler=cluster.scheduler_address))
        killer.join(5)
        assert killed and killed[0][2] >= 1  # a worker died while it ran a start
        _same(on_dask, on_the_pool)
    finally:
        client.close()
        cluster.close()


TWO = """
[[configuration]]
name = "whole"
deck = "main.bdf"
parameters = "p.toml"
frf = "test.npz"

[[configuration]]
name = "lower"
deck = "main.bdf"
parameters = "p.toml"
frf = "test.npz"
band = [10.0, 200.0]
""" + CONFIG.split("[test]\nfrf = \"test.npz\"\n")[1]


@pytest.mark.slow  # two whole calibrations; the fast tier runs starts and failures on Dask
def test_the_surrogates_of_two_configurations_build_on_the_cluster(tiny, tmp_path):  # noqa: F811
    """Two configurations (the plate's test over two bands): their surrogates are built on
    the cluster side by side, with the result of building them one after another here, to
    the rounding of BLAS (a worker runs one BLAS thread, this process several, and their
    sums differ in the last digits; measured 8e-8 relative on p)."""
    results = []
    for k, engine in enumerate((None, Engine("dask", workers=2))):
        (tmp_path / str(k)).mkdir()
        cfg = read_config(_tiny_copy(tiny, tmp_path / str(k), TWO))
        lines: list[str] = []
        results.append(run(cfg, tmp_path / str(k) / "out", engine=engine,
                           progress=lines.append))  # fmt: skip
        built_there = [x for x in lines if "surrogates of 2 configurations building" in x]
        assert len(built_there) == (0 if engine is None else 2)  # cycles 1 and 2
    assert [c.name for c in results[1].cases] == ["whole", "lower"]
    a, b = results
    assert len(a.cycles) == len(b.cycles)
    np.testing.assert_allclose(a.p_final, b.p_final, rtol=1e-6, atol=1e-9)
    assert a.deviation_after == pytest.approx(b.deviation_after, rel=1e-5)
    assert a.deviation_before == pytest.approx(b.deviation_before, rel=1e-9)


@pytest.mark.parametrize(("line", "error"), [
    ('engine = "spark"', r"engine = 'spark': expected \"local\" or \"dask\""),
    ('scheduler = "tcp://localhost:8786"',
     r"scheduler = 'tcp://localhost:8786' needs engine = \"dask\" \(engine is 'local'\)"),
    ("scheduler = 8786", r"scheduler = 8786: expected a string"),
])  # fmt: skip
def test_engine_keys_are_checked(tiny, tmp_path, line, error):  # noqa: F811
    from femcal.calibrate.config import ConfigError

    text = CONFIG.replace("seed = 1", f"seed = 1\n{line}")
    with pytest.raises(ConfigError, match=error):
        read_config(_tiny_copy(tiny, tmp_path, text))


def test_a_scheduler_that_does_not_answer_is_one_line(tiny, tmp_path, monkeypatch,  # noqa: F811
                                                      capsys):  # fmt: skip
    """No scheduler at the address: the command says so in one line (exit status 1 or 2),
    without a traceback, after the connection's time-out."""
    from femcal import cli
    from femcal.parallel import cluster

    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT", 2.0)
    cfg = _tiny_copy(tiny, tmp_path, CONFIG)
    code = cli.main(["calibrate", str(cfg), "--out", str(tmp_path / "out"),
                     "--scheduler", "tcp://127.0.0.1:9"])  # fmt: skip
    err = capsys.readouterr().err
    assert code != 0 and "Traceback" not in err
    last = err.strip().splitlines()[-1]
    assert "cannot reach the Dask scheduler at 'tcp://127.0.0.1:9' within 2 s" in last, err
    assert cli.main(["calibrate", str(cfg), "--out", str(tmp_path / "out"), "--engine",
                     "local", "--scheduler", "tcp://127.0.0.1:9"]) == 2  # fmt: skip
    assert "--scheduler needs the Dask engine" in capsys.readouterr().err


def test_the_parts_of_an_identification_on_the_cluster():
    """A noisy test split into three parts, each identified on a Dask worker (automatic
    orders): the same poles and model as one after another here, to BLAS rounding."""
    from femcal.identify import identify
    from femcal.parallel.cluster import DaskExecutor

    from .test_identify import BAND, modal_set

    data, _ = modal_set(noise=0.02, seed=1, p=24)
    here = identify(data, BAND, splits=(40.0, 60.0))
    with DaskExecutor.start(2) as pool:
        there = identify(data, BAND, splits=(40.0, 60.0), pool=pool)
    assert [(p.band, p.order) for p in there.parts] == [(p.band, p.order) for p in here.parts]
    assert len(there.parts) == 3
    np.testing.assert_allclose(there.frequency_hz, here.frequency_hz, rtol=1e-9)
    np.testing.assert_allclose(there.damping_ratio, here.damping_ratio, rtol=1e-6)


def _die() -> None:
    os.kill(os.getpid(), signal.SIGKILL)  # as the system's out-of-memory killer would


def _fail() -> None:
    raise ValueError("the task's own error")


def _sleep(seconds: float) -> float:
    time.sleep(seconds)
    return seconds


def test_a_lost_local_worker_is_one_line():
    """A local worker process killed mid-task: a ResourceError that says what was lost and
    what is kept, not the pool's BrokenProcessPool."""
    from femcal.errors import ResourceError
    from femcal.parallel.cluster import result_of

    with Engine("local", workers=2).open() as pool:
        job = pool.submit(_die)
        with pytest.raises(ResourceError, match=r"a worker process ended without the result "
                                                r"of a test task .*; nothing else lost"):
            result_of(job, "a test task", "nothing else lost")


def test_dask_failures_are_one_line_and_dask_prints_nothing(capfd):
    """On a Dask LocalCluster: a task's own error comes back as it is, and neither the
    worker nor the client prints Dask's log of it; a cluster that goes away mid-task is a
    one-line FemcalError."""
    from femcal.errors import FemcalError
    from femcal.parallel.cluster import DaskExecutor, result_of

    with DaskExecutor.start(1) as pool, pytest.raises(ValueError, match="the task's own error"):
        result_of(pool.submit(_fail), "a test task")
    err = capfd.readouterr().err
    assert "distributed" not in err and "Traceback" not in err, err
    pool = DaskExecutor.start(1)
    try:
        job = pool.submit(_sleep, 30.0)
        time.sleep(1.0)
        pool.cluster.close()
        with pytest.raises(FemcalError, match=r"a test task was cancelled|connection to the "
                                              "Dask cluster was lost"):  # fmt: skip
            result_of(job, "a test task")
    finally:
        pool.shutdown(wait=False, cancel_futures=True)
