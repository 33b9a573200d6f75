"""``femcal synth-rig-test DECK --params TOML --actuators CSV --sensors CSV --out DIR
[--truth TOML] [--period S] [--cycles N] [--rate HZ] ...``: lab-like rig-test time histories
(MTS RPC III) of a frame on its displacement-driven actuators (see
femcal.jobs.synthetic_rig_test)."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from ..atomic import write_lines
from ..jobs.synthetic_rig_test import RigTestSettings, make_rig_test, rig_truth_toml
from ..testdata.formats.rpc3 import write_rpc3
from ..testdata.timedata import TimeData
from .paths import output_folder
from .synth import hidden_differences

_D = RigTestSettings()


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "synth-rig-test", help="synthetic rig-test time histories (RPC III) from a deck",
        description="Simulate a rig test of the frame on its actuators: hidden parameter "
        "values, a cross support the model lacks, periodic random displacement drives, "
        "noise; writes NAME.rsp (every channel), NAME.drv (one period of the drives) and "
        "NAME.truth.toml.")  # fmt: skip
    p.add_argument("deck", type=Path, help="NASTRAN deck of the frame on its oil columns")
    p.add_argument("--params", type=Path, required=True, help="parameters TOML")
    p.add_argument("--actuators", type=Path, required=True,
                   help="actuators CSV (label, grid of the oil column's frame end, direction)")
    p.add_argument("--sensors", type=Path, required=True, help="accelerometers CSV")
    p.add_argument("--truth", type=Path, metavar="TOML",
                   help="take the hidden values and cross support from this truth file (a "
                   "synthetic hammer test's), instead of drawing them")  # fmt: skip
    p.add_argument("--out", type=Path, required=True, metavar="DIR", help="folder to write")
    p.add_argument("--name", default="rig_test", help="file stem (default rig_test)")
    p.add_argument("--seed", type=int, default=_D.seed, help=f"random seed (default {_D.seed})")
    p.add_argument("--rate", type=float, default=_D.rate_hz, metavar="HZ",
                   help=f"sampling rate (default {_D.rate_hz:g} Hz)")
    p.add_argument("--period", type=float, default=_D.period_s, metavar="S",
                   help=f"drive period (default {_D.period_s:g} s)")
    p.add_argument("--cycles", type=int, default=_D.cycles, metavar="N",
                   help=f"periods recorded (default {_D.cycles})")
    p.add_argument("--band", type=float, nargs=2, default=_D.drive_band, metavar=("F1", "F2"),
                   help=f"drive band (default {_D.drive_band[0]:g} {_D.drive_band[1]:g} Hz)")
    p.add_argument("--rms", type=float, default=_D.drive_rms, metavar="MM",
                   help=f"RMS of each drive (default {_D.drive_rms:g}, the model's length)")
    p.add_argument("--noise", type=float, default=_D.noise,
                   help=f"noise as a fraction of each channel's RMS (default {_D.noise:g})")
    p.add_argument("--modes-to", type=float, default=_D.modes_to, metavar="HZ",
                   help=f"modes simulated (default up to {_D.modes_to:g} Hz; the rest static)")
    p.add_argument("--floats", action="store_true",
                   help="store 32-bit floats (default: 16-bit integers with a scale per "
                   "channel, as rig controllers write)")  # fmt: skip


def _command(args: argparse.Namespace) -> str:
    """The command line that makes the same test (paths as given)."""
    parts = ["femcal synth-rig-test", str(args.deck), "--params", str(args.params),
             "--actuators", str(args.actuators), "--sensors", str(args.sensors)]
    if args.truth is not None:
        parts += ["--truth", str(args.truth)]
    parts += ["--seed", str(args.seed), "--rate", f"{args.rate:g}", "--period", f"{args.period:g}",
              "--cycles", str(args.cycles), "--band", f"{args.band[0]:g}", f"{args.band[1]:g}",
              "--rms", f"{args.rms:g}", "--noise", f"{args.noise:g}", "--modes-to",
              f"{args.modes_to:g}"] + (["--floats"] if args.floats else [])
    return " ".join([*parts, "--out", str(args.out), "--name", args.name])


def run(args: argparse.Namespace) -> int:
    t0 = time.perf_counter()

    def progress(msg: str) -> None:
        print(f"[{time.perf_counter() - t0:7.1f} s] {msg}", file=sys.stderr, flush=True)

    try:
        settings = RigTestSettings(seed=args.seed, rate_hz=args.rate, period_s=args.period,
                                   cycles=args.cycles, drive_band=tuple(args.band),
                                   drive_rms=args.rms, noise=args.noise,
                                   modes_to=args.modes_to)  # fmt: skip
    except ValueError as e:
        print(f"femcal synth-rig-test: {e}", file=sys.stderr)
        return 2
    output_folder(args.out, "--out")
    progress(f"making the synthetic rig test of {args.deck}")
    test = make_rig_test(args.deck, args.params, args.actuators, args.sensors, settings,
                         truth_path=args.truth, progress=progress)  # fmt: skip
    args.out.mkdir(parents=True, exist_ok=True)
    stem = args.out / args.name
    kind = "FLOATING_POINT" if args.floats else "SHORT_INTEGER"
    d = test.data
    units = (test.plant.input_units,) * len(test.plant.inputs)
    drive = TimeData(d.dt, test.drive, test.plant.inputs, units)
    truth = rig_truth_toml(test, _command(args))
    paths = [write_rpc3(stem.with_suffix(".rsp"), d, data_type=kind),
             write_rpc3(stem.with_suffix(".drv"), drive, data_type=kind, time_type="DRIVE"),
             write_lines(stem.with_suffix(".truth.toml"), truth)]  # fmt: skip
    for p in paths:
        progress(f"wrote {p}")
    print(f"{d.n_channels} channels x {d.n_samples} samples at {1 / d.dt:g} Hz "
          f"({settings.cycles} periods of {settings.period_s:g} s); {test.plant.n_modes} modes "
          f"up to {settings.modes_to:g} Hz")  # fmt: skip
    print(hidden_differences(len(test.parameters), settings.spread, settings.seed,
                             test.support_x, test.support_stiffness, truth=args.truth)
          + f"; the truth in {stem.with_suffix('.truth.toml').name}")  # fmt: skip
    return 0
