"""Scaling of the workflow's independent tasks on 1 and 2 workers (issue 28): the hammer
calibration's Levenberg-Marquardt starts and the bundled design study's points, on this
machine's process pool and on a Dask LocalCluster.

    .venv/bin/python benchmarks/scaling.py [--starts 8] [--part starts|study|both]

``starts``: the demo calibration (models/truck_frame/hammer_calibration.toml: the shipped
test identified, 30 parameters, the 100-mode exact surrogate) is run up to its first
multi-start search, whose problem is taken there; then ``--starts`` of its start points are
run again on each engine (serial in this process, 2 local worker processes, Dask
LocalClusters of 1 and 2 workers, the cluster's start-up included) and the wall time and the
results compared (every engine must give the serial starts bit for bit). It also prints the
surrogate build's time and the problem's pickled size, the costs a projection to many
machines needs (docs/scaling.md).

``study``: models/truck_frame/cross_member_study.toml (three points of the hammer frame)
solved one after another, on 2 local processes and on a Dask LocalCluster of 2 workers.

The machine is shared: compare the ratios of one run, not times across runs.
"""

from __future__ import annotations

import argparse
import pickle
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
FRAME = ROOT / "models" / "truck_frame"
WORK = ROOT / "benchmarks" / "_work" / "scaling"


class _Taken(Exception):
    """Raised inside the calibration once its first search's problem is taken."""


def first_search_problem() -> tuple[object, list[np.ndarray], float]:
    """The demo calibration's first multi-start problem and start points, and the seconds
    from the run's start to the end of the nominal surrogate's build."""
    from femcal.calibrate import workflow
    from femcal.calibrate.config import read_config
    from femcal.jobs.calibration import run

    taken: dict[str, object] = {}
    stamps: list[tuple[float, str]] = []

    def take(problem, pts, **_kw):
        taken["problem"], taken["pts"] = problem, pts
        raise _Taken

    cfg = replace(read_config(FRAME / "hammer_calibration.toml"), pictures=False)
    real = workflow.run_starts
    workflow.run_starts = take
    t0 = time.perf_counter()
    try:
        run(cfg, WORK / "calibration", fresh=True,
            progress=lambda m: stamps.append((time.perf_counter() - t0, str(m))))
    except _Taken:
        pass
    finally:
        workflow.run_starts = real
    built = next(t for t, m in reversed(stamps) if "identifiability at the nominal" in m)
    started = next(t for t, m in stamps if m.startswith("cycle 1:"))
    return taken["problem"], taken["pts"], built - started


def part_starts(n: int) -> None:
    from femcal.calibrate.starts import run_starts
    from femcal.parallel.cluster import Engine

    print(f"## The hammer calibration's first search: {n} starts\n")
    t = time.perf_counter()
    problem, pts, build = first_search_problem()
    print(f"set-up to the first search: {time.perf_counter() - t:.1f} s; the nominal "
          f"surrogate and its exact gradient: {build:.1f} s; the problem pickled: "
          f"{len(pickle.dumps(problem)) / 1e6:.1f} MB\n")
    pts = pts[:n]
    engines = [("serial, this process", Engine("local", 1)),
               ("2 local processes", Engine("local", 2)),
               ("Dask LocalCluster, 1 worker", Engine("dask", 1)),
               ("Dask LocalCluster, 2 workers", Engine("dask", 2))]
    print("| engine | wall s | per start s | speed-up | same starts |")
    print("|---|---|---|---|---|")
    ref = None
    for name, engine in engines:
        t = time.perf_counter()
        with engine.session() as session:  # a Dask cluster's start-up counted
            res = run_starts(problem, pts, session=session)
        wall = time.perf_counter() - t
        if ref is None:
            ref = (res, wall)
        same = all(np.array_equal(a.p, b.p) and a.cost == b.cost
                   for a, b in zip(res, ref[0], strict=True))  # fmt: skip
        print(f"| {name} | {wall:.1f} | {wall / n:.2f} | {ref[1] / wall:.2f} | "
              f"{'yes' if same else 'NO'} |")
    seconds = [r.seconds for r in ref[0]]
    print(f"\nper start in a worker: {np.mean(seconds):.2f} s mean, {min(seconds):.2f}-"
          f"{max(seconds):.2f} s; iterations {min(r.iterations for r in ref[0])}-"
          f"{max(r.iterations for r in ref[0])}\n")


def part_study() -> None:
    from femcal.jobs.study import read_study_config, run_study
    from femcal.parallel.cluster import Engine

    cfg = read_study_config(FRAME / "cross_member_study.toml")
    print(f"## The design study: {len(cfg.values)} points of the hammer frame\n")
    print("| engine | wall s | speed-up | same frequencies (rel) |")
    print("|---|---|---|---|")
    ref = None
    for name, engine in (("serial, this process", Engine("local", 1)),
                         ("2 local processes", Engine("local", 2)),
                         ("Dask LocalCluster, 2 workers", Engine("dask", 2))):  # fmt: skip
        t = time.perf_counter()
        res = run_study(cfg, engine=engine)
        wall = time.perf_counter() - t
        if ref is None:
            ref = (res, wall)
        diff = max(float(np.max(np.abs(a.frequencies / b.frequencies - 1)))
                   for a, b in zip(res.points, ref[0].points, strict=True))  # fmt: skip
        print(f"| {name} | {wall:.1f} | {ref[1] / wall:.2f} | {diff:.1e} |")
    print()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--starts", type=int, default=8, help="starts per engine (default 8)")
    ap.add_argument("--part", choices=("starts", "study", "both"), default="both")
    args = ap.parse_args(argv)
    WORK.mkdir(parents=True, exist_ok=True)
    if args.part in ("starts", "both"):
        part_starts(args.starts)
    if args.part in ("study", "both"):
        part_study()
    return 0


if __name__ == "__main__":
    sys.exit(main())
