"""``femcal timedata info FILE [--json OUT]``: what a time-history file holds (MTS RPC III
.rsp, .tim, .drv; CSV with a time column; NPZ: the formats registered for time histories,
read by :func:`femcal.testdata.formats.read_time_data`): step, length and every channel's
name, unit and range."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from ..atomic import write_lines
from ..testdata.formats import formats, read_time_data, suffixes
from ..testdata.timedata import TimeData


def add_parser(sub: argparse._SubParsersAction) -> None:
    kinds = "; ".join(f"{f.description} ({', '.join(f.suffixes)})" for f in formats("time"))
    p = sub.add_parser("timedata", help="time histories (RPC III, CSV, NPZ): summaries",
                       description=f"Time-history files of a rig test: {kinds}.")  # fmt: skip
    tsub = p.add_subparsers(dest="action", required=True, metavar="ACTION")
    info = tsub.add_parser("info", help="step, length and each channel's name, unit and range")
    info.add_argument("file", type=Path,
                      help=f"time-history file ({', '.join(suffixes('time'))})")  # fmt: skip
    info.add_argument("--json", type=Path, metavar="OUT", help="also write the summary as JSON")


def summary(data: TimeData) -> dict:
    """``{"dt", "n_samples", "channels": [{"name", "unit", "max", "min", "mean", "rms"}]}``."""
    v = data.values
    return {
        "dt": data.dt,
        "n_samples": data.n_samples,
        "channels": [
            {"name": data.names[c], "unit": data.units[c], "max": float(v[c].max()),
             "min": float(v[c].min()), "mean": float(v[c].mean()),
             "rms": float(np.sqrt(np.mean(v[c] ** 2)))}
            for c in range(data.n_channels)
        ],
    }  # fmt: skip


def run(args: argparse.Namespace) -> int:
    data = read_time_data(args.file)
    s = summary(data)
    print(f"{args.file}: {data.n_channels} channels x {data.n_samples} samples, dt = "
          f"{data.dt:g} s ({1 / data.dt:g} Hz), {data.n_samples * data.dt:g} s")
    print(f"{'#':>3} {'name':<24} {'unit':<10} {'min':>12} {'max':>12} {'mean':>12} {'rms':>12}")
    for k, c in enumerate(s["channels"], 1):
        print(f"{k:>3} {c['name'][:24]:<24} {c['unit'][:10]:<10} {c['min']:12.5g} "
              f"{c['max']:12.5g} {c['mean']:12.5g} {c['rms']:12.5g}")
    if args.json:
        write_lines(args.json, [json.dumps(s, indent=1)])
    return 0
