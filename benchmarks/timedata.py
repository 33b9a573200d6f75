"""Rig-sized time data: a synthetic rig test of the study's size written as RPC III, read back
and turned into FRFs as the study processed it (issue 24's target: 24 channels x 30 cycles x
136 s at 512 Hz, about 50 M samples, read and turned into FRFs in under a minute on 2 cores).

    .venv/bin/python benchmarks/timedata.py [--period 136] [--cycles 30] [--segment 8]

The test is ``femcal synth-rig-test`` of the rig frame with the battery box (7 actuators, 24
channels, the hammer test's hidden values), stored as 16-bit integers as rig controllers
write. The FRFs are H1 of the 10 accelerations on the 7 actuator displacements: the study's
chain (cycle averaging, detrending, 0.5-30 Hz FIR band-pass of order 20, Welch) and Welch
over the whole record; each is checked against the hidden frame's exact FRFs where the
multiple coherence exceeds 0.95. Prints the time of each step and the peak memory.
"""

from __future__ import annotations

import argparse
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from femcal.jobs.synthetic_rig_test import RigTestSettings, make_rig_test  # noqa: E402
from femcal.testdata.estimate import FRFSettings, estimate_frfs  # noqa: E402
from femcal.testdata.formats.rpc3 import read_rpc3, write_rpc3  # noqa: E402

FRAME = ROOT / "models" / "truck_frame"


def accuracy(result, plant, n_in: int) -> tuple[float, float]:
    """Median relative error of the FRFs against the plant's where the multiple coherence
    exceeds 0.95 (errors over each output's largest FRF at the line), and that share."""
    f = result.frf.frequency_hz
    exact = plant.frf(f)[2 * n_in:]
    good = result.frf.coherence > 0.95
    err = np.abs(result.frf.H - exact) / np.abs(exact).max(axis=1, keepdims=True)
    return float(np.median(err[np.broadcast_to(good[:, None, :], err.shape)])), float(good.mean())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--period", type=float, default=136.0, help="drive period (s)")
    ap.add_argument("--cycles", type=int, default=30, help="cycles recorded")
    ap.add_argument("--segment", type=float, default=8.0, help="Welch segment (s)")
    args = ap.parse_args()
    t0 = time.perf_counter()
    test = make_rig_test(FRAME / "rig_frame_battery.bdf", FRAME / "hammer_frame.params.toml",
                         FRAME / "rig_frame_battery.inputs.csv",
                         FRAME / "rig_frame_battery.sensors.csv",
                         RigTestSettings(period_s=args.period, cycles=args.cycles),
                         truth_path=FRAME / "hammer_test.truth.toml")  # fmt: skip
    t_make = time.perf_counter() - t0
    data, plant = test.data, test.plant
    n_in = len(plant.inputs)
    ins, outs = list(data.names[:n_in]), list(data.names[2 * n_in:])
    rows = [("simulate the test (not the target)", t_make, "")]
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "rig.rsp"
        t0 = time.perf_counter()
        write_rpc3(path, data, data_type="SHORT_INTEGER")
        rows.append(("write RPC III (16-bit)", time.perf_counter() - t0, ""))
        size = path.stat().st_size
        shape = data.values.shape
        del data, test  # the file is read back from disk alone
        t0 = time.perf_counter()
        back = read_rpc3(path)
        t_read = time.perf_counter() - t0
        rows.append(("read RPC III", t_read, ""))
        for name, settings in (
            ("study chain: average, detrend, band-pass, H1",
             FRFSettings(period_s=args.period, segment_s=args.segment, band=(0.5, 30.0))),
            ("H1 over the whole record", FRFSettings(segment_s=args.segment, band=(0.5, 30.0))),
        ):  # fmt: skip
            t0 = time.perf_counter()
            result = estimate_frfs(back, ins, outs, settings)
            t = time.perf_counter() - t0
            err, share = accuracy(result, plant, n_in)
            rows.append((name, t, f"{result.spectra.segments} segments; median error "
                         f"{100 * err:.1f} % where coherence > 0.95 ({100 * share:.0f} % of "
                         "lines)"))  # fmt: skip
            rows.append(("  read + FRFs", t_read + t, ""))
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"{shape[0]} channels x {shape[1]} samples = {shape[0] * shape[1] / 1e6:.1f} M "
          f"samples, file {size / 1e6:.0f} MB; {len(outs)} x {n_in} FRFs")  # fmt: skip
    print(f"{'step':<46} {'seconds':>8}  note")
    for name, t, note in rows:
        print(f"{name:<46} {t:8.1f}  {note}")
    print(f"peak memory {peak:.0f} MB")


if __name__ == "__main__":
    main()
