"""``femcal correlate DECK TEST [--sensors CSV] [--band F1 F2] [--modes N]
[--identify-band F1 F2] [--split F ...] [--order N|auto ...] [--min-mac M] [--out DIR]``:
an FE model's modes against a test's (MAC and frequency pairs), without calibration
(:mod:`femcal.jobs.correlate`)."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from ..identify.workflow import METHODS
from ..jobs.correlate import FE_RATIO, IDENTIFY_MARGIN, run_correlation, summary_lines
from .identify import _order
from .paths import UsageError, output_folder


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("correlate", help="correlate FE modes with test modes (MAC, frequency)",
                       description="Pair the modes of an FE model with a test's by MAC and "
                       "frequency: the deck solved (or the modes.npz of femcal solve --out) "
                       "against FRFs identified over the band (any format femcal reads) or "
                       "an identified model (model.npz of femcal identify --out), at the "
                       "test's channels. Writes the paired table, the MAC matrix and a "
                       "self-contained HTML page with the shapes.")  # fmt: skip
    p.add_argument("deck", type=Path, help="NASTRAN deck, or modes.npz of femcal solve --out")
    p.add_argument("test", type=Path,
                   help="test FRFs (.npz, .csv, .uff/.unv, .mat) or an identified model "
                   "(model.npz of femcal identify --out)")  # fmt: skip
    p.add_argument("--sensors", type=Path, metavar="CSV",
                   help="sensors CSV (label, grid, ..., directions): places channels "
                   "labelled LABEL:+X|+Y|+Z on the sensors' grids")  # fmt: skip
    p.add_argument("--band", type=float, nargs=2, metavar=("F1", "F2"),
                   help="test band in Hz: the FRFs are identified over it (needed for FRFs); "
                   "of an identified model the modes in it are kept (default its band)")
    p.add_argument("--modes", type=int, metavar="N",
                   help=f"the lowest N FE modes: solved from the deck, or kept of a modes "
                   f"file (default: every mode up to {FE_RATIO:g} x F2 of the deck; all of "
                   "the file)")  # fmt: skip
    p.add_argument("--identify-band", type=float, nargs=2, metavar=("F1", "F2"),
                   help=f"identify the FRFs over this band (holding --band; default --band "
                   f"widened by a factor {IDENTIFY_MARGIN:g} on each side, within the data)")
    p.add_argument("--split", type=float, nargs="+", default=None, metavar="F",
                   help="identify in parts split at these frequencies (Hz); default: chosen "
                   "from the CMIF's peaks")
    p.add_argument("--method", choices=METHODS, default="plscf",
                   help="the identification's estimator: plscf (default) or subspace")
    p.add_argument("--order", type=_order, nargs="+", default=None, metavar="N",
                   help="identification order: one for every part, or one per part; 'auto' "
                   "(default) from each part's stabilisation diagram")  # fmt: skip
    p.add_argument("--min-mac", type=float, default=0.4, metavar="M",
                   help="lowest MAC of a pair (default 0.4)")
    p.add_argument("--out", type=Path, metavar="DIR",
                   help="write correlation.csv, mac.csv and correlation.html")


def _check(args: argparse.Namespace) -> None:
    """Refuse unusable options (UsageError, exit status 2) before any file is read."""
    for option, band in (("--band", args.band), ("--identify-band", args.identify_band)):
        if band is not None and not (np.isfinite(band).all() and 0 < band[0] < band[1]):
            raise UsageError(f"{option} {band[0]:g} {band[1]:g}: expected 0 < F1 < F2 (Hz, "
                             "finite)")  # fmt: skip
    if args.identify_band is not None:
        if args.band is None:
            raise UsageError("--identify-band: needs --band (the band of the test modes)")
        (i1, i2), (f1, f2) = args.identify_band, args.band
        if not (i1 <= f1 and f2 <= i2):
            raise UsageError(f"--identify-band {i1:g} {i2:g}: expected it to hold --band "
                             f"{f1:g} {f2:g}")  # fmt: skip
        lo, hi = i1, i2
    elif args.band is not None:
        lo, hi = args.band[0] / IDENTIFY_MARGIN, args.band[1] * IDENTIFY_MARGIN
    elif args.split:
        raise UsageError("--split: needs --band (the FRFs are identified around it)")
    bad = [x for x in args.split or () if not (np.isfinite(x) and lo < x < hi)]
    if bad:
        raise UsageError(f"--split {bad[0]:g}: expected a frequency inside the identification "
                         f"band {lo:g}-{hi:g} Hz")  # fmt: skip
    if args.order is not None and len(args.order) > 1 and args.split is None:
        raise UsageError(f"--order: {len(args.order)} orders without --split; expected one "
                         "order for every part, or --split with one order per part")
    n_parts = len(args.split or ()) + 1
    if args.order is not None and len(args.order) not in (1, n_parts):
        raise UsageError(f"--order: {len(args.order)} orders for {n_parts} parts; expected one "
                         "for every part or one per part")  # fmt: skip
    if args.modes is not None and args.modes < 1:
        raise UsageError(f"--modes {args.modes}: expected a number of modes >= 1")
    if not (np.isfinite(args.min_mac) and 0 <= args.min_mac <= 1):
        raise UsageError(f"--min-mac {args.min_mac:g}: expected a MAC in [0, 1]")
    output_folder(args.out, "--out")


def run(args: argparse.Namespace) -> int:
    t0 = time.perf_counter()

    def progress(msg: str) -> None:
        print(f"[{time.perf_counter() - t0:7.1f} s] {msg}", file=sys.stderr, flush=True)

    _check(args)
    orders = args.order
    if orders is not None and len(orders) == 1:
        orders = orders[0]
    result, _files = run_correlation(
        args.deck, args.test, sensors=args.sensors,
        band=None if args.band is None else tuple(args.band), n_modes=args.modes,
        identify_band=None if args.identify_band is None else tuple(args.identify_band),
        splits=args.split, orders=orders, min_mac=args.min_mac, out=args.out,
        progress=progress, method=args.method)  # fmt: skip
    print("\n".join(summary_lines(result)))
    return 0
