"""The long fuzz run: seeded mutations of reference decks, FRF files, calibration configs and
RPC III time histories (the harnesses in tests/fuzz/), counted by outcome. The target is 0
crashes (a traceback for the user), 0 hangs and 0 wrong answers where an oracle exists (a deck
that solves gives the same modes written back by femcal; an RPC III file valid or changed only
in form reads as the channels its generator wrote, a broken one is refused).

    .venv/bin/python benchmarks/fuzz.py       # decks 10000, frf 5000, configs 5000, rpc 20000
    .venv/bin/python benchmarks/fuzz.py --part decks --cases 20000 --seed 7
    .venv/bin/python benchmarks/fuzz.py --part rpc

Prints one row per part and writes every case that is not ``ok`` or a clean error, with the
seed that rebuilds it, to benchmarks/_work/fuzz/<part>.json.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib
import json
import sys
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

#: part -> (module, runner function, default number of cases)
PARTS = {
    "decks": ("tests.fuzz.decks", "run_deck_fuzz", 10_000),
    "frf": ("tests.fuzz.frf", "run_frf_fuzz", 5_000),
    "configs": ("tests.fuzz.configs", "run_config_fuzz", 5_000),
    "rpc": ("tests.fuzz.rpc", "run_rpc_fuzz", 20_000),
}
BAD = ("crash", "hang", "wrong")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--part", choices=sorted(PARTS), action="append",
                    help="which harness (default: all)")  # fmt: skip
    ap.add_argument("--cases", type=int, help="cases per part (default: the part's own)")
    ap.add_argument("--seed", type=int, default=1, help="first case's seed (default 1)")
    args = ap.parse_args()
    out = ROOT / "benchmarks" / "_work" / "fuzz"
    out.mkdir(parents=True, exist_ok=True)
    print(f"{'part':<8} {'cases':>6} {'ok':>6} {'error':>6} {'crash':>6} {'hang':>5} "
          f"{'wrong':>6} {'seconds':>8}")  # fmt: skip
    failed = 0
    for part in args.part or list(PARTS):
        module, func, default = PARTS[part]
        run = getattr(importlib.import_module(module), func)
        n = args.cases or default
        t0 = time.perf_counter()
        findings = run(args.seed, n)
        seconds = time.perf_counter() - t0
        counts = Counter(_outcome(f) for f in findings)
        bad = [dataclasses.asdict(f) for f in findings if _outcome(f) in BAD]
        (out / f"{part}.json").write_text(json.dumps(bad, indent=1, default=str))
        failed += len(bad)
        print(f"{part:<8} {len(findings):>6} {counts['ok']:>6} {counts['error']:>6} "
              f"{counts['crash']:>6} {counts['hang']:>5} {counts['wrong']:>6} {seconds:>8.0f}",
              flush=True)  # fmt: skip
    return 1 if failed else 0


def _outcome(finding: object) -> str:
    """The finding's outcome in this table's words (a harness may say "clean error")."""
    o = str(getattr(finding, "outcome", "crash")).lower()
    return "error" if "error" in o else o


if __name__ == "__main__":
    sys.exit(main())
