"""Where the normal modes' time goes, stage by stage, on the clamped plate of
``eigen_vs_calculix.py`` (N x N CQUAD4, 20 modes: 200 is 242 k DOF, 410 about 1 M).

    python benchmarks/eigen_stages.py [--sizes 200 410] [--repeat N]

Each run is a fresh process doing what ``femcal solve plate_N.bdf --json`` does, in the
library's own steps: imports, reading, building the model, then ``solve_normal_modes`` with
a progress callback whose every line is timed (assembly, the a-set, the split into parts,
each part's factor and lowest-root check, the Lanczos iteration, the Rayleigh quotients and
the g-set), then the JSON. A stage's time runs from the line before it to its own line.
The table prints each stage's median over the runs (Markdown on stdout).

Where the parts are shared with a forked process (the command line's default on a machine of
two cores or more: ``femcal.solve.eigen._in_parts``), that process's lines arrive when this
one next waits for it, so the parts' stages overlap and their times are those of the lines'
arrival; the total is the wall time.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
from pathlib import Path

import eigen_vs_calculix as plate
from commits import median

HERE = Path(__file__).resolve().parent

#: One run, in a fresh process: (stage, seconds) pairs as JSON on stdout.
_RUN = r"""
import json, sys, time
T = time.perf_counter
t0 = T()
from femcal.parallel.executors import limit_openmp
limit_openmp()  # as the command line does
from femcal.deck import read_deck
from femcal.io.modes import modes_json, write_json
from femcal.model.build import build_model
from femcal.solve.normal_modes import solve_normal_modes
stamps = [("imports", T())]
deck = read_deck(sys.argv[1]); stamps.append(("reading", T()))
model = build_model(deck); stamps.append(("model", T()))
modes, _ = solve_normal_modes(model, progress=lambda line: stamps.append((line, T())))
stamps.append(("the modes' last steps (Rayleigh quotients, g-set)", T()))
write_json(sys.argv[2], modes_json(modes, model)); stamps.append(("writing", T()))
out, before = [], t0
for what, t in stamps:
    out.append((what, t - before))
    before = t
print(json.dumps(out))
"""

#: Progress lines -> stage names (the line that ends a stage names it; the lines of one
#: stage add up).
_STAGES = [
    (r"^assembled K and M", "assembly"),
    (r"^a-set \d+ DOF", "constraints, AUTOSPC (a-set)"),
    (r"^(\d+) independent parts", "split into parts"),
    (r"^part (\d+) of \d+ \(\d+ DOF\): K - sigma M factored", "part {0}: factor"),
    (r"^K - sigma M factored", "factor"),
    (r"^part (\d+) of \d+: ", "part {0}: lowest-root check"),
    (r"^part (\d+) of \d+ \(\d+ DOF\) has", "(parts skipped)"),
    (r"^Lanczos: \d+ roots converged", "Lanczos iteration"),
    (r"^Lanczos: ", "(to the Lanczos)"),
]


def stage_of(line: str) -> str:
    for pattern, name in _STAGES:
        m = re.match(pattern, line)
        if m:
            return name.format(*m.groups())
    return line


def one_run(deck: Path) -> list[tuple[str, float]]:
    js = deck.with_name(f"{deck.stem}_stages.json")
    out = subprocess.run([sys.executable, "-c", _RUN, str(deck), str(js)], check=True,
                         capture_output=True, text=True)  # fmt: skip
    merged: dict[str, float] = {}
    for what, seconds in json.loads(out.stdout.strip().splitlines()[-1]):
        name = stage_of(what)
        merged[name] = merged.get(name, 0.0) + seconds
    return list(merged.items())


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[200])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    for n in args.sizes:
        deck = plate.nastran_deck(n)
        runs = [one_run(deck) for _ in range(args.repeat)]
        names = [name for name, _ in runs[0]]
        print(f"\n{n}x{n} plate ({deck.name}), {args.repeat} runs: median s per stage\n")
        print("| stage | s | share |\n|---|---|---|")
        totals = [sum(s for _, s in run) for run in runs]
        total = median(totals)
        for name in names:
            s = median([dict(run).get(name, 0.0) for run in runs])
            print(f"| {name} | {s:.2f} | {100 * s / total:.0f} % |")
        print(f"| **total** (runs {', '.join(f'{t:.2f}' for t in totals)}) | {total:.2f} | |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
