"""Two commits of femcal side by side in one run: the demo's calibration and the plate's
normal modes, each run whole (a process from the command line), alternating old and new.

    python benchmarks/commits.py OLD [NEW] [--jobs calibrate eigen] [--sizes 200 410]
                                 [--repeat N] [--calculix]

OLD and NEW are git revisions (NEW: the working tree's HEAD). Each is checked out once into
``benchmarks/_work/commits/<sha>`` (a git worktree) and run with this environment's Python,
its own sources first on the path; the jobs alternate old, new, old, new, ... so that a
machine's slow spell falls on both. Wall time and peak memory by GNU time (the largest
resident set of the process or of one child); "tree MB" is the peak of the proportional set
sizes of the process and its forked workers summed, sampled every 50 ms (a page they share
counted once).

* ``calibrate``: ``femcal calibrate models/truck_frame/hammer_calibration.toml`` (the demo's
  job, every start afresh). Besides the whole run, its set-up: the seconds from the line that
  announces the exact dependence of K and M to the first cycle's line. The figures the
  console prints (the parameter table, the deviation, the test-FE table) are compared as
  text; the calibrated values also as numbers, from report.json.
* ``eigen``: ``femcal solve plate_N.bdf --json`` on the clamped plate of
  ``eigen_vs_calculix.py`` (N x N CQUAD4: 200 is 242 k DOF, 410 about 1 M); the 20
  frequencies compared. With ``--calculix`` CalculiX runs the same plate once per size, for
  the ratio.

The tables print to stdout (Markdown), each run's figures to stderr as it ends.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import re
import subprocess
import sys
import threading
import time
from pathlib import Path

import eigen_vs_calculix as plate

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
WORK = HERE / "_work" / "commits"
DEMO = "models/truck_frame/hammer_calibration.toml"


def checkout(rev: str) -> tuple[str, Path]:
    """(short sha, worktree) of a revision, checked out once."""
    sha = subprocess.run(["git", "rev-parse", "--short=10", rev], cwd=ROOT, check=True,
                         capture_output=True, text=True).stdout.strip()  # fmt: skip
    tree = WORK / sha
    if not (tree / "src" / "femcal").is_dir():
        WORK.mkdir(parents=True, exist_ok=True)
        subprocess.run(["git", "worktree", "add", "--force", "--detach", str(tree), sha],
                       cwd=ROOT, check=True, capture_output=True)  # fmt: skip
    return sha, tree


#: Seconds between two samples of a run's memory (:func:`tree_pss_mb`).
SAMPLE = 0.05


def _descendants(pid: int) -> list[int]:
    """pid and every process below it (Linux: /proc/PID/task/*/children)."""
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        out.append(p)
        for task in Path(f"/proc/{p}/task").glob("*/children"):
            with contextlib.suppress(OSError):  # (the process ended meanwhile)
                todo += [int(c) for c in task.read_text().split()]
    return out


def tree_pss_mb(pid: int) -> float:
    """The proportional set size of process pid and its descendants, summed, in MiB: each
    page shared between them (a forked worker's pages it has not written) counted once."""
    total = 0
    for p in _descendants(pid):
        try:
            text = Path(f"/proc/{p}/smaps_rollup").read_text()
        except OSError:
            continue
        m = re.search(r"^Pss:\s+(\d+) kB", text, re.M)
        total += int(m.group(1)) if m else 0
    return total / 1024.0


def femcal(tree: Path, args: list[str], cwd: Path) -> tuple[float, float, str, float]:
    """(wall s, peak MB, stdout, peak MB of the process tree) of ``femcal ARGS`` from the
    worktree's sources. The peak is GNU time's: the largest resident set of the process or
    of any one child it waited for. The tree's peak sums the proportional set sizes of the
    process and its forked workers, sampled every :data:`SAMPLE` s."""
    env = {**os.environ, "PYTHONPATH": str(tree / "src")}
    proc = subprocess.Popen(["/usr/bin/time", "-f", "__TIME__ %e %M", sys.executable, "-m",
                             "femcal", *args], cwd=cwd, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)  # fmt: skip
    peak = [0.0]

    def sample() -> None:
        while proc.poll() is None:
            peak[0] = max(peak[0], tree_pss_mb(proc.pid))
            time.sleep(SAMPLE)

    watch = threading.Thread(target=sample, daemon=True)
    watch.start()
    stdout, stderr = proc.communicate()
    watch.join()
    if proc.returncode != 0:
        raise SystemExit(f"femcal {' '.join(args)} failed in {tree}:\n{stderr[-3000:]}")
    m = re.search(r"__TIME__ ([\d.]+) (\d+)", stderr)
    return float(m.group(1)), int(m.group(2)) / 1024.0, stdout + stderr, peak[0]


def calibrate(tree: Path, sha: str, k: int) -> dict:
    out = WORK / "out" / f"{sha}-{k}"
    wall, mb, text, tree_mb = femcal(tree, ["calibrate", DEMO, "--out", str(out), "--fresh"],
                                     tree)  # fmt: skip
    (out / "console.txt").write_text(text)  # (where the time went, line by line)
    stamp = lambda pat: float(re.search(r"\[\s*([\d.]+) s\] [^\n]*" + pat, text).group(1))  # noqa: E731
    setup = stamp("cycle 1: Levenberg") - stamp("the exact dependence of K and M")
    table = text[text.index("parameter  "):text.index("deviation: ")]
    deviation = re.search(r"deviation: .*", text).group(0)
    report = json.loads((out / "report.json").read_text())
    values = [p["calibrated"] for p in report["parameters"]]
    return dict(wall=wall, mb=mb, tree_mb=tree_mb, setup=setup, table=table,
                deviation=deviation, values=values)  # fmt: skip


def eigen(tree: Path, n: int) -> dict:
    deck = plate.nastran_deck(n)
    js = deck.with_name(f"{deck.stem}_{tree.name}.json")
    wall, mb, _, tree_mb = femcal(tree, ["solve", str(deck), "--json", str(js)], deck.parent)
    freqs = [m["frequency_hz"] for m in json.loads(js.read_text())["modes"]]
    return dict(wall=wall, mb=mb, tree_mb=tree_mb, freqs=freqs)


def median(xs: list[float]) -> float:
    xs = sorted(xs)
    mid = len(xs) // 2
    return xs[mid] if len(xs) % 2 else 0.5 * (xs[mid - 1] + xs[mid])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("old")
    ap.add_argument("new", nargs="?", default="HEAD")
    ap.add_argument("--jobs", nargs="+", choices=("calibrate", "eigen"),
                    default=["calibrate", "eigen"])  # fmt: skip
    ap.add_argument("--sizes", type=int, nargs="+", default=[200])
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--calculix", action="store_true", help="CalculiX once per plate size")
    args = ap.parse_args(argv)
    plate.WORK.mkdir(parents=True, exist_ok=True)
    (old, old_tree), (new, new_tree) = checkout(args.old), checkout(args.new)
    pairs = [(old, old_tree), (new, new_tree)]
    if "calibrate" in args.jobs:
        runs: dict[str, list[dict]] = {old: [], new: []}
        for k in range(args.repeat):
            for sha, tree in pairs:
                r = calibrate(tree, sha, k)
                runs[sha].append(r)
                print(f"calibrate {sha}: {r['wall']:.1f} s, set-up {r['setup']:.1f} s, "
                      f"{r['mb']:.0f} MB (tree {r['tree_mb']:.0f}); {r['deviation']}",
                      file=sys.stderr, flush=True)  # fmt: skip
        a, b = runs[old][0], runs[new][0]
        lines_a, lines_b = a["table"].splitlines(), b["table"].splitlines()
        differ = [f"{x.split()[0]}: {x.split()[2]} -> {y.split()[2]}"
                  for x, y in zip(lines_a, lines_b, strict=True) if x != y]  # fmt: skip
        rel = max(abs(u / v - 1.0) for u, v in zip(b["values"], a["values"], strict=True))
        print("| commit | calibrate s | set-up s | peak MB | tree MB | deviation |")
        print("|---|---|---|---|---|---|")
        for sha in (old, new):
            rs = runs[sha]
            print(f"| {sha} | {median([r['wall'] for r in rs]):.1f} | "
                  f"{median([r['setup'] for r in rs]):.1f} | {max(r['mb'] for r in rs):.0f} | "
                  f"{max(r['tree_mb'] for r in rs):.0f} | "
                  f"{rs[0]['deviation'].removeprefix('deviation: ')} |")  # fmt: skip
        print(f"\nspeed-up {median([r['wall'] for r in runs[old]]) / median([r['wall'] for r in runs[new]]):.2f}x, "  # noqa: E501
              f"set-up {median([r['setup'] for r in runs[old]]) / median([r['setup'] for r in runs[new]]):.1f}x; "  # noqa: E501
              f"printed tables {'identical' if not differ else 'differ in ' + '; '.join(differ)}; "
              f"calibrated values within {rel:.1e} (relative)\n")  # fmt: skip
    if "eigen" in args.jobs:
        print("| mesh | DOF | commit | femcal s | peak MB | tree MB | CalculiX s | ratio | "
              "f1-f5 (Hz) |")  # fmt: skip
        print("|---|---|---|---|---|---|---|---|---|")
        for n in args.sizes:
            ccx = plate.run_calculix(n) if args.calculix else None
            runs = {old: [], new: []}
            for _ in range(args.repeat):
                for sha, tree in pairs:
                    r = eigen(tree, n)
                    runs[sha].append(r)
                    print(f"{n}x{n} {sha}: {r['wall']:.1f} s, {r['mb']:.0f} MB (tree "
                          f"{r['tree_mb']:.0f})", file=sys.stderr, flush=True)  # fmt: skip
            fa, fb = runs[old][0]["freqs"], runs[new][0]["freqs"]
            for sha in (old, new):
                w = median([r["wall"] for r in runs[sha]])
                c = f"{ccx[0]:.1f} | {ccx[0] / w:.1f}x" if ccx else "- | -"
                fs = ", ".join(f"{x:.4f}" for x in runs[sha][0]["freqs"][:5])
                print(f"| {n}x{n} | {6 * (n + 1) ** 2:,} | {sha} | {w:.1f} | "
                      f"{max(r['mb'] for r in runs[sha]):.0f} | "
                      f"{max(r['tree_mb'] for r in runs[sha]):.0f} | {c} | {fs} |")  # fmt: skip
            worst = max(abs(y / x - 1.0) for x, y in zip(fa, fb, strict=True))
            print(f"\n{n}x{n}: the 20 frequencies of the two commits agree within {worst:.1e}\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
