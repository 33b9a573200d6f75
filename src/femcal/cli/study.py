"""``femcal study CONFIG.toml --out DIR``: a design study, a model generator run over the
values of a design variable, the modes tracked by MAC (:mod:`femcal.jobs.study`)."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("study", help="design study: modes of a generated model over a variable",
                       description="Run a model generator over the values of a design "
                       "variable, solve each point's normal modes, track the elastic modes "
                       "across the points by MAC at common stations, and write study.csv, "
                       "study.json and frequencies.png.")  # fmt: skip
    p.add_argument("config", type=Path, help="study configuration (TOML)")
    p.add_argument("--out", required=True, type=Path, metavar="DIR", help="folder to write into")


def run(args: argparse.Namespace) -> int:
    from ..jobs.study import read_study_config, run_study, summary_lines, write_study
    from .console import Console
    from .paths import output_folder

    output_folder(args.out, "--out")
    cfg = read_study_config(args.config)
    progress = Console()
    try:
        result = run_study(cfg, progress=progress)
    finally:
        progress.close()
    print("\n".join(summary_lines(result)))
    for path in write_study(result, args.out):
        print(f"wrote {path}")
    return 0
