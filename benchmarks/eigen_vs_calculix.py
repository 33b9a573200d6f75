"""Normal modes of the same plate in femcal (CQUAD4) and CalculiX (S4), measured in one run.

A square steel plate 1 m x 1 m x 5 mm, clamped along one edge, 20 modes, meshes n x n.
Wall time and peak memory of each solver's whole run (reading the input, assembly, eigen
solution, results) are measured with GNU time; the first five frequencies of each are shown.

    python benchmarks/eigen_vs_calculix.py [--sizes 50 100 150 200 300] [--femcal-only 410]
                                           [--repeat N]

With ``--repeat N`` each solver runs N times per mesh, alternating, and the table gives the
median wall time (the largest peak memory): on a shared machine single runs of the same job
vary by 10-20 %.

Needs CalculiX (Debian: ``apt-get install calculix-ccx``). Units mm, t, s, N, MPa.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
WORK = HERE / "_work" / "eigen"
FEMCAL = ROOT / ".venv" / "bin" / "femcal"
E, NU, RHO, T, SIZE = 210000.0, 0.3, 7.85e-9, 5.0, 1000.0


def grid(n: int):
    h = SIZE / n
    m = n + 1
    nodes = [(j * m + i + 1, i * h, j * h) for j in range(m) for i in range(m)]
    quads = []
    for j in range(n):
        for i in range(n):
            g = j * m + i + 1
            quads.append((j * n + i + 1, g, g + 1, g + m + 1, g + m))
    clamped = [j * m + 1 for j in range(m)]  # the edge x = 0
    return nodes, quads, clamped


def nastran_deck(n: int) -> Path:
    path = WORK / f"plate_{n}.bdf"
    if path.exists():
        return path
    nodes, quads, clamped = grid(n)
    lines = ["SOL 103", "CEND", "METHOD = 1", "SPC = 1", "BEGIN BULK",
             "EIGRL,1,,,20", f"PSHELL,1,1,{T},1,,1", f"MAT1,1,{E},,{NU},{RHO}"]  # fmt: skip
    lines += [f"GRID,{g},,{x!r},{y!r},0." for g, x, y in nodes]
    lines += [f"CQUAD4,{e},1,{a},{b},{c},{d}" for e, a, b, c, d in quads]
    lines += [f"SPC1,1,123456,{g}" for g in clamped]
    lines.append("ENDDATA")
    _write(path, lines)
    return path


def calculix_input(n: int) -> Path:
    path = WORK / f"ccx_{n}" / "plate.inp"
    if path.exists():
        return path
    nodes, quads, clamped = grid(n)
    lines = ["*NODE, NSET=NALL"] + [f"{g}, {x!r}, {y!r}, 0." for g, x, y in nodes]
    lines += ["*ELEMENT, TYPE=S4, ELSET=EALL"]
    lines += [f"{e}, {a}, {b}, {c}, {d}" for e, a, b, c, d in quads]
    lines += ["*NSET, NSET=FIX"] + [f"{g}," for g in clamped]
    lines += ["*MATERIAL, NAME=STEEL", "*ELASTIC", f"{E}, {NU}", "*DENSITY", f"{RHO}",
              "*SHELL SECTION, ELSET=EALL, MATERIAL=STEEL", f"{T}",
              "*BOUNDARY", "FIX, 1, 6",
              "*STEP", "*FREQUENCY", "20", "*END STEP"]  # fmt: skip
    _write(path, lines)
    return path


def _write(path: Path, lines: list[str]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text("\n".join(lines) + "\n")
    os.replace(tmp, path)


def timed(cmd: list[str], cwd: Path) -> tuple[float, float, str]:
    """(wall seconds, peak resident MB, stdout) of a command, by GNU time."""
    out = subprocess.run(["/usr/bin/time", "-f", "__TIME__ %e %M", *cmd], cwd=cwd,
                         capture_output=True, text=True, check=True)  # fmt: skip
    m = re.search(r"__TIME__ ([\d.]+) (\d+)", out.stderr)
    return float(m.group(1)), int(m.group(2)) / 1024.0, out.stdout


def run_femcal(n: int) -> tuple[float, float, list[float]]:
    deck = nastran_deck(n)
    js = deck.with_suffix(".json")
    wall, mb, _ = timed([str(FEMCAL), "solve", str(deck), "--json", str(js)], WORK)
    freqs = [m["frequency_hz"] for m in json.loads(js.read_text())["modes"]]
    return wall, mb, freqs


def run_calculix(n: int) -> tuple[float, float, list[float]]:
    inp = calculix_input(n)
    wall, mb, _ = timed(["ccx", "-i", "plate"], inp.parent)
    text = (inp.parent / "plate.dat").read_text()
    block = text.split("E I G E N V A L U E   O U T P U T")[1]
    freqs = []
    for line in block.splitlines():
        parts = line.split()
        if len(parts) == 5 and parts[0].isdigit():
            freqs.append(float(parts[3]))  # MODE, EIGENVALUE, OMEGA rad, cycles/time, imag
    return wall, mb, freqs


def _median_run(runs: list[tuple[float, float, list[float]]]) -> tuple[float, float, list[float]]:
    """(median wall s, largest peak MB, frequencies of the first run) of repeated runs."""
    walls = sorted(r[0] for r in runs)
    mid = len(walls) // 2
    wall = walls[mid] if len(walls) % 2 else 0.5 * (walls[mid - 1] + walls[mid])
    return wall, max(r[1] for r in runs), runs[0][2]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[50, 100, 150, 200, 300])
    ap.add_argument("--femcal-only", type=int, nargs="*", default=[410],
                    help="meshes run with femcal alone (410 x 410: about 1 M DOF)")
    ap.add_argument("--repeat", type=int, default=1,
                    help="runs of each solver per mesh; the median time is shown")  # fmt: skip
    args = ap.parse_args(argv)
    WORK.mkdir(parents=True, exist_ok=True)
    have_ccx = shutil.which("ccx") is not None
    if not have_ccx:
        print("CalculiX (ccx) not found: install calculix-ccx; femcal runs alone", file=sys.stderr)
    print("| mesh | DOF | femcal s | femcal MB | CalculiX s | CalculiX MB | speed-up | "
          "memory ratio | femcal f1-f5 (Hz) | CalculiX f1-f5 (Hz) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for n in [*args.sizes, *args.femcal_only]:
        dof = 6 * (n + 1) ** 2
        both = have_ccx and n in args.sizes
        fruns, cruns = [], []
        for _ in range(max(1, args.repeat)):
            fruns.append(run_femcal(n))
            if both:
                cruns.append(run_calculix(n))
        if args.repeat > 1:
            times = lambda runs: ", ".join(f"{r[0]:.1f}" for r in runs)  # noqa: E731
            print(f"{n}x{n}: femcal runs {times(fruns)} s"
                  + (f"; CalculiX runs {times(cruns)} s" if both else ""), file=sys.stderr)
        fw, fm, ff = _median_run(fruns)
        if both:
            cw, cm, cf = _median_run(cruns)
            ratio = f"{cw / fw:.1f}x | {cm / fm:.1f}x"
            cfs = ", ".join(f"{x:.3f}" for x in cf[:5])
            ccx_cols = f"{cw:.1f} | {cm:.0f}"
        else:
            ratio, cfs, ccx_cols = "- | -", "-", "- | -"
        ffs = ", ".join(f"{x:.3f}" for x in ff[:5])
        print(f"| {n}x{n} | {dof:,} | {fw:.1f} | {fm:.0f} | {ccx_cols} | {ratio} | {ffs} | {cfs} |",
              flush=True)  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
