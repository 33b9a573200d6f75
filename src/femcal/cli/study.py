"""``femcal study CONFIG.toml --out DIR``: a design study, a model generator run over the
values of a design variable, the modes tracked by MAC (:mod:`femcal.jobs.study`)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("study", help="design study: modes of a generated model or a deck over a "
                       "variable",
                       description="Run a model generator, or a deck with the fields a "
                       "design variable sets, over the variable's values, solve each "
                       "point's normal modes, track the elastic modes across the points by "
                       "MAC at common stations, and write study.csv, "
                       "study.json and frequencies.png. Each solved point is kept in "
                       "DIR/points/, so a stopped study resumes.")  # fmt: skip
    p.add_argument("config", type=Path, help="study configuration (TOML)")
    p.add_argument("--out", required=True, type=Path, metavar="DIR", help="folder to write into")
    p.add_argument("--workers", type=int, default=1, metavar="N",
                   help="points solved side by side: local processes, or the Dask "
                   "LocalCluster's workers with --engine dask (default 1)")
    p.add_argument("--engine", choices=("local", "dask"),
                   help="where the points are solved: this machine (default) or a Dask "
                   "cluster")  # fmt: skip
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="a running Dask scheduler (tcp://host:8786); implies --engine dask")


def run(args: argparse.Namespace) -> int:
    from ..jobs.study import read_study_config, run_study, summary_lines, write_study
    from ..parallel.cluster import Engine
    from .console import Console
    from .paths import output_folder

    output_folder(args.out, "--out")
    if args.workers < 1:
        print(f"femcal study: --workers {args.workers}: expected at least 1", file=sys.stderr)
        return 2
    if args.scheduler and args.engine == "local":
        print("femcal study: --scheduler needs the Dask engine (not --engine local)",
              file=sys.stderr)  # fmt: skip
        return 2
    kind = "dask" if args.scheduler else (args.engine or "local")
    engine = Engine(kind, args.workers, args.scheduler)
    cfg = read_study_config(args.config)
    progress = Console()
    try:
        result = run_study(cfg, engine=engine, state=args.out / "points", progress=progress)
    finally:
        progress.close()
    print("\n".join(summary_lines(result)))
    for path in write_study(result, args.out):
        print(f"wrote {path}")
    return 0
