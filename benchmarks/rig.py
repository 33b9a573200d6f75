"""The virtual rig's speed (issue 25's target: 60 s of 7-actuator drive at 512 Hz simulated on
the rig frame in under 30 s on 2 cores).

    .venv/bin/python benchmarks/rig.py [--seconds 60] [--long 3600]

Builds the plant of rig_frame_battery.bdf (modes to 200 Hz), then plays a band-limited random
drive of --seconds and of --long seconds (to show that hours of drive fit: the modal
histories are made block by block); prints each step's time and the peak memory.
"""

from __future__ import annotations

import argparse
import resource
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from femcal.model.build import load_model  # noqa: E402
from femcal.rig.plant import build_plant  # noqa: E402
from femcal.rig.simulate import simulate  # noqa: E402
from femcal.testdata.points import read_points  # noqa: E402

FRAME = ROOT / "models" / "truck_frame"
DT = 1 / 512


def drive(seconds: float, rng: np.random.Generator) -> np.ndarray:
    n = round(seconds / DT)
    f = np.fft.rfftfreq(n, DT)
    phases = np.exp(2j * np.pi * rng.uniform(size=(7, len(f))))
    S = np.where((f >= 0.5) & (f <= 40), 1.0, 0.0) * phases
    d = np.fft.irfft(S, n, axis=1)
    return d * (0.5 / np.sqrt(np.mean(d**2, axis=1, keepdims=True)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--long", type=float, default=3600.0)
    args = ap.parse_args()
    rng = np.random.default_rng(25)
    rows = []
    t0 = time.perf_counter()
    plant = build_plant(load_model(FRAME / "rig_frame_battery.bdf"),
                        read_points(FRAME / "rig_frame_battery.inputs.csv"),
                        read_points(FRAME / "rig_frame_battery.sensors.csv"), modes_to=200.0)
    t_build = time.perf_counter() - t0
    rows.append((f"plant: {plant.n_modes} modes, {len(plant.outputs)} outputs", t_build))
    for seconds in (args.seconds, args.long):
        d = drive(seconds, rng)
        t0 = time.perf_counter()
        simulate(plant, d, DT)
        t = time.perf_counter() - t0
        rows.append((f"simulate {seconds:g} s ({d.shape[1]} samples)", t))
        if seconds == args.seconds:
            rows.append((f"plant + {seconds:g} s", t_build + t))
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"{'step':<40} {'seconds':>8}")
    for name, t in rows:
        print(f"{name:<40} {t:8.2f}")
    print(f"peak memory {peak:.0f} MB")


if __name__ == "__main__":
    main()
