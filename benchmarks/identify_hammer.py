"""Identification of the shipped synthetic hammer test, set against the hidden frame's true
modes, and side by side with sdypy-ema's LSCF on the same data (issue 7).

    make bench-identify      # installs sdypy-ema into .venv-ema for the LSCF side

The true modes are recomputed from the deck with the hidden parameter values and the cross
support (:func:`femcal.jobs.synthetic_test.hidden_frame`, same seed as the shipped set). Each
identified mode is paired with the true mode of the nearest frequency; MAC is against the
true shape at the 72 sensor channels. Prints one table per method and a summary.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
FRAME = ROOT / "models" / "truck_frame"
EMA_PY = ROOT / ".venv-ema" / "bin" / "python"


def true_modes():
    from femcal.jobs.synthetic_test import SynthSettings, hidden_frame

    s = SynthSettings()
    model, modes, _ = hidden_frame(FRAME / "hammer_frame.bdf", FRAME / "hammer_frame.params.toml",
                                   s, np.random.default_rng(s.seed))  # fmt: skip
    truth = tomllib.loads((FRAME / "hammer_test.truth.toml").read_text())
    return model, modes, np.array(truth["modes"]["damping_ratio"])


def sensor_shapes(model, modes, data) -> np.ndarray:
    from femcal.response.frf import direction_matrix

    axes = {"X": (1, 0, 0), "Y": (0, 1, 0), "Z": (0, 0, 1)}
    pts = []
    for c in data.outputs:
        sign = -1.0 if c.direction.startswith("-") else 1.0
        pts.append((c.grid, sign * np.array(axes[c.direction.lstrip("+-")], float)))
    return np.asarray(direction_matrix(model, pts) @ modes.shapes)


def compare(name, fr, z, shapes, seconds, true_f, true_z, true_shapes, band):
    from femcal.correlate.shapes import mac

    sel = np.flatnonzero((true_f >= band[0]) & (true_f <= band[1]))
    rows = []
    for k in sel:
        if len(fr) == 0:
            rows.append((true_f[k], None, None, None, None))
            continue
        j = int(np.argmin(np.abs(fr - true_f[k])))
        if abs(fr[j] / true_f[k] - 1) > 0.05:
            rows.append((true_f[k], None, None, None, None))
            continue
        m = float(mac(shapes[:, [j]], true_shapes[:, [k]])[0, 0]) if shapes is not None else None
        rows.append((true_f[k], fr[j], 100 * (fr[j] / true_f[k] - 1), 100 * (z[j] / true_z[k] - 1),
                     m))  # fmt: skip
    print(f"\n### {name} ({seconds:.1f} s, {len(fr)} modes identified in the band)\n")
    print("| true Hz | identified Hz | frequency error % | damping error % | MAC |")
    print("|---|---|---|---|---|")
    for tf, f, ef, ez, m in rows:
        if f is None:
            print(f"| {tf:.3f} | not found | | | |")
        else:
            ms = f"{m:.4f}" if m is not None else "-"
            print(f"| {tf:.3f} | {f:.3f} | {ef:+.3f} | {ez:+.1f} | {ms} |")
    extra = len(fr) - sum(r[1] is not None for r in rows)
    if extra > 0:
        print(f"\n{extra} identified pole(s) match no true mode.")
    return rows


def run_lscf(data, band, approx_hz, order):
    """sdypy-ema LSCF in its own environment: poles of all 144 FRFs (as SIMO locations),
    the stable poles nearest the given frequencies, shapes by its LSFD."""
    tmp = ROOT / "benchmarks" / "_work"
    tmp.mkdir(exist_ok=True)
    inp, out = tmp / "lscf_in.npz", tmp / "lscf_out.json"
    np.savez(inp, f=data.frequency_hz, H=data.H, band=np.array(band), approx=np.array(approx_hz),
             order=np.array(order))  # fmt: skip
    code = r"""
import json, sys, time, warnings
import numpy as np
from sdypy import EMA
z = np.load(sys.argv[1])
f, H, band, approx, order = z['f'], z['H'], z['band'], z['approx'], int(z['order'])
p, m, K = H.shape
frf = H.reshape(p * m, K)
t = time.perf_counter()
with warnings.catch_warnings():
    warnings.simplefilter('ignore')
    a = EMA.Model(frf=frf, freq=f, lower=float(band[0]), upper=float(band[1]),
                     pol_order_high=order, frf_form='accelerance')
    a.get_poles(method='lscf', show_progress=False)
    a.select_closest_poles(list(approx))
    how = 'its stable-pole selection'
    hits = int(np.sum(np.abs(np.asarray(a.nat_freq) / approx - 1) < 0.01))
    if hits < len(approx):
        # its selection missed modes: the poles of model order `order` nearest each instead
        k = order // 2 - 1
        fr, xi = np.asarray(a.pole_freq[k]), np.asarray(a.pole_xi[k])
        ok = (xi > 0) & (xi < 0.2)
        idx = [int(np.argmin(np.where(ok, np.abs(fr / fa - 1), np.inf))) for fa in approx]
        a.pole_ind = np.array([[k, i] for i in idx])
        a.nat_freq, a.nat_xi = fr[idx], xi[idx]
        how = (f'its stable-pole selection (select_closest_poles) found {hits} of the '
               f'{len(approx)} modes; taken instead: the poles of model order {order} nearest '
               'each')
    H_rec, A = a.get_constants(whose_poles='own', FRF_ind='all')
secs = time.perf_counter() - t
A = np.asarray(A).reshape(p, m, -1)
json.dump({'fn': list(map(float, a.nat_freq)), 'xi': list(map(float, a.nat_xi)), 'how': how,
           'shape_re': A.real.tolist(), 'shape_im': A.imag.tolist(), 'seconds': secs},
          open(sys.argv[2], 'w'))
"""
    subprocess.run([str(EMA_PY), "-c", code, str(inp), str(out)], check=True)
    res = json.loads(out.read_text())
    A = np.array(res["shape_re"]) + 1j * np.array(res["shape_im"])  # (p, m, k)
    best_input = np.argmax(np.linalg.norm(A, axis=0), axis=0)  # per mode
    shapes = np.stack([A[:, best_input[k], k] for k in range(A.shape[2])], axis=1)
    print(f"\nLSCF poles: {res['how']}")
    return np.array(res["fn"]), np.array(res["xi"]), shapes, res["seconds"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--no-lscf", action="store_true", help="femcal only")
    ap.add_argument("--lscf-order", type=int, default=40)
    args = ap.parse_args(argv)
    from femcal.identify import identify
    from femcal.testdata.formats.matlab import read_mat

    data = read_mat(FRAME / "hammer_test.mat")
    model, modes, true_z = true_modes()
    true_f = modes.frequencies_hz
    true_shapes = sensor_shapes(model, modes, data)
    band = (10.0, 120.0)
    cases = [("femcal, only the band (pLSCF, parts from the CMIF)", None, None),
             ("femcal, parts 10-50-80-120 Hz, automatic orders", (50.0, 80.0), None),
             ("femcal, the study's parts 10-60-100-120 Hz, automatic orders", (60.0, 100.0), None),
             ("femcal, the study's parts and orders (4 each)", (60.0, 100.0), 4),
             ("femcal, one part 10-120 Hz, automatic order", (), None)]  # fmt: skip
    found = None
    for name, splits, order in cases:
        t = time.perf_counter()
        m = identify(data, band, splits=splits, orders=order)
        secs = time.perf_counter() - t
        compare(name, m.frequency_hz, m.damping_ratio, m.shapes, secs, true_f, true_z,
                true_shapes, band)  # fmt: skip
        found = found if found is not None else m.frequency_hz
    if args.no_lscf:
        return 0
    if not EMA_PY.exists():
        print(f"\nsdypy-ema is not installed in {EMA_PY.parent.parent}: run `make bench-identify`",
              file=sys.stderr)  # fmt: skip
        return 1
    fr, z, shapes, secs = run_lscf(data, band, found, args.lscf_order)
    compare(f"sdypy-ema LSCF, order {args.lscf_order}, poles nearest femcal's", fr, z, shapes,
            secs, true_f, true_z, true_shapes, band)  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
