"""Rig-sized time data: write, read and turn into H1 FRFs an RPC III file of the rig test's size
(issue 24's target: 24 channels x 30 cycles x 136 s at 512 Hz, about 50 M samples, read and
turned into FRFs in under a minute on 2 cores).

    .venv/bin/python benchmarks/timedata.py [--seconds 4080] [--segment 4096]

7 white-noise drives; 17 responses, each the sum of the drives through digital resonators;
prints the time of each step and the peak memory.
"""

from __future__ import annotations

import argparse
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import scipy.signal as ss

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from femcal.testdata.formats.rpc3 import read_rpc3, write_rpc3  # noqa: E402
from femcal.testdata.signal import h1  # noqa: E402
from femcal.testdata.timedata import TimeData  # noqa: E402

FS, N_IN, N_OUT = 512.0, 7, 17


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=30 * 136.0, help="record length (s)")
    ap.add_argument("--segment", type=int, default=4096, help="Welch segment (samples)")
    args = ap.parse_args()
    n = int(args.seconds * FS)
    rng = np.random.default_rng(24)
    t0 = time.perf_counter()
    x = rng.standard_normal((N_IN, n))
    y = np.zeros((N_OUT, n))
    for o in range(N_OUT):
        for i in range(N_IN):
            w = 2 * np.pi * (3.0 + 1.7 * o + 0.9 * i)
            b, a = ss.bilinear([w**2], [1.0, 0.06 * w, w**2], FS)
            y[o] += ss.lfilter(b, a, x[i])
    names = tuple(f"drive {i + 1}" for i in range(N_IN)) + tuple(
        f"response {o + 1}" for o in range(N_OUT))
    data = TimeData(1 / FS, np.vstack([x, y]), names, ("mm",) * N_IN + ("m/s^2",) * N_OUT)
    t_make = time.perf_counter() - t0
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "rig.rsp"
        t0 = time.perf_counter()
        write_rpc3(path, data)
        t_write = time.perf_counter() - t0
        size = path.stat().st_size
        del data, x, y
        t0 = time.perf_counter()
        back = read_rpc3(path)
        t_read = time.perf_counter() - t0
        t0 = time.perf_counter()
        est = h1(back.values[:N_IN], back.values[N_IN:], back.dt, args.segment)
        t_h1 = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"{N_IN + N_OUT} channels x {n} samples = {(N_IN + N_OUT) * n / 1e6:.1f} M samples, "
          f"file {size / 1e6:.0f} MB (32-bit floats)")
    print(f"{'step':<28} {'seconds':>8}")
    for name, t in (("simulate (not the target)", t_make), ("write RPC III", t_write),
                    ("read RPC III", t_read),
                    (f"H1 {N_OUT}x{N_IN}, {est.segments} segments", t_h1),
                    ("read + H1", t_read + t_h1)):  # fmt: skip
        print(f"{name:<28} {t:8.1f}")
    print(f"peak memory {peak:.0f} MB")


if __name__ == "__main__":
    main()
