"""Deck reading speed and peak memory: femcal against pyNastran 1.4.1, measured in one run.

Each measurement runs in a fresh Python process (so peak RSS is that reader's own); the
table shows wall time of the read, the process's peak resident memory, and the ratios.

    python benchmarks/parse.py [--sizes 1000] [--repeat 3]

pyNastran is used only here, from its own virtual environment (``.venv-bench``; pyNastran
1.4.1 pins NumPy < 2, which femcal's environment does not). ``make bench-parse`` makes it.

Decks: refdecks/pyn_bwb (10 135 grids, 60 810 DOF, 1.1 MB of small-field bulk data) and a
generated flat plate of n x n CQUAD4 (n = 1000: 1 M elements, 1 M grids, small field).
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
ROOT = HERE.parent
WORK = HERE / "_work"
REFDECKS = ROOT.parent / "shared" / "refdecks"


def write_plate(n: int, path: Path) -> Path:
    """A flat n x n CQUAD4 plate (1 mm elements) in small field, written once and reused."""
    if path.exists():
        return path
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    with tmp.open("w") as f:
        f.write("SOL 103\nCEND\nMETHOD = 1\nBEGIN BULK\nEIGRL   1                       10\n")
        f.write("PSHELL  1       1       5.      1               1\n")
        f.write("MAT1    1       210000.         .3      7.85-9\n")
        m = n + 1
        buf = []
        for j in range(m):
            for i in range(m):
                buf.append(
                    f"GRID    {j * m + i + 1:<8}        {float(i):<8.1f}{float(j):<8.1f}0.\n"
                )
            if len(buf) > 100_000:
                f.writelines(buf)
                buf = []
        for j in range(n):
            for i in range(n):
                g1 = j * m + i + 1
                nodes = f"{g1:<8}{g1 + 1:<8}{g1 + m + 1:<8}{g1 + m:<8}"
                buf.append(f"CQUAD4  {j * n + i + 1:<8}1       {nodes}\n")
            if len(buf) > 100_000:
                f.writelines(buf)
                buf = []
        f.writelines(buf)
        f.write("ENDDATA\n")
    os.replace(tmp, path)
    return path


def child(reader: str, deck: str) -> None:
    """Run one read in this process and print {seconds, peak_mb, base_mb} as JSON."""
    if reader.startswith("femcal"):
        from femcal.deck import read_deck
        from femcal.model.build import build_model

        base = _rss_mb()
        t = time.perf_counter()
        d = read_deck(deck)
        if reader == "femcal+model":
            build_model(d)
        dt = time.perf_counter() - t
    else:
        import logging

        from pyNastran.bdf.bdf import read_bdf

        logging.disable(logging.CRITICAL)
        base = _rss_mb()
        t = time.perf_counter()
        read_bdf(deck, xref=(reader == "pyNastran+xref"), debug=None)
        dt = time.perf_counter() - t
    print(json.dumps({"seconds": dt, "peak_mb": _rss_mb(), "base_mb": base}))


def _rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def measure(python: Path, reader: str, deck: Path, repeat: int) -> dict:
    best = None
    for _ in range(repeat):
        out = subprocess.run(
            [str(python), __file__, "--child", reader, str(deck)],
            check=True, capture_output=True, text=True,
        ).stdout  # fmt: skip
        r = json.loads(out.strip().splitlines()[-1])
        if best is None or r["seconds"] < best["seconds"]:
            best = r
    return best


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--child", nargs=2, metavar=("READER", "DECK"), help=argparse.SUPPRESS)
    ap.add_argument("--sizes", type=int, nargs="*", default=[1000], help="plate sizes n (n x n)")
    ap.add_argument("--repeat", type=int, default=3, help="runs per case (the fastest is kept)")
    ap.add_argument("--femcal-python", type=Path, default=ROOT / ".venv" / "bin" / "python")
    ap.add_argument(
        "--pynastran-python", type=Path, default=ROOT / ".venv-bench" / "bin" / "python"
    )
    args = ap.parse_args(argv)
    if args.child:
        child(*args.child)
        return 0
    decks = [("pyn_bwb (60 810 DOF)", REFDECKS / "pyn_bwb" / "bwb_freq.bdf", args.repeat)]
    for n in args.sizes:
        p = write_plate(n, WORK / f"plate_{n}x{n}.bdf")
        decks.append(
            (
                f"plate {n}x{n} ({n * n:,} CQUAD4, {(n + 1) ** 2:,} GRID)",
                p,
                1 if n >= 500 else args.repeat,
            )
        )
    pairs = [("femcal", "pyNastran"), ("femcal+model", "pyNastran+xref")]
    print(
        "| deck | femcal step | pyNastran step | femcal s | pyNastran s | speed-up | "
        "femcal peak MB | pyNastran peak MB | memory ratio |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for label, deck, rep in decks:
        for ours, theirs in pairs:
            a = measure(args.femcal_python, ours, deck, rep)
            b = measure(args.pynastran_python, theirs, deck, rep)
            print(
                f"| {label} | {_step(ours)} | {_step(theirs)} | {a['seconds']:.2f} | "
                f"{b['seconds']:.2f} | {b['seconds'] / a['seconds']:.1f}x | {a['peak_mb']:.0f} | "
                f"{b['peak_mb']:.0f} | {b['peak_mb'] / a['peak_mb']:.1f}x |",
                flush=True,
            )
    return 0


def _step(reader: str) -> str:
    return {
        "femcal": "read_deck",
        "femcal+model": "read_deck + build_model",
        "pyNastran": "read_bdf(xref=False)",
        "pyNastran+xref": "read_bdf(xref=True)",
    }[reader]


if __name__ == "__main__":
    sys.exit(main())
