"""Both of femcal's estimators against sdypy-ema's LSCF, on real measured FRFs with published
modes and on synthetic FRFs with known modes: accuracy and time side by side (issue 38).

    make bench-identify-real      # installs sdypy-ema into .venv-ema for its side
    .venv/bin/python benchmarks/identify_real.py [--tool-holder DIR] [--sets beam,aircraft]

The sets: the real ones of tests/data/real (a lightly damped beam, roving hammer 1 x 9; a lab
aircraft frame, 3 x 74 with coherence; two noisy single FRFs), each over its published
band; the shipped synthetic hammer test (72 x 2, 2 % noise; its hidden frame's modes) and a
noise-free 14 x 2 plate holding 12 modes (its FE modes). ``--tool-holder DIR`` adds the UBC
tool-holder set (five ``Point_N_Channel_1_CH1.txt`` files, receptance; 3-5 % damping), which
has no licence that lets it be kept in the repository.

femcal runs with only the band given. sdypy-ema's LSCF has no automatic choice of its
stable poles: it is given what an engineer clicking on its stabilisation diagram would aim
at, the reference's own frequencies (``select_closest_poles``), at its default highest
order. A mode counts as found within the reference's accuracy (``published.json``; for the
synthetic sets 0.1 %). Times are the identification alone, one run each.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
REAL = ROOT / "tests" / "data" / "real"
EMA_PY = ROOT / ".venv-ema" / "bin" / "python"
sys.path.insert(0, str(ROOT / "tests"))


@dataclass
class Case:
    name: str
    data: object
    band: tuple[float, float]
    modes_hz: list[float]
    accuracy_hz: list[float]


def real_cases(tool_holder: Path | None) -> list[Case]:
    from test_identify_real import aircraft, beam, published, single_frf

    out = []
    for folder, load in (("modelab_beam", beam), ("uliege_aircraft", aircraft)):
        ref = published(folder)
        out.append(Case(folder, load(), tuple(ref["band_hz"]), ref["modes_hz"],
                        [ref["accuracy_hz"]] * len(ref["modes_hz"])))  # fmt: skip
    ref = published("vibrationtesting")
    for case in ("case1.mat", "case2.mat"):
        modes = ref["modes_hz"][case]
        out.append(Case(f"vibrationtesting {case}", single_frf(case), tuple(ref["band_hz"]),
                        modes, [ref["accuracy_hz"]] * len(modes)))  # fmt: skip
    if tool_holder is not None:
        from femcal.testdata.data import Channel, FRFData

        H = []
        for k in range(1, 6):
            a = np.loadtxt(tool_holder / f"Point_{k}_Channel_1_CH1.txt")
            f = a[:, 0]
            H.append(a[:, 1] + 1j * a[:, 2])
        data = FRFData(f, np.array(H)[None], (Channel.parse("1:+Z"),),
                       tuple(Channel.parse(f"{k}:+Z") for k in range(1, 6)), "receptance",
                       "m/N")  # fmt: skip
        # the source's hand estimates from the driving point's real-part extrema and
        # imaginary peak at 1 Hz lines, each mode's peak moved by its heavily damped
        # neighbours: taken as accurate to an eighth of its half-power bandwidth
        modes, zeta = [1074.0, 1961.0, 2617.0], [0.034, 0.0454, 0.0453]
        out.append(Case("UBC tool holder", data, (300.0, 3500.0), modes,
                        [0.25 * z * m for m, z in zip(modes, zeta, strict=True)]))  # fmt: skip
    return out


def synthetic_cases() -> list[Case]:
    from calib_decks import INS, OUTS, write_plate
    from femcal.jobs.synthetic_test import SynthSettings, hidden_frame
    from femcal.model import EigenRequest
    from femcal.response.frf import channel_matrix, modal_frf
    from femcal.solve.normal_modes import solve_normal_modes
    from femcal.testdata.data import Channel, FRFData
    from femcal.testdata.formats import read_frf

    frame = ROOT / "models" / "truck_frame"
    hammer = read_frf(frame / "hammer_test.uff")
    s = SynthSettings()
    _, modes, _ = hidden_frame(frame / "hammer_frame.bdf", frame / "hammer_frame.params.toml",
                               s, np.random.default_rng(s.seed))  # fmt: skip
    band = (10.0, 120.0)
    true = [float(f) for f in modes.frequencies_hz if band[0] < f < band[1]]
    out = [Case("synthetic hammer test 72 x 2", hammer, band, true,
                [1e-3 * f for f in true])]  # fmt: skip
    work = ROOT / "benchmarks" / "_work" / "plate"
    work.mkdir(parents=True, exist_ok=True)
    model, _ = write_plate(work)
    fe, _ = solve_normal_modes(model, request=EigenRequest(nd=40))
    o = [Channel.parse(x) for x in OUTS]
    i = [Channel.parse(x) for x in INS]
    f = np.arange(2.0, 750.0, 0.25)
    H = modal_frf(fe.shapes, fe.radians, channel_matrix(model, o), channel_matrix(model, i).T,
                  f, 0.02, "accelerance")  # fmt: skip
    band = (8.0, 420.0)
    true = [float(x) for x in fe.frequencies_hz if band[0] < x < band[1]]
    out.append(Case("noise-free plate 14 x 2", FRFData(f, H, tuple(o), tuple(i), "accelerance",
                                                        "mm/s^2/N"), band, true,
                    [1e-3 * x for x in true]))  # fmt: skip
    return out


def found(freqs: np.ndarray, case: Case) -> tuple[int, float, int]:
    """(published modes found within their accuracy, the worst of their errors in % of
    the frequency, poles matching no reference mode), one to one, nearest pairs first."""
    pairs = sorted((abs(f - m), i, j) for i, m in enumerate(case.modes_hz)
                   for j, f in enumerate(freqs))  # fmt: skip
    got: dict[int, int] = {}
    used: set[int] = set()
    for d, i, j in pairs:
        if i not in got and j not in used and d <= case.accuracy_hz[i]:
            got[i] = j
            used.add(j)
    worst = max((100 * abs(freqs[j] / case.modes_hz[i] - 1) for i, j in got.items()),
                default=float("nan"))  # fmt: skip
    return len(got), worst, len(freqs) - len(got)


def run_femcal(case: Case, method: str) -> tuple[np.ndarray, float]:
    from femcal.identify import Settings, identify

    t = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = identify(case.data, case.band, settings=Settings(method=method))
    return model.frequency_hz, time.perf_counter() - t


LSCF_CODE = r"""
import json, sys, time, warnings
import numpy as np
from sdypy import EMA
z = np.load(sys.argv[1])
f, H, band, approx, form = z['f'], z['H'], z['band'], z['approx'], str(z['form'])
p, m, K = H.shape
t = time.perf_counter()
with warnings.catch_warnings():
    warnings.simplefilter('ignore')
    a = EMA.Model(frf=H.reshape(p * m, K), freq=f, lower=float(band[0]),
                  upper=float(band[1]), frf_form=form)
    a.get_poles(method='lscf', show_progress=False)
    a.select_closest_poles(list(approx))
json.dump({'fn': list(map(float, a.nat_freq)), 'seconds': time.perf_counter() - t},
          open(sys.argv[2], 'w'))
"""


def run_sdypy(case: Case) -> tuple[np.ndarray, float]:
    tmp = ROOT / "benchmarks" / "_work"
    tmp.mkdir(exist_ok=True)
    inp, out = tmp / "lscf_in.npz", tmp / "lscf_out.json"
    form = case.data.quantity if case.data.quantity != "mobility" else "mobility"
    np.savez(inp, f=case.data.frequency_hz, H=case.data.H, band=np.array(case.band),
             approx=np.array(case.modes_hz), form=np.array(form))  # fmt: skip
    subprocess.run([str(EMA_PY), "-c", LSCF_CODE, str(inp), str(out)], check=True,
                   capture_output=True)  # fmt: skip
    res = json.loads(out.read_text())
    return np.unique(np.array(res["fn"])), res["seconds"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tool-holder", type=Path, metavar="DIR",
                    help="folder of the UBC tool-holder set's Point_N_Channel_1_CH1.txt")
    ap.add_argument("--no-sdypy", action="store_true", help="femcal's estimators only")
    ap.add_argument("--no-synthetic", action="store_true", help="the real sets only")
    args = ap.parse_args(argv)
    cases = real_cases(args.tool_holder)
    if not args.no_synthetic:
        cases += synthetic_cases()
    sdypy = not args.no_sdypy and EMA_PY.exists()
    if not args.no_sdypy and not sdypy:
        print(f"sdypy-ema is not installed in {EMA_PY.parent.parent}: run `make "
              "bench-identify-real`; femcal's estimators only", file=sys.stderr)  # fmt: skip
    print("| set | reference modes | method | found within the reference's accuracy | worst "
          "error % | other poles | time s |")
    print("|---|---|---|---|---|---|---|")
    for case in cases:
        runs = [("femcal pLSCF", lambda c: run_femcal(c, "plscf")),
                ("femcal subspace", lambda c: run_femcal(c, "subspace"))]
        if sdypy:
            runs.append(("sdypy-ema LSCF, poles picked at the reference", run_sdypy))
        for label, fn in runs:
            try:
                freqs, secs = fn(case)
            except Exception as e:  # a benchmark row, not a crash
                print(f"| {case.name} | {len(case.modes_hz)} | {label} | failed: "
                      f"{type(e).__name__} | | | |")  # fmt: skip
                continue
            n, worst, other = found(freqs, case)
            print(f"| {case.name} | {len(case.modes_hz)} | {label} | {n} | {worst:.3f} | "
                  f"{other} | {secs:.1f} |", flush=True)  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
