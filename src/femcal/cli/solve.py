"""``femcal solve DECK [--modes N] [--backend lanczos|slepc] [--json FILE] [--out DIR]
[--png DIR] [--gif DIR [--gif-modes N]] [--html FILE] [--pch FILE] [--uff FILE [--at
SENSORS_CSV]]``: SOL 103 normal modes.

With ``--backend slepc`` the command may run under ``mpirun -n N``: every rank reads the deck
and takes part in the solution (:mod:`femcal.solve.slepc`); rank 0 alone prints, writes the
files and reports an error the ranks share (the others end with the same status, silently).
"""

from __future__ import annotations

import argparse
import warnings
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

from ..assembly import Options, assemble
from ..assembly.weight import weight_summary, weight_table
from ..atomic import write_lines
from ..deck import read_deck
from ..errors import FemcalError
from ..io.modes import eigen_table, modes_json, write_json, write_npz, write_vtu
from ..model.build import build_model
from ..solve.normal_modes import Modes, solve_normal_modes
from .console import Console
from .paths import UsageError, output_folder, output_path

#: Suffixes of the files --pch and --uff write.
PUNCH_SUFFIXES = (".pch", ".punch")
UFF_SUFFIXES = (".unv", ".uff")
#: Suffixes of the page --html writes.
HTML_SUFFIXES = (".html", ".htm")
#: --backend choices: femcal's own eigensolver (block shift-invert Lanczos on CHOLMOD, dense
#: below 600 DOF), or SLEPc under MPI (optional: make setup-slepc).
BACKENDS = ("lanczos", "slepc")


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("solve", help="normal modes (SOL 103) of a NASTRAN deck")
    p.add_argument("deck", type=Path, help="NASTRAN input file")
    p.add_argument("--modes", type=int, metavar="N", help="number of modes (overrides EIGRL ND)")
    p.add_argument("--backend", choices=BACKENDS, default="lanczos",
                   help="eigensolver: lanczos (default; femcal's shift-invert block Lanczos on "
                   "CHOLMOD, dense for small models) or slepc (SLEPc Krylov-Schur on MUMPS, "
                   "run it as `mpirun -n N .venv-slepc/bin/femcal solve --backend slepc ...`; "
                   "installed by `make setup-slepc`)")  # fmt: skip
    p.add_argument("--json", type=Path, metavar="FILE", help="write the eigenvalue table as JSON")
    p.add_argument("--out", type=Path, metavar="DIR",
                   help="write modes.npz, modes.vtu (ParaView) and eigenvalues.txt")  # fmt: skip
    p.add_argument("--png", type=Path, metavar="DIR", help="render each mode to DIR/mode_NNN.png")
    p.add_argument("--gif", type=Path, metavar="DIR",
                   help="animate each mode over one period to DIR/mode_NNN.gif")  # fmt: skip
    p.add_argument("--gif-modes", type=int, metavar="N",
                   help="with --gif: only the first N modes (default every mode)")  # fmt: skip
    p.add_argument("--html", type=Path, metavar="FILE",
                   help="write an interactive 3-D page of the modes (.html, self-contained: "
                   "opens in a browser without a server; the first 20 modes)")  # fmt: skip
    p.add_argument("--pch", type=Path, metavar="FILE",
                   help="write the eigenvalues and eigenvectors as a NASTRAN punch file "
                   "(.pch, as DISPLACEMENT(PUNCH); CD frames)")  # fmt: skip
    p.add_argument("--uff", type=Path, metavar="FILE",
                   help="write grids, trace lines and mode shapes as a universal file "
                   "(.unv/.uff: datasets 15, 82, 55; basic frame) for Test.Lab, ME'scope, "
                   "pyuff")  # fmt: skip
    p.add_argument("--at", type=Path, metavar="SENSORS_CSV",
                   help="with --uff: only the grids of this sensors CSV (label,grid,...,"
                   "directions), joined by a wireframe along the mesh; default every grid "
                   "and the element edges")  # fmt: skip


def _sensor_grids(path: Path) -> list[int]:
    """The grids of a sensors CSV, in the file's order, each once."""
    from ..testdata.points import read_points

    return list(dict.fromkeys(g for _, g, _ in read_points(path)))


def run(args: argparse.Namespace) -> int:
    if args.backend != "slepc":
        return _run(args, root=True)
    from ..solve.slepc import mpi_rank_and_size

    rank, _ = mpi_rank_and_size()
    if rank == 0:
        return _run(args, root=True)
    # the other ranks: the same work, silently (rank 0 says what they all would)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            return _run(args, root=False)
        except FemcalError:
            return 2


def _silent(msg: str) -> None:
    """The progress callback of the ranks other than 0."""


def _run(args: argparse.Namespace, *, root: bool) -> int:
    """The command; ``root``: this process prints and writes (False on MPI ranks other than
    0, which only take part in the SLEPc solution)."""
    # Lanczos as a bar on a terminal; its last step closes it
    progress: Callable[[str], None] = Console() if root else _silent
    output_folder(args.out, "--out")
    output_folder(args.png, "--png")
    output_folder(args.gif, "--gif")
    if args.gif_modes is not None:
        if args.gif is None:
            raise UsageError(f"--gif-modes {args.gif_modes}: chooses the modes of --gif; "
                             "expected --gif DIR too")  # fmt: skip
        if args.gif_modes < 1:
            raise UsageError(f"--gif-modes {args.gif_modes}: expected a number of modes >= 1")
    output_path(args.html, "--html", HTML_SUFFIXES)
    output_path(args.pch, "--pch", PUNCH_SUFFIXES)
    output_path(args.uff, "--uff", UFF_SUFFIXES)
    if args.at is not None and args.uff is None:
        raise UsageError(f"--at {args.at}: chooses the grids of --uff; expected --uff FILE too")
    sensors = _sensor_grids(args.at) if args.at is not None else None
    progress(f"reading {args.deck}")
    deck = read_deck(args.deck)
    model = build_model(deck)
    if sensors is not None:
        rows = model.node_index(sensors)
        bad = [g for g, r in zip(sensors, rows, strict=True) if r < 0 or not model.is_grid[r]]
        if bad:
            raise UsageError(f"--at {args.at}: grid {bad[0]} is not a GRID of {args.deck}"
                             + (f" ({len(bad) - 1} more)" if len(bad) > 1 else ""))
    progress(f"{model.n_grids} grids, {sum(len(b) for b in model.elements.values())} elements, "
             f"{model.n_dof} DOF")  # fmt: skip
    request = model.eigen.request()
    if args.modes is not None:
        if args.modes < 1:
            raise UsageError(f"--modes {args.modes}: expected a number of modes >= 1")
        request = replace(request, nd=args.modes)
    mats = None
    if args.backend != "slepc" or model.params.grdpnt is not None:
        mats = assemble(model, Options())
    if args.backend == "slepc":
        # without GRDPNT the backend assembles itself (each rank with its share of the
        # cores) and frees the g-set matrices before the factorisation
        from ..solve.slepc import solve_normal_modes_slepc

        solved = solve_normal_modes_slepc(model, matrices=mats, request=request,
                                          progress=progress)  # fmt: skip
        if solved is None:  # not rank 0: nothing to print or write
            return 0
        modes: Modes = solved[0]
    else:
        modes, _ = solve_normal_modes(model, matrices=mats, request=request, progress=progress)
    progress(f"{len(modes.eigenvalues)} modes ({modes.backend})")
    table = list(eigen_table(modes))
    print("\n".join(table))
    if len(modes.autospc):
        shown = ", ".join(f"{g}:{c}" for g, c in modes.autospc[:12])
        more = f" and {len(modes.autospc) - 12} more" if len(modes.autospc) > 12 else ""
        print(f"\nAUTOSPC fixed {len(modes.autospc)} DOF (grid:component): {shown}{more}")
    summary = modes_json(modes, model)
    if model.params.grdpnt is not None and mats is not None:
        # NASTRAN's generator reports in the input's mass units, before PARAM WTMASS
        wtmass = model.params.wtmass if model.params.wtmass else 1.0
        ws = weight_summary(model, mats.M / wtmass, model.params.grdpnt)
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
    if args.gif:
        from ..viz.animate import animate_modes

        paths = animate_modes(modes, model, args.gif, title=args.deck.name,
                              max_modes=args.gif_modes)  # fmt: skip
        progress(f"wrote {len(paths)} animations to {args.gif}")
    if args.html:
        from ..viz.webview import write_webview

        write_webview(args.html, modes, model, title=args.deck.name)
        size = args.html.stat().st_size / 1e6
        progress(f"wrote {args.html} ({size:.1f} MB)")
    if args.pch:
        from ..io.punch import write_punch

        case = deck.case
        write_punch(args.pch, modes, title=case.value("TITLE") or "",
                    subtitle=case.value("SUBTITLE") or "", label=case.value("LABEL") or "",
                    subcase=case.effective()[0][0] or 1)  # fmt: skip
        progress(f"wrote {args.pch} ({len(modes.eigenvalues)} eigenvectors, CD frames)")
    if args.uff:
        _write_uff(args.uff, modes, model, sensors, args.deck.name)
        progress(f"wrote {args.uff} ({len(modes.eigenvalues)} shapes at "
                 f"{model.n_grids if sensors is None else len(sensors)} grids)")
    return 0


def _write_uff(path: Path, modes, model, sensors: list[int] | None, name: str) -> None:
    from ..io.uff_shapes import (
        TraceLines,
        fe_shapes,
        mesh_edges,
        model_grids,
        sensor_wireframe,
        write_uff_shapes,
    )

    grids = model_grids(model, sensors)
    if sensors is None:
        lines = TraceLines(mesh_edges(model), "femcal element edges")
    else:
        lines = TraceLines(sensor_wireframe(model, sensors), "femcal sensor wireframe")
    shapes = fe_shapes(modes, model, sensors, title=f"femcal normal modes of {name}",
                       units="as solved (EIGRL normalisation), model units")  # fmt: skip
    write_uff_shapes(path, grids, [shapes], lines)
