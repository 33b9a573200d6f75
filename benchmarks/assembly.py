"""Time and peak memory to form K and M: a 500 x 500 CQUAD4 plate (about 1.5 M DOF) and a
block of about 100 000 CHEXA.

    python benchmarks/assembly.py [--plate 500] [--hexa 47]

Each case runs in a fresh process: the deck is written once (benchmarks/_work), read and
turned into a model (not timed), then ``femcal.assembly.assemble`` is timed. Peak
memory is the process's peak resident set after assembly, and its growth over the peak before
it.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
WORK = HERE / "_work"


def plate_deck(n: int) -> Path:
    """n x n CQUAD4 steel plate, 1 m x 1 m x 5 mm (mm, t, s)."""
    path = WORK / f"asm_plate_{n}.bdf"
    if path.exists():
        return path
    WORK.mkdir(parents=True, exist_ok=True)
    h = 1000.0 / n
    m = n + 1
    lines = ["BEGIN BULK", "PSHELL  1       1       5.      1               1",
             "MAT1    1       210000.         .3      7.85-9"]  # fmt: skip
    for j in range(m):
        for i in range(m):
            lines.append(f"GRID,{j * m + i + 1},,{i * h!r},{j * h!r},0.")
    for j in range(n):
        for i in range(n):
            g = j * m + i + 1
            lines.append(f"CQUAD4,{j * n + i + 1},1,{g},{g + 1},{g + m + 1},{g + m}")
    lines.append("ENDDATA")
    tmp = path.with_suffix(".tmp")
    tmp.write_text("\n".join(lines) + "\n")
    os.replace(tmp, path)
    return path


def hexa_deck(n: int) -> Path:
    """n x n x n CHEXA steel block of 10 mm elements (n = 47: 103 823 elements)."""
    path = WORK / f"asm_hexa_{n}.bdf"
    if path.exists():
        return path
    WORK.mkdir(parents=True, exist_ok=True)
    m = n + 1
    lines = ["BEGIN BULK", "PSOLID  1       1", "MAT1    1       210000.         .3      7.85-9"]

    def gid(i: int, j: int, k: int) -> int:
        return (k * m + j) * m + i + 1

    for k in range(m):
        for j in range(m):
            for i in range(m):
                lines.append(f"GRID,{gid(i, j, k)},,{10.0 * i},{10.0 * j},{10.0 * k}")
    e = 0
    for k in range(n):
        for j in range(n):
            for i in range(n):
                e += 1
                g = [gid(i, j, k), gid(i + 1, j, k), gid(i + 1, j + 1, k), gid(i, j + 1, k)]
                g += [x + m * m for x in g]
                lines.append(f"CHEXA,{e},1,{','.join(map(str, g[:6]))}")
                lines.append(f",{g[6]},{g[7]}")
    lines.append("ENDDATA")
    tmp = path.with_suffix(".tmp")
    tmp.write_text("\n".join(lines) + "\n")
    os.replace(tmp, path)
    return path


def child(deck: str) -> None:
    from femcal.assembly import assemble
    from femcal.deck import read_deck
    from femcal.model.build import build_model

    model = build_model(read_deck(deck))
    before = _rss_mb()
    t = time.perf_counter()
    mats = assemble(model)
    dt = time.perf_counter() - t
    print(json.dumps({
        "seconds": dt, "peak_mb": _rss_mb(), "before_mb": before, "n_dof": model.n_dof,
        "nnz_K": int(mats.K.nnz), "nnz_M": int(mats.M.nnz),
        "elements": {k: len(b) for k, b in model.elements.items()},
    }))  # fmt: skip


def _rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--child", metavar="DECK", help=argparse.SUPPRESS)
    ap.add_argument("--plate", type=int, default=500, help="plate elements per side")
    ap.add_argument("--hexa", type=int, default=47, help="block elements per side")
    args = ap.parse_args(argv)
    if args.child:
        child(args.child)
        return 0
    print("| model | DOF | elements | nnz(K) | assemble K+M s | peak MB | growth MB |")
    print("|---|---|---|---|---|---|---|")
    for label, deck in ((f"plate {args.plate}x{args.plate} CQUAD4", plate_deck(args.plate)),
                        (f"block {args.hexa}^3 CHEXA", hexa_deck(args.hexa))):  # fmt: skip
        out = subprocess.run([sys.executable, __file__, "--child", str(deck)], check=True,
                             capture_output=True, text=True).stdout  # fmt: skip
        r = json.loads(out.strip().splitlines()[-1])
        n_el = sum(r["elements"].values())
        growth = r["peak_mb"] - r["before_mb"]
        print(f"| {label} | {r['n_dof']:,} | {n_el:,} | {r['nnz_K']:,} | {r['seconds']:.2f} | "
              f"{r['peak_mb']:.0f} | {growth:.0f} |", flush=True)  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
