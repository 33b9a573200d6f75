"""``femcal calibrate CONFIG.toml --out DIR``: the whole calibration (identification, damping
equalisation, identifiability, surrogate, multi-start Levenberg-Marquardt on the posterior,
report)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import message

if TYPE_CHECKING:
    from ..calibrate.result import CalibrationResult


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("calibrate", help="calibrate a deck's parameters against test FRFs",
                       description="Calibrate FE parameters so the model's FRFs match the "
                       "test's (FEMCali's method). The configuration file is described in "
                       "femcal.calibrate.config; see the README.")  # fmt: skip
    p.add_argument("config", type=Path, help="calibration configuration (TOML)")
    p.add_argument("--out", type=Path, required=True, metavar="DIR",
                   help="results: report.json, report.html, the calibrated deck, pictures")
    p.add_argument("--workers", type=int, metavar="N", help="parallel processes for the starts")
    p.add_argument("--engine", choices=("local", "dask"),
                   help="where the starts run: this machine's processes (local, the default) "
                   "or a Dask cluster (a LocalCluster of --workers processes, or --scheduler)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="a running Dask scheduler (tcp://host:8786) to run the starts on; "
                   "implies --engine dask")
    p.add_argument("--starts", type=int, metavar="N", help="number of starts")
    p.add_argument("--fresh", action="store_true",
                   help="ignore starts finished by an earlier run into DIR")
    p.add_argument("--no-pictures", action="store_true", help="report.json and HTML tables only")
    p.add_argument("--verbose", action="store_true",
                   help="every iteration of every start on the console, not only a progress "
                   "bar per phase")  # fmt: skip


def run(args: argparse.Namespace) -> int:
    from ..calibrate.config import SETTINGS, read_config
    from ..io.calibration import AUGMENTED_FOLDER, summary_lines
    from ..jobs.calibration import run as calibrate
    from .console import Console
    from .paths import output_folder

    progress = Console(verbose=args.verbose)
    output_folder(args.out, "--out")
    for name, v in (("workers", args.workers), ("starts", args.starts)):
        if v is not None and not SETTINGS[name].accepts(v):
            print(f"femcal calibrate: --{name} {v}: expected {SETTINGS[name].expected}",
                  file=sys.stderr)  # fmt: skip
            return 2
    if args.scheduler and args.engine == "local":
        print("femcal calibrate: --scheduler needs the Dask engine (not --engine local)",
              file=sys.stderr)  # fmt: skip
        return 2
    try:
        cfg = read_config(args.config)
        engine = None
        if args.engine or args.scheduler:
            from ..parallel.cluster import Engine

            kind = "dask" if args.scheduler else args.engine
            engine = Engine(kind, args.workers or cfg.workers,
                            args.scheduler or (cfg.scheduler if kind == "dask" else None))
        result = calibrate(cfg, args.out, fresh=args.fresh, workers=args.workers,
                           starts=args.starts, engine=engine, progress=progress)  # fmt: skip
    except (KeyError, ValueError) as e:
        progress.close()
        print(f"femcal calibrate: {message(e)}", file=sys.stderr)
        return 2
    finally:
        progress.close()  # a bar left open by an interruption or an error
    if cfg.pictures and not args.no_pictures:
        from ..io.calibration import write_report

        write_report(result, args.out, progress=progress)
        if result.augmented is not None:  # the calibration with the model-form element
            write_report(result.augmented.result, args.out / AUGMENTED_FOLDER,
                         progress=progress)  # fmt: skip
    _print_parameters(result)
    if result.augmented is not None:
        print(f"\nwith {result.augmented.added.describe()} added "
              f"({args.out / AUGMENTED_FOLDER}):")  # fmt: skip
        _print_parameters(result.augmented.result)
        print()
    def fmt(v, spec):
        return format(v, spec) if v is not None else "-"

    for case in result.cases:
        if len(result.cases) > 1:
            print(f"configuration {case.name}:")
        print(f"{'test Hz':>9} {'FE before':>10} {'FE after':>10} {'MAC before':>11} "
              f"{'MAC after':>10}")
        for m in case.modes:
            print(f"{m.test_hz:9.3f} {fmt(m.fe_before_hz, '10.3f')} "
                  f"{fmt(m.fe_after_hz, '10.3f')} {fmt(m.mac_before, '11.4f')} "
                  f"{fmt(m.mac_after, '10.4f')}")
        print(f"deviation: {case.deviation_before:.6g} before, {case.deviation_after:.6g} "
              "after")
    print()
    for line in summary_lines(result):
        print(line)
    return 0


def _print_parameters(result: CalibrationResult) -> None:
    """The parameter table: nominal, calibrated, change, prior and posterior, status."""
    w = max([10, *(len(r.parameter.name) for r in result.parameters)])
    print(f"{'parameter':<{w}} {'nominal':>12} {'calibrated':>12} {'change %':>9} "
          f"{'prior %':>8} {'post. %':>8} status")
    for r in result.parameters:
        status = "held" if r.held else ("identifiable" if r.identifiable else "weak")
        post = "-" if r.held else f"{100 * r.posterior_std_p:.2f}"
        print(f"{r.parameter.name:<{w}} {r.parameter.nominal:12.6g} {r.calibrated:12.6g} "
              f"{100 * r.p:+9.2f} {100 * r.prior_std_p:8.2f} {post:>8} {status}"
              f"{' (at a bound!)' if r.at_bound else ''}")
