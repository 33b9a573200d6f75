"""``femcal synth-test DECK --params TOML --sensors CSV --inputs CSV --out DIR [--seed N]
[--support-x MM --support-stiffness K] [--added-mass M --added-mass-at X Y Z]``: lab-like
hammer-test FRFs from a deck with hidden parameters and model-form differences (see
femcal.jobs.synthetic_test)."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from ..atomic import write_lines
from ..errors import message
from ..jobs.synthetic_test import SynthSettings, make_hammer_test, truth_toml
from ..testdata.formats.matlab import write_mat
from ..testdata.formats.uff import write_uff
from .paths import output_folder


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("synth-test", help="synthetic hammer-test FRFs from a deck")
    p.add_argument("deck", type=Path, help="NASTRAN input file of the nominal model")
    p.add_argument("--params", type=Path, required=True, help="parameters TOML (hidden values)")
    p.add_argument("--sensors", type=Path, required=True, help="sensor positions CSV")
    p.add_argument("--inputs", type=Path, required=True, help="hammer inputs CSV")
    p.add_argument("--out", type=Path, required=True, metavar="DIR", help="folder to write")
    p.add_argument("--name", default="hammer_test", help="file stem (default hammer_test)")
    p.add_argument("--seed", type=int, default=SynthSettings.seed, help="random seed")
    p.add_argument("--support-x", type=float, default=SynthSettings.support_x, metavar="MM",
                   help="where along the frame the cross support the model lacks acts "
                        f"(default {SynthSettings.support_x:g} mm)")  # fmt: skip
    p.add_argument("--support-stiffness", type=float, default=SynthSettings.support_stiffness,
                   metavar="K", help="its rotational stiffness about X and Z at each rail, "
                   f"N mm/rad (default {SynthSettings.support_stiffness:g}; 0: none)")
    p.add_argument("--added-mass", type=float, default=SynthSettings.added_mass, metavar="M",
                   help="a point mass the model lacks, in the deck's mass unit (default 0: "
                        "none)")  # fmt: skip
    p.add_argument("--added-mass-at", type=float, nargs=3, metavar=("X", "Y", "Z"),
                   default=SynthSettings.added_mass_at,
                   help="where: the grid nearest this point, basic coordinates (default "
                        f"{' '.join(f'{x:g}' for x in SynthSettings.added_mass_at)})")


def run(args: argparse.Namespace) -> int:
    t0 = time.perf_counter()
    output_folder(args.out, "--out")
    print(f"[{0.0:7.1f} s] making the synthetic test of {args.deck}", file=sys.stderr)
    try:
        settings = SynthSettings(seed=args.seed, support_x=args.support_x,
                                 support_stiffness=args.support_stiffness,
                                 added_mass=args.added_mass,
                                 added_mass_at=tuple(args.added_mass_at))  # fmt: skip
        test = make_hammer_test(args.deck, args.params, args.sensors, args.inputs, settings)
    except (KeyError, ValueError) as e:  # bad parameter, sensor or input files (TOML too)
        print(f"femcal synth-test: {message(e)}", file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    d = test.data
    stem = args.out / args.name
    paths = [
        write_uff(stem.with_suffix(".uff"), d, binary=True),
        write_mat(stem.with_suffix(".mat"), d),
        write_lines(stem.with_suffix(".truth.toml"), truth_toml(test)),
    ]
    for p in paths:
        print(f"[{time.perf_counter() - t0:7.1f} s] wrote {p}", file=sys.stderr)
    n_o, n_i, n_f = d.H.shape
    f0, f1 = d.frequency_hz[0], d.frequency_hz[-1]
    print(f"{n_o} outputs x {n_i} inputs x {n_f} frequencies ({f0:g}-{f1:g} Hz), "
          f"{d.quantity} in {d.units}")  # fmt: skip
    s = test.settings
    print(hidden_differences(len(test.parameters), s.spread, s.seed, s.support_x,
                             s.support_stiffness, s.added_mass, s.added_mass_at)
          + f"; noise {100 * s.noise:g} % of each FRF; the truth in "
          f"{stem.with_suffix('.truth.toml').name}")  # fmt: skip
    return 0


def hidden_differences(n_parameters: int, spread: float, seed: int, support_x: float,
                       support_stiffness: float, added_mass: float = 0.0,
                       added_mass_at: tuple[float, float, float] | None = None, *,
                       truth: Path | None = None) -> str:
    """What the hidden frame has that the deck has not, in one line, with the option that
    changes each (a calibration is judged against what it could know); ``truth``: the
    values came from that file."""
    parts = [f"the hidden frame: {n_parameters} parameters from {truth}" if truth else
             f"the hidden frame: {n_parameters} parameters drawn within {100 * spread:g} % of "
             f"their bounds (--seed {seed})"]  # fmt: skip
    option = "" if truth else " (--support-stiffness 0: none)"
    parts.append(f"a cross support the deck lacks, {support_stiffness:g} N mm/rad about X and Z "
                 f"at each rail at x = {support_x:g} mm{option}" if support_stiffness
                 else "no cross support")  # fmt: skip
    if added_mass and added_mass_at is not None:
        parts.append(f"a mass the deck lacks, {added_mass:g} (the deck's mass unit) at the grid "
                     "nearest "
                     f"({', '.join(f'{x:g}' for x in added_mass_at)})")
    return "; ".join(parts)
