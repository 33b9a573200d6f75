"""The SLEPc backend under MPI against the default solver, on the clamped plate of
``eigen_vs_calculix.py`` (1 m x 1 m x 5 mm steel, one edge clamped, CQUAD4, 20 modes).

For each mesh (200 x 200: 242 406 DOF; 410 x 410: 1 013 526 DOF) it runs, one after the
other, whole ``femcal solve DECK --json F`` commands (reading, assembly, constraints,
eigensolution, results):

* the default solver: ``.venv/bin/femcal solve`` (block shift-invert Lanczos on CHOLMOD);
* the SLEPc backend on 1 and 2 ranks: ``mpirun -n N --bind-to none .venv-slepc/bin/femcal
  solve --backend slepc`` (Krylov-Schur, shift-invert, MUMPS Cholesky).

Wall time is the whole command's; each process's peak resident memory is GNU time's (every
rank runs under its own ``/usr/bin/time``), shown as the largest rank's and the sum over the
ranks. "solve s" is the time from the a-set to the modes, read from rank 0's progress lines
(so the rest, reading and assembling, is what every rank repeats). The last columns give the
largest relative difference of the 20 frequencies from the default solver's and the first
three.

    python benchmarks/slepc_scaling.py [--sizes 200 410] [--ranks 1 2]

Needs ``make setup-slepc`` (``.venv-slepc/`` and Open MPI). Units mm, t, s, N, MPa.
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from eigen_vs_calculix import FEMCAL, ROOT, WORK, nastran_deck

SLEPC_FEMCAL = ROOT / ".venv-slepc" / "bin" / "femcal"
#: Each rank's wall time and peak resident set, by GNU time, on its own line.
TIME_FORMAT = "__RANK__ %e %M"
#: A case that takes longer than this is stopped and reported as such.
TIMEOUT_S = 3600


@dataclass
class Run:
    """One whole command: wall seconds, each process's peak MB, the solution's seconds (a-set
    to modes) and the frequencies (Hz)."""

    wall: float
    peaks_mb: list[float]
    solve: float | None
    freqs: list[float]


def _progress_time(stderr: str, pattern: str) -> float | None:
    """The timestamp (s) of the first progress line ``[   t s] ...`` matching ``pattern``."""
    m = re.search(r"\[\s*([\d.]+) s\] " + pattern, stderr)
    return float(m.group(1)) if m else None


def run_case(deck: Path, ranks: int | None) -> Run:
    """``femcal solve`` of the deck: the default solver (ranks None) or SLEPc on ``ranks``."""
    out = deck.with_name(f"{deck.stem}_{'default' if ranks is None else f'slepc{ranks}'}.json")
    timed = ["/usr/bin/time", "-f", TIME_FORMAT]
    if ranks is None:
        cmd = [*timed, str(FEMCAL), "solve", str(deck), "--json", str(out)]
    else:
        cmd = ["mpirun", "-n", str(ranks), "--allow-run-as-root", "--oversubscribe",
               "--bind-to", "none", *timed, str(SLEPC_FEMCAL), "solve", str(deck),
               "--backend", "slepc", "--json", str(out)]  # fmt: skip
    t0 = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=TIMEOUT_S)
    wall = time.perf_counter() - t0
    if done.returncode:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{done.stderr[-3000:]}")
    peaks = [int(kb) / 1024.0 for kb in re.findall(r"__RANK__ [\d.]+ (\d+)", done.stderr)]
    start = _progress_time(done.stderr, r"a-set \d+ DOF")
    end = _progress_time(done.stderr, r"\d+ modes \(")
    solve = end - start if start is not None and end is not None else None
    freqs = [m["frequency_hz"] for m in json.loads(out.read_text())["modes"]]
    return Run(wall, peaks, solve, freqs)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[200, 410],
                    help="plate meshes n x n (200: 242 406 DOF, 410: 1 013 526 DOF)")
    ap.add_argument("--ranks", type=int, nargs="*", default=[1, 2],
                    help="MPI ranks of the SLEPc runs")  # fmt: skip
    args = ap.parse_args(argv)
    if not SLEPC_FEMCAL.exists() or shutil.which("mpirun") is None:
        print("needs .venv-slepc/ and mpirun: run `make setup-slepc` first", file=sys.stderr)
        return 1
    WORK.mkdir(parents=True, exist_ok=True)
    print("| mesh | DOF | solver | ranks | wall s | solve s | peak MB (largest rank) | "
          "peak MB (sum of ranks) | max rel. diff. of f1-f20 | f1-f3 (Hz) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for n in args.sizes:
        deck = nastran_deck(n)
        dof = 6 * (n + 1) ** 2
        base = run_case(deck, None)
        cases: list[tuple[str, int | None, Run]] = [("default (CHOLMOD, Lanczos)", None, base)]
        for r in args.ranks:
            cases.append(("SLEPc (MUMPS, Krylov-Schur)", r, run_case(deck, r)))
        for name, ranks, run in cases:
            diff = max(abs(a / b - 1.0) for a, b in zip(run.freqs, base.freqs, strict=True))
            solve = f"{run.solve:.1f}" if run.solve is not None else "-"
            f13 = ", ".join(f"{f:.4f}" for f in run.freqs[:3])
            print(f"| {n}x{n} | {dof:,} | {name} | {ranks or 1} | {run.wall:.1f} | {solve} | "
                  f"{max(run.peaks_mb):.0f} | {sum(run.peaks_mb):.0f} | "
                  f"{'-' if ranks is None else f'{diff:.1e}'} | {f13} |", flush=True)  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
