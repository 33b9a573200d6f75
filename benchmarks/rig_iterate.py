"""Drive iteration on the battery-box rig frame with a 272 s target (the length of the shipped
rig test: 4 cycles of 68 s at 512 Hz), as issue 39 asks: how long it takes and what it finds.

    .venv/bin/python benchmarks/rig_iterate.py [--seconds 272] [--noise 0.03]
    .venv/bin/python benchmarks/rig_iterate.py --sweep

The "physical rig" is rig_frame_battery.bdf with the hammer test's hidden values, the cross
support the model lacks and 1.2 % damping; the model is the nominal deck with 2 %. A
band-limited random drive (1 mm RMS, 0.5-30 Hz) played on the physical rig makes the target
at the 7 control accelerometers, then with --noise white noise of that fraction of each
channel's RMS. The iteration (8 corrections) inverts the model's FRF, then the FRF measured
on the physical rig. Prints each step's time, the peak memory, and what the drive found
is: its difference from the played one in 1-30 Hz, its level there, its RMS, and the
response's in-band error against the noise-free target.

--sweep runs the model's FRF over five seeds x 8 s and 32 s records x noise 0 and 3 % x a
flat and a road-like drive (amplitude falling as 1/f above 2 Hz) and prints the worst of
each figure.
"""

from __future__ import annotations

import argparse
import resource
import sys
import time
import tomllib
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from femcal.assembly import Options, assemble  # noqa: E402
from femcal.jobs.synthetic_test import hidden_values, with_cross_support  # noqa: E402
from femcal.model.build import load_model  # noqa: E402
from femcal.rig.iterate import (  # noqa: E402
    IterationSettings,
    frf_on_lines,
    iterate_drive,
    measured_frf,
)
from femcal.rig.plant import build_plant  # noqa: E402
from femcal.rig.simulate import simulate  # noqa: E402
from femcal.testdata.points import read_points  # noqa: E402

FRAME = ROOT / "models" / "truck_frame"
CONTROL = ("S_V_front_left:+Z", "S_V_front_right:+Z", "S_V_rear_left:+Z",
           "S_V_rear_right:+Z", "S_L_front:+Y", "S_L_rear:+Y", "S_X_rear:-X")  # fmt: skip
DT = 1 / 512


def plants():
    deck = FRAME / "rig_frame_battery.bdf"
    actuators = read_points(FRAME / "rig_frame_battery.inputs.csv")
    sensors = read_points(FRAME / "rig_frame_battery.sensors.csv")
    model = build_plant(load_model(deck), actuators, sensors, modes_to=200.0, damping=0.02)
    with open(FRAME / "hammer_test.truth.toml", "rb") as fh:
        truth = tomllib.load(fh)
    given = {p["name"]: p["true"] for p in truth["parameter"]}
    frame, _ = hidden_values(load_model(deck), FRAME / "hammer_frame.params.toml", 0.0,
                             np.random.default_rng(0), given)  # fmt: skip
    mats = with_cross_support(frame, assemble(frame, Options()), truth["support_x_mm"],
                              truth["support_stiffness_nmm_per_rad"])  # fmt: skip
    physical = build_plant(frame, actuators, sensors, modes_to=200.0, matrices=mats,
                           damping=0.012)  # fmt: skip
    return model, physical


def random_drive(n: int, rng: np.random.Generator, road: bool = False) -> np.ndarray:
    """(7, n) band-limited random drives, 0.5-30 Hz, 1 mm RMS (road: amplitude 1/f above
    2 Hz)."""
    f = np.fft.rfftfreq(n, DT)
    lines = (f >= 0.5) & (f <= 30.0)
    S = np.zeros((7, len(f)), complex)
    S[:, lines] = np.exp(2j * np.pi * rng.uniform(size=(7, int(lines.sum()))))
    if road:
        S[:, lines] /= np.maximum(f[lines], 2.0)
    played = np.fft.irfft(S, n, axis=1)
    return played / np.sqrt(np.mean(played**2, axis=1, keepdims=True))


def figures(it, played: np.ndarray, clean: np.ndarray, control) -> tuple[float, ...]:
    """(drive - played in 1-30 Hz, level off there, RMS ratio, response in band), worst."""
    n = played.shape[1]
    f = np.fft.rfftfreq(n, DT)
    band, lines = (f >= 1.0) & (f <= 30.0), (f >= 0.5) & (f <= 30.0)
    P, D = np.fft.rfft(played, axis=1), np.fft.rfft(it.drive, axis=1)
    size = np.linalg.norm(P[:, band], axis=1)
    diff = np.linalg.norm(D[:, band] - P[:, band], axis=1) / size
    level = np.linalg.norm(D[:, band], axis=1) / size
    R, T = np.fft.rfft(it.response[control], axis=1), np.fft.rfft(clean, axis=1)
    resp = np.linalg.norm(R[:, lines] - T[:, lines], axis=1) / np.linalg.norm(T[:, lines],
                                                                              axis=1)
    rms = np.sqrt(np.mean(it.drive**2, axis=1) / np.mean(played**2, axis=1))
    return diff.max(), np.abs(level - 1).max(), rms.max(), resp.max()


def sweep(model, physical, control) -> None:
    print("record  noise  drive   worst: drive - played %  level off %  RMS ratio  response %")
    for seconds in (8.0, 32.0):
        for noise in (0.0, 0.03):
            for road in (False, True):
                worst = np.zeros(4)
                for seed in range(11, 16):
                    rng = np.random.default_rng(seed)
                    played = random_drive(round(seconds / DT), rng, road)
                    clean = simulate(physical, played, DT, periodic=True)[control]
                    size = np.sqrt(np.mean(clean**2, axis=1, keepdims=True))
                    target = clean + noise * size * rng.standard_normal(clean.shape)
                    n = played.shape[1]
                    H = frf_on_lines(model, control, n, DT, (0.5, 40.0))
                    it = iterate_drive(physical, H, target, control, DT,
                                       IterationSettings(iterations=8))  # fmt: skip
                    worst = np.maximum(worst, figures(it, played, clean, control))
                print(f"{seconds:5.0f} s {100 * noise:5.0f} % {'road' if road else 'flat':>5} "
                      f"{100 * worst[0]:27.1f} {100 * worst[1]:12.1f} {worst[2]:10.3f} "
                      f"{100 * worst[3]:11.2f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=272.0)
    ap.add_argument("--noise", type=float, default=0.0)
    ap.add_argument("--sweep", action="store_true")
    args = ap.parse_args()
    if args.sweep:
        model, physical = plants()
        sweep(model, physical, [model.outputs.index(c) for c in CONTROL])
        return
    rows = []
    t0 = time.perf_counter()
    model, physical = plants()
    rows.append(("two plants (nominal and physical; 21 modes each)", time.perf_counter() - t0))
    control = [model.outputs.index(c) for c in CONTROL]
    n = round(args.seconds / DT)
    rng = np.random.default_rng(39)
    played = random_drive(n, rng)
    t0 = time.perf_counter()
    clean = simulate(physical, played, DT, periodic=True)[control]
    rows.append((f"target: {args.seconds:g} s ({n} samples) played on the physical rig",
                 time.perf_counter() - t0))  # fmt: skip
    size = np.sqrt(np.mean(clean**2, axis=1, keepdims=True))
    target = clean + args.noise * size * rng.standard_normal(clean.shape)
    settings = IterationSettings(iterations=8)
    found = []
    for how in ("model", "measured"):
        t0 = time.perf_counter()
        H = (frf_on_lines(model, control, n, DT, settings.band) if how == "model"
             else measured_frf(physical, control, n, DT, settings.band))  # fmt: skip
        rows.append((f"FRF: {how}", time.perf_counter() - t0))
        t0 = time.perf_counter()
        it = iterate_drive(physical, H, target, control, DT, settings)
        rows.append((f"iterate, {how} FRF: first drive + 8 corrections",
                     time.perf_counter() - t0))  # fmt: skip
        found.append((how, *figures(it, played, clean, control)))
    width = max(len(r[0]) for r in rows)
    print(f"{'step':<{width}}  seconds")
    for name, t in rows:
        print(f"{name:<{width}}  {t:7.2f}")
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20
    print(f"peak memory {peak:.2f} GB")
    print(f"\nnoise on the target: {100 * args.noise:g} % of each channel's RMS")
    print("FRF       drive - played, 1-30 Hz (worst %)  level off (worst %)  RMS / played "
          "(worst)  response in band (worst %)")
    for how, diff, level, rms, resp in found:
        print(f"{how:<9} {100 * diff:34.1f} {100 * level:20.1f} {rms:22.3f} {100 * resp:27.2f}")


if __name__ == "__main__":
    main()
