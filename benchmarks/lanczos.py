"""Block shift-invert Lanczos against ARPACK, on the same matrices in one process.

    .venv/bin/python benchmarks/lanczos.py

The 200x200 plate of eigen_vs_calculix.py (20 modes, as there) and the bundled hammer frame
(100 modes, as each calibration surrogate rebuild asks): the whole ``solve_modes`` call of
each method (factorisation included, the same in both), and the largest relative difference
of their eigenvalues.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))


def matrices(deck_path: Path):
    """(K_aa, M_aa) of a deck after constraints and AUTOSPC, as solve_normal_modes forms them."""
    from femcal.assembly import Options, assemble
    from femcal.assembly.constraints import autospc, build_reduction
    from femcal.model.build import load_model

    model = load_model(deck_path)
    mats = assemble(model, Options())
    red = build_reduction(model)
    K, M = red.reduce(mats.K), red.reduce(mats.M)
    red = autospc(model, red, K, M, enabled=True)
    if len(red.autospc):
        K, M = red.reduce(mats.K), red.reduce(mats.M)
    return K, M


def main() -> int:
    import eigen_vs_calculix as plate
    from femcal.model import EigenRequest
    from femcal.solve.eigen import solve_modes

    plate.WORK.mkdir(parents=True, exist_ok=True)
    cases = [("200x200 plate", plate.nastran_deck(200), 20),
             ("hammer frame", HERE.parent / "models" / "truck_frame" / "hammer_frame.bdf", 100)]
    print("| model | a-set DOF | modes | ARPACK s | block Lanczos s | ratio "
          "| eigenvalues agree to |")
    print("|---|---|---|---|---|---|---|")
    for name, path, nd in cases:
        K, M = matrices(path)
        seconds, lam = {}, {}
        for method in ("arpack", "block"):
            t = time.perf_counter()
            res = solve_modes(K, M, EigenRequest(nd=nd), method=method)
            seconds[method] = time.perf_counter() - t
            lam[method] = res.eigenvalues
        big = np.abs(lam["arpack"]).max()
        diff = np.abs(lam["block"] - lam["arpack"]).max() / big
        print(f"| {name} | {K.shape[0]:,} | {nd} | {seconds['arpack']:.2f} | "
              f"{seconds['block']:.2f} | {seconds['arpack'] / seconds['block']:.1f}x | "
              f"{diff:.0e} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
