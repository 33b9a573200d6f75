"""``femcal model truck-frame --variant hammer --out DIR``: write a bundled model's files."""

from __future__ import annotations

import argparse
from pathlib import Path

VARIANTS = ("hammer", "rig", "rig-battery")


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("model", help="write a bundled model (NASTRAN deck and data files)")
    p.add_argument("name", choices=["truck-frame"], help="which model")
    p.add_argument(
        "--variant",
        choices=VARIANTS,
        default="hammer",
        help="hammer: on air bellows (default); rig, rig-battery: on the 7-post rig",
    )
    p.add_argument("--out", required=True, metavar="DIR", help="folder to write into")
    p.add_argument(
        "--pictures",
        action="store_true",
        help="also solve the model and render the mesh and its first four flexible modes "
        "into DIR/pictures",
    )


def run(args: argparse.Namespace) -> int:
    from ..examples.truck_frame import write_frame
    from .paths import output_folder

    output_folder(Path(args.out), "--out")
    paths = write_frame(args.variant, args.out)
    for path in paths:
        print(f"wrote {path}")
    if args.pictures:
        for path in _pictures(paths[0], Path(args.out) / "pictures"):
            print(f"wrote {path}")
    return 0


def _pictures(deck_path: Path, out: Path) -> list[Path]:
    from ..model.build import load_model
    from ..solve.normal_modes import solve_normal_modes
    from ..viz.render import render_mesh, render_modes

    model = load_model(deck_path)
    modes, _ = solve_normal_modes(model)
    flexible = [i for i, f in enumerate(modes.frequencies_hz) if f > 5.0][:4]
    title = deck_path.stem.replace("_", " ")
    paths = [render_mesh(model, out / "mesh.png", title=f"{title}: {model.n_dof} DOF")]
    return paths + render_modes(modes, model, out, title=title, which=flexible, scale=0.06)
