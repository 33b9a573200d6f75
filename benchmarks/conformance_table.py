"""The SOL 103 conformance table: every reference deck against its NASTRAN run.

    python benchmarks/conformance_table.py

For each deck in ../shared/refdecks: tier, the worst relative frequency error over the modes
marked valid (and at which mode), the tolerance tests/test_conformance.py applies, and the
outcome. The same comparison is what the test asserts; this prints it as a table.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
REFDECKS = ROOT.parent / "shared" / "refdecks"
#: Below this every reference frequency counts as a zero (mechanisms) and is compared absolutely.
ALL_ZERO_HZ = 1e-4
SHELL_SOLID = {"CQUAD4", "CTRIA3", "CQUAD8", "CTRIA6", "CQUADR", "CTRIAR", "CSHEAR", "CHEXA",
               "CPENTA", "CTETRA", "CPYRAM"}  # fmt: skip


def main() -> int:
    from femcal.deck import read_deck
    from femcal.errors import FemcalError
    from femcal.model.build import build_model
    from femcal.solve.normal_modes import solve_normal_modes

    print("| deck | tier | modes | worst error | at mode | tolerance | time s | result |")
    print("|---|---|---|---|---|---|---|---|")
    for ref_path in sorted(REFDECKS.glob("*/reference.json")):
        ref = json.loads(ref_path.read_text())
        tier = ref.get("tier", "?")
        tol = 1e-2 if set(ref["deck"]["card_count"]) & SHELL_SOLID else 1e-3
        valid = [m for m in ref["modes"] if m["valid"]]
        t0 = time.perf_counter()
        try:
            deck = read_deck(ref_path.parent / ref["deck"]["main_file"])
            modes, _ = solve_normal_modes(build_model(deck))
        except FemcalError as e:
            msg = str(e).splitlines()[-1].strip()[:90]
            print(f"| {ref['name']} | {tier} | {len(valid)} | - | - | {tol:.0e} | - | {msg} |")
            continue
        dt = time.perf_counter() - t0
        f = modes.frequencies_hz
        fmax = max(m["cycles_hz"] for m in valid)
        if fmax < ALL_ZERO_HZ:  # every reference mode is a mechanism: compare absolutely
            n = min(len(f), len(valid))
            worst = float(np.abs(f[:n]).max()) if n else 0.0
            ok = n == len(valid) and worst < ALL_ZERO_HZ
            print(f"| {ref['name']} | {tier} | {n}/{len(valid)} | all ~0 Hz (femcal up to "
                  f"{worst:.1e} Hz) | - | {tol:.0e} | {dt:.2f} | "
                  f"{'match' if ok else 'differs'} |", flush=True)  # fmt: skip
            continue
        worst, at, zeros_ok = 0.0, 0, True
        for m in valid:
            i = m["mode"] - 1
            if i >= len(f):
                zeros_ok = False
                continue
            if m["cycles_hz"] < 1e-3 * fmax:
                zeros_ok &= abs(f[i]) < 1e-3 * fmax
                continue
            err = abs(f[i] / m["cycles_hz"] - 1.0)
            if err > worst:
                worst, at = err, m["mode"]
        found = sum(1 for m in valid if m["mode"] - 1 < len(f))
        ok = worst <= tol and zeros_ok and found == len(valid)
        result = "match" if ok else ("does not match" if tier != "C" else "differs (tier C)")
        print(f"| {ref['name']} | {tier} | {found}/{len(valid)} | {worst:.2e} | {at} | "
              f"{tol:.0e} | {dt:.2f} | {result} |", flush=True)  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
