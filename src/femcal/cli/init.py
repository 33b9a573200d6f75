"""``femcal init DECK --test FILE [--sensors CSV] [--inputs CSV] --out DIR [--force]``: a
start for the calibration of one's own deck: a proposal of its parameters
(``DIR/<stem>.params.toml``) and a commented configuration (``DIR/<stem>_calibration.toml``)
(:mod:`femcal.jobs.init`)."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("init", help="propose the parameters and configuration of a calibration",
                       description="Propose a calibration of a deck against a test: the "
                       "parameters (every PSHELL T and MAT1 E the elements use, PBAR/PROD A "
                       "and PBUSH/PELAS K where the deck has them, bounds relative to the "
                       "deck's values, the most influential first) and a configuration with "
                       "a comment on every key (the band from the first flexible FE mode to "
                       "the test's top, the identification's parts). The sensors, inputs and "
                       "test channels are checked against the deck's grids. Both files are "
                       "checked by femcal calibrate's readers before they are written; "
                       "existing files are left alone without --force.")  # fmt: skip
    p.add_argument("deck", type=Path, help="NASTRAN deck")
    p.add_argument("--test", type=Path, required=True, metavar="FILE",
                   help="test FRFs (.uff/.unv, .mat, .npz, .csv), channels GRID:DIRECTION")
    p.add_argument("--sensors", type=Path, metavar="CSV",
                   help="sensor positions (label, grid, ..., directions)")
    p.add_argument("--inputs", type=Path, metavar="CSV",
                   help="input positions (label, grid, ..., direction)")
    p.add_argument("--out", type=Path, required=True, metavar="DIR",
                   help="folder for <stem>.params.toml and <stem>_calibration.toml")
    p.add_argument("--force", action="store_true", help="replace files of an earlier init")


def run(args: argparse.Namespace) -> int:
    from ..jobs.init import run_init
    from .console import Console
    from .paths import output_folder

    output_folder(args.out, "--out")
    progress = Console()
    try:
        proposal, files = run_init(args.deck, args.test, args.out, sensors=args.sensors,
                                   inputs=args.inputs, force=args.force,
                                   progress=progress)  # fmt: skip
    finally:
        progress.close()
    b = proposal.band
    print(f"{'parameter':<14} {'nominal':>12} {'lower':>12} {'upper':>12} {'% per 1 %':>9}  "
          "what")
    for q in proposal.parameters:
        what = f"{q.card} {q.id} {q.field}{f' ({q.label})' if q.label else ''}"
        print(f"{q.name:<14} {q.nominal:12.6g} {q.lower:12.6g} {q.upper:12.6g} "
              f"{q.sensitivity:9.3g}  {what}")
    for note in proposal.notes:
        print(f"note: {note}")
    kinds: dict[str, int] = {}
    for q in proposal.parameters:
        k = f"{q.card} {q.field if q.card != 'PBUSH' else 'K'}"
        kinds[k] = kinds.get(k, 0) + 1
    print(f"wrote {files.parameters}: {len(proposal.parameters)} parameters "
          f"({', '.join(f'{n} {k}' for k, n in kinds.items())})")
    # the config leaves the parts to the test's CMIF peaks; the FE modes' gaps are offered,
    # commented out
    print(f"wrote {files.config}: band {b.band[0]:g}-{b.band[1]:g} Hz "
          f"({len(b.band_modes_hz)} FE modes), identified over {b.identify_band[0]:g}-"
          f"{b.identify_band[1]:g} Hz in parts chosen from the test's CMIF peaks")  # fmt: skip
    print(f"next: {files.next_command}")
    return 0
