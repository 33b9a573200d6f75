"""``femcal frf DECK --input GID:C ... --output GID:C ... --freq F1:F2:DF [--damping Z]
[--quantity Q] [--residual] --out FILE.npz|.csv|.uff|.mat``: FRFs by modal superposition."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from ..assembly import Options, assemble
from ..model import EigenRequest
from ..model.build import load_model
from ..response.frf import modal_frf, point_matrix, residual_flexibility
from ..response.modal import QUANTITIES
from ..solve.normal_modes import solve_normal_modes
from ..testdata.data import FRFData
from ..testdata.formats import format_of, write_frf


def _point(text: str) -> tuple[int, int]:
    try:
        g, c = text.split(":")
        return int(g), int(c)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r}: expected GRID:COMPONENT, e.g. 1001:3"
        ) from None


def _band(text: str) -> np.ndarray:
    try:
        f1, f2, df = (float(v) for v in text.split(":"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected F1:F2:DF in Hz") from None
    if not (0 <= f1 < f2 and df > 0):
        raise argparse.ArgumentTypeError(f"{text!r}: expected 0 <= F1 < F2 and DF > 0")
    return f1 + df * np.arange(int(np.floor((f2 - f1) / df + 1e-9)) + 1)


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("frf", help="frequency responses of a deck by modal superposition")
    p.add_argument("deck", type=Path, help="NASTRAN input file")
    p.add_argument(
        "--input",
        type=_point,
        action="append",
        required=True,
        metavar="GID:C",
        help="force input: grid and component 1-6 in its output frame (repeat)",
    )
    p.add_argument(
        "--output",
        type=_point,
        action="append",
        required=True,
        metavar="GID:C",
        help="response output: grid and component 1-6 (repeat)",
    )
    p.add_argument(
        "--freq",
        type=_band,
        required=True,
        metavar="F1:F2:DF",
        help="frequencies in Hz, e.g. 0.05:150:0.05",
    )
    p.add_argument(
        "--damping",
        type=float,
        default=0.02,
        metavar="Z",
        help="modal damping ratio of every mode (default 0.02)",
    )
    p.add_argument("--quantity", choices=QUANTITIES, default="receptance")
    p.add_argument(
        "--modes-to",
        type=float,
        metavar="HZ",
        help="modes used: all up to HZ (default twice the highest frequency)",
    )
    p.add_argument(
        "--residual",
        action="store_true",
        help="add the residual flexibility of the modes left out (restrained models)",
    )
    p.add_argument(
        "--out",
        type=Path,
        required=True,
        metavar="FILE",
        help="FILE.npz, FILE.csv, FILE.uff (UFF 58) or FILE.mat",
    )


def run(args: argparse.Namespace) -> int:
    t0 = time.perf_counter()

    def progress(msg: str) -> None:
        print(f"[{time.perf_counter() - t0:7.1f} s] {msg}", file=sys.stderr, flush=True)

    try:
        format_of(args.out, "frf", writing=True)
    except ValueError as e:
        print(f"femcal frf: --out {e}", file=sys.stderr)
        return 2
    progress(f"reading {args.deck}")
    model = load_model(args.deck)
    try:
        C = point_matrix(model, args.output)
        B = point_matrix(model, args.input).T
    except ValueError as e:
        print(f"femcal frf: {e}", file=sys.stderr)
        return 2
    f = args.freq
    top = args.modes_to if args.modes_to is not None else 2.0 * float(f[-1])
    mats = assemble(model, Options())
    modes, red = solve_normal_modes(model, matrices=mats, request=EigenRequest(v2=top, nd=None),
                                    progress=progress)  # fmt: skip
    progress(f"{len(modes.eigenvalues)} modes up to {top:g} Hz")
    R = None
    if args.residual:
        keep = modes.radians > 0
        try:
            R = residual_flexibility(
                red.reduce(mats.K), red.T, C, B, modes.shapes[:, keep], modes.radians[keep]
            )
        except ValueError as e:
            print(f"femcal frf: --residual: {e}", file=sys.stderr)
            return 2
    H = modal_frf(modes.shapes, modes.radians, C, B, f, args.damping, args.quantity, R)
    data = FRFData.from_labels(
        f,
        H,
        [f"{g}:{c}" for g, c in args.output],
        [f"{g}:{c}" for g, c in args.input],
        args.quantity,
    )
    write_frf(args.out, data)
    progress(
        f"wrote {args.out}: {H.shape[0]} outputs x {H.shape[1]} inputs x {H.shape[2]} frequencies"
    )
    return 0
