"""``femcal frf DECK --input GID:C ... --output GID:C ... --freq F1:F2:DF [--damping Z]
[--quantity Q] [--residual] --out FILE.npz|.csv|.uff|.mat``: FRFs by modal superposition."""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..assembly import Options, assemble
from ..errors import ResourceError
from ..model import EigenRequest
from ..model.build import load_model
from ..resources import check_memory
from ..response.frf import modal_frf, point_matrix, residual_flexibility
from ..response.modal import QUANTITIES
from ..solve.normal_modes import solve_normal_modes
from ..testdata.data import FRFData
from ..testdata.formats import write_frf
from .paths import UsageError, output_file


def _point(text: str) -> tuple[int, int]:
    try:
        g, c = text.split(":")
        return int(g), int(c)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r}: expected GRID:COMPONENT, e.g. 1001:3"
        ) from None


@dataclass(frozen=True)
class Grid:
    """The frequency grid of ``--freq F1:F2:DF`` (Hz): F1, F1 + DF, ... up to F2; ``text``
    as given."""

    f1: float
    f2: float
    df: float
    text: str

    def problem(self) -> str | None:
        """What is wrong with the grid, or None."""
        if not all(np.isfinite(v) for v in (self.f1, self.f2, self.df)):
            return "expected finite numbers"
        if not (0 <= self.f1 < self.f2 and self.df > 0):
            return "expected 0 <= F1 < F2 and DF > 0"
        return None

    def count(self) -> int:
        """Number of frequencies (a finite grid, see :meth:`problem`)."""
        return int(np.floor((self.f2 - self.f1) / self.df + 1e-9)) + 1

    def frequencies(self) -> np.ndarray:
        """The grid (n,), Hz."""
        return self.f1 + self.df * np.arange(self.count())

    def __str__(self) -> str:
        return self.text


def _band(text: str) -> Grid:
    try:
        f1, f2, df = (float(v) for v in text.split(":"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected F1:F2:DF in Hz") from None
    return Grid(f1, f2, df, text)


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


#: Bytes per value of H (complex128) and the number of (k, n_freq) complex arrays the modal
#: sum makes (the modal factors, their denominators and the product in einsum).
_BYTES, _MODAL_ARRAYS = 16, 3


def _count(n: int) -> str:
    """``999,999,999,001``, or ``1e+300`` for a number too long to read."""
    return f"{n:,}" if n < 10**15 else f"{float(n):.3g}"


def _check(args: argparse.Namespace) -> str | None:
    """What is wrong with the arguments, as one line, or None; checked before the deck is
    read, and the grid against the memory before anything is allocated."""
    grid: Grid = args.freq
    problem = grid.problem()
    if problem:
        return f"--freq {grid}: {problem}"
    if not (np.isfinite(args.damping) and 0 <= args.damping < 1):
        return f"--damping {args.damping:g}: expected a damping ratio 0 <= Z < 1 (0.02 is 2 %)"
    if args.modes_to is not None and not (np.isfinite(args.modes_to) and args.modes_to > 0):
        return f"--modes-to {args.modes_to:g}: expected a frequency above 0 Hz"
    try:
        output_file(args.out, "--out", "frf")
    except UsageError as e:
        return str(e)
    n = grid.count()
    check_memory(float(n) * (_BYTES * len(args.output) * len(args.input) + 8),
                 f"--freq {grid} ({_count(n)} frequencies) for {len(args.output)} outputs x "
                 f"{len(args.input)} inputs")  # fmt: skip
    return None


def run(args: argparse.Namespace) -> int:
    t0 = time.perf_counter()

    def progress(msg: str) -> None:
        print(f"[{time.perf_counter() - t0:7.1f} s] {msg}", file=sys.stderr, flush=True)

    try:
        problem = _check(args)
    except ResourceError as e:
        problem = str(e)
    if problem:
        print(f"femcal frf: {problem}", file=sys.stderr)
        return 2
    progress(f"reading {args.deck}")
    model = load_model(args.deck)
    try:
        C = point_matrix(model, args.output)
        B = point_matrix(model, args.input).T
    except ValueError as e:
        print(f"femcal frf: {e}", file=sys.stderr)
        return 2
    grid: Grid = args.freq
    top = args.modes_to if args.modes_to is not None else 2.0 * grid.f2
    mats = assemble(model, Options())
    modes, red = solve_normal_modes(model, matrices=mats, request=EigenRequest(v2=top, nd=None),
                                    progress=progress)  # fmt: skip
    progress(f"{len(modes.eigenvalues)} modes up to {top:g} Hz")
    if len(modes.eigenvalues) == 0 and not args.residual:
        print(f"femcal frf: no mode up to {top:g} Hz: every FRF would be zero; expected "
              "--modes-to above the first mode, or --residual", file=sys.stderr)  # fmt: skip
        return 2
    n = grid.count()
    try:
        check_memory(float(n) * _BYTES * (len(args.output) * len(args.input)
                                          + _MODAL_ARRAYS * len(modes.eigenvalues)),
                     f"--freq {grid} ({_count(n)} frequencies) for {len(args.output)} outputs x "
                     f"{len(args.input)} inputs and {len(modes.eigenvalues)} modes")
    except ResourceError as e:
        print(f"femcal frf: {e}", file=sys.stderr)
        return 2
    f = grid.frequencies()
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
