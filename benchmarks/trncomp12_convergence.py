"""How far the NASTRAN modes of refdeck pyn_trncomp12 are from its plate's converged modes.

    python benchmarks/trncomp12_convergence.py [--sizes 16 32 64]

pyn_trncomp12 is a 720 x 360 plate, 0.1 thick ([45/0/45] PCOMP over MAT8, RHO in weight
units), meshed with six elements 180 to 360 long (CQUADR, CQUAD8 and CTRIA6 with omitted
midside nodes, CTRIAR), each with its own material angle THETA; GRID PS fixes R3 everywhere
and the x = 0 edge. Its NX 2019.2 run (EIGR up to 200 Hz) has 9 bending modes (1-9, below
0.01 Hz: the coarse mesh has 9 free T3 with mass) and 20 membrane modes (10-29, 0.77-15 Hz).

This script builds the same plate (the same laminate, each coarse element's region with that
element's material angle from its G1-G2 side, the same PS constraints) on N x N cells of
720/N x 360/N, each split into two CTRIA3 along the diagonal that also bounds the triangular
regions, and solves it twice: as given, whose lowest 9 modes are bending ones, and with T3, R1
and R2 fixed too, whose modes are the membrane ones. It prints NASTRAN's and femcal's modes
of the coarse deck beside the refined ones, with the coarse ones' differences from the finest
mesh.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DECK = ROOT.parent / "shared" / "refdecks" / "pyn_trncomp12"
N_BENDING, N_MEMBRANE = 9, 20

LAMINATE = """PCOMP,100,,,1.E+3,STRN,,,,+P11
+P11,120,0.0333,45.0,YES,120,0.0333,0.0,YES,+P12
+P12,120,0.0333,45.0,YES
MAT8,120,1.0E7,1.0E6,0.3,4.0E6,4.0E6,4.0E6,.283,+M11
+M11,,,2.+4,,2.+3,,1.4+4"""


def material_angle(x: float, y: float) -> float:
    """THETA (degrees, from +x; mod 180 as the laminate is orthotropic) of the coarse element
    whose region holds (x, y): elements 1 and 2 above y = 180, 3/4 and 5/6 below, split by the
    diagonals (360, 0)-(720, 180) and (0, 0)-(360, 180). Elements 4 and 6 have G1-G2 along -x."""
    if y > 180:
        return 60.0 if x > 360 else 90.0
    if x > 360:
        return 30.0 if y < (x - 360) / 2 else 50.0
    return 45.0 if y < x / 2 else 23.0


def refined_deck(n: int, membrane_only: bool) -> str:
    """Bulk data of the plate on n x n cells, two CTRIA3 each (G1-G2 along +x or -x)."""
    dx, dy = 720 / n, 360 / n
    extra = "345" if membrane_only else ""

    def nid(i: int, j: int) -> int:
        return 1 + j * (n + 1) + i

    lines = ["SOL 103", "CEND", "METHOD = 2", "BEGIN BULK", "EIGRL,2,,,30"]
    for j in range(n + 1):
        for i in range(n + 1):
            edge = ("12356" if j in (0, n) else "1356") if i == 0 else "6"
            ps = "".join(sorted(set(edge + extra)))
            lines.append(f"GRID,{nid(i, j)},,{i * dx:.6f},{j * dy:.6f},0.,,{ps}")
    eid = 1
    for j in range(n):
        for i in range(n):
            ll, lr, ur, ul = nid(i, j), nid(i + 1, j), nid(i + 1, j + 1), nid(i, j + 1)
            lower = material_angle((i + 2 / 3) * dx, (j + 1 / 3) * dy)
            upper = material_angle((i + 1 / 3) * dx, (j + 2 / 3) * dy)
            lines.append(f"CTRIA3,{eid},100,{ll},{lr},{ur},{lower}")
            lines.append(f"CTRIA3,{eid + 1},100,{ur},{ul},{ll},{upper}")
            eid += 2
    return "\n".join([*lines, LAMINATE, "ENDDATA", ""])


def modes_hz(path: Path, count: int) -> np.ndarray:
    from femcal.deck import read_deck
    from femcal.model.build import build_model
    from femcal.solve.normal_modes import solve_normal_modes

    deck = read_deck(path)
    modes, _ = solve_normal_modes(build_model(deck))
    return modes.frequencies_hz[:count]


def row(label: str, f: np.ndarray, finest: np.ndarray | None) -> str:
    if finest is None:
        cells = [f"{x:.4g}" for x in f]
    else:
        cells = [f"{x:.4g} ({(x / y - 1) * 100:+.0f} %)" for x, y in zip(f, finest, strict=True)]
    return f"| {label} | " + " | ".join(cells) + " |"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[16, 32, 64])
    args = ap.parse_args()
    ref = json.loads((DECK / "reference.json").read_text())
    nx = np.array([m["cycles_hz"] for m in ref["modes"]])
    coarse = modes_hz(DECK / "trncomp12.bdf", N_BENDING + N_MEMBRANE)
    refined = {}
    with tempfile.TemporaryDirectory() as tmp:
        for n in args.sizes:
            for membrane in (False, True):
                p = Path(tmp) / f"plate_{n}_{int(membrane)}.bdf"
                p.write_text(refined_deck(n, membrane))
                refined[n, membrane] = modes_hz(p, N_MEMBRANE if membrane else N_BENDING)
    finest = max(args.sizes)
    for title, membrane, sl in (("Bending modes (coarse deck modes 1-9), Hz", False,
                                 slice(0, N_BENDING)),
                                ("Membrane modes (coarse deck modes 10-29, first 10 shown), Hz",
                                 True, slice(N_BENDING, N_BENDING + 10))):  # fmt: skip
        k = sl.stop - sl.start
        print(f"\n{title}; in brackets the difference from the {finest}x{finest} mesh\n")
        print("| model | " + " | ".join(str(i + 1) for i in range(k)) + " |")
        print("|---|" + "---|" * k)
        ref_f = refined[finest, membrane][:k]
        print(row("NX 2019.2, 6 elements", nx[sl], ref_f))
        print(row("femcal, 6 elements", coarse[sl], ref_f))
        for n in args.sizes:
            print(row(f"femcal, {n}x{n}x2 CTRIA3", refined[n, membrane][:k],
                      None if n == finest else ref_f))  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
