"""``femcal solve DECK [--modes N] [--json FILE] [--out DIR] [--png DIR]``: SOL 103 normal modes."""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

from ..assembly import Options, assemble
from ..assembly.weight import weight_summary, weight_table
from ..atomic import write_lines
from ..io.modes import eigen_table, modes_json, write_json, write_npz, write_vtu
from ..model.build import load_model
from ..solve.normal_modes import solve_normal_modes
from .paths import output_folder


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("solve", help="normal modes (SOL 103) of a NASTRAN deck")
    p.add_argument("deck", type=Path, help="NASTRAN input file")
    p.add_argument("--modes", type=int, metavar="N", help="number of modes (overrides EIGRL ND)")
    p.add_argument("--json", type=Path, metavar="FILE", help="write the eigenvalue table as JSON")
    p.add_argument("--out", type=Path, metavar="DIR",
                   help="write modes.npz, modes.vtu (ParaView) and eigenvalues.txt")  # fmt: skip
    p.add_argument("--png", type=Path, metavar="DIR", help="render each mode to DIR/mode_NNN.png")


def run(args: argparse.Namespace) -> int:
    t0 = time.perf_counter()

    def progress(msg: str) -> None:
        print(f"[{time.perf_counter() - t0:7.1f} s] {msg}", file=sys.stderr, flush=True)

    output_folder(args.out, "--out")
    output_folder(args.png, "--png")
    progress(f"reading {args.deck}")
    model = load_model(args.deck)
    progress(f"{model.n_grids} grids, {sum(len(b) for b in model.elements.values())} elements, "
             f"{model.n_dof} DOF")  # fmt: skip
    request = model.eigen.request()
    if args.modes is not None:
        if args.modes < 1:
            print(f"femcal solve: --modes {args.modes}: expected a number of modes >= 1",
                  file=sys.stderr)  # fmt: skip
            return 2
        request = replace(request, nd=args.modes)
    mats = assemble(model, Options())
    modes, _ = solve_normal_modes(model, matrices=mats, request=request, progress=progress)
    progress(f"{len(modes.eigenvalues)} modes ({modes.backend})")
    table = list(eigen_table(modes))
    print("\n".join(table))
    if len(modes.autospc):
        shown = ", ".join(f"{g}:{c}" for g, c in modes.autospc[:12])
        more = f" and {len(modes.autospc) - 12} more" if len(modes.autospc) > 12 else ""
        print(f"\nAUTOSPC fixed {len(modes.autospc)} DOF (grid:component): {shown}{more}")
    summary = modes_json(modes, model)
    if model.params.grdpnt is not None:
        ws = weight_summary(model, mats.M, model.params.grdpnt)
        print()
        print("\n".join(weight_table(ws)))
        summary["weight"] = {
            "reference": ws.reference.tolist(),
            "mass": ws.mass.tolist(),
            "cg": ws.cg.tolist(),
            "inertia_cg": ws.inertia_cg.tolist(),
        }
    if args.json:
        write_json(args.json, summary)
        progress(f"wrote {args.json}")
    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)
        write_npz(args.out / "modes.npz", modes, model)
        write_vtu(args.out / "modes.vtu", modes, model)
        write_lines(args.out / "eigenvalues.txt", table)
        progress(f"wrote {args.out}/modes.npz, modes.vtu, eigenvalues.txt")
    if args.png:
        from ..viz.render import render_modes

        paths = render_modes(modes, model, args.png, title=args.deck.name)
        progress(f"wrote {len(paths)} pictures to {args.png}")
    return 0
