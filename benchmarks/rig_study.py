"""The study's question on the virtual rig: do the hammer-test calibration's parameters make the
battery-box rig frame a better stand-in for the physical rig than the nominal ones?

    make demo                                      # out/report.json: the calibrated values
    .venv/bin/python benchmarks/rig_study.py [--report out/report.json] [--out DIR]

The "physical rig" is the battery-box rig frame as the synthetic tests' hidden frame: the
hammer test's hidden values (models/truck_frame/hammer_test.truth.toml), the cross support
the model lacks (grounded CELAS2 springs) and 1.2 % damping. A road-like drive (0.5-40 Hz,
amplitude falling as 1 / f above 2 Hz, 0.5 mm RMS, 60 s looped) played on it gives the
target: the 7 accelerometers next to the actuators (controlled) and the battery box's
triaxial one (not controlled). Then ``femcal rig compare`` iterates each model on itself
(nominal deck; nominal deck with the calibrated values; the hidden frame itself, the floor)
and compares its drives with the physical rig's and its battery-box prediction with the
measured one. Every step is a femcal command, printed as it runs.
"""

from __future__ import annotations

import argparse
import shlex
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from femcal.calibrate.parameters import read_parameters  # noqa: E402
from femcal.io.calibration import write_calibrated_deck  # noqa: E402
from femcal.model.build import load_model  # noqa: E402
from femcal.testdata.formats import write_time_data  # noqa: E402
from femcal.testdata.timedata import TimeData  # noqa: E402

FRAME = ROOT / "models" / "truck_frame"
FEMCAL = [sys.executable, "-m", "femcal"]
LABELS = ("V_front_left", "V_front_right", "V_rear_left", "V_rear_right", "L_front",
          "L_rear", "X_rear")  # fmt: skip
CONTROL = ("S_V_front_left:+Z", "S_V_front_right:+Z", "S_V_rear_left:+Z",
           "S_V_rear_right:+Z", "S_L_front:+Y", "S_L_rear:+Y", "S_X_rear:-X")  # fmt: skip
DT = 1 / 512


def truth_deck(path: Path) -> Path:
    """rig_frame_battery.bdf with the hammer test's hidden values and the cross support as
    grounded CELAS2 springs about X and Z at the rail webs' mid-height grids."""
    with open(FRAME / "hammer_test.truth.toml", "rb") as fh:
        truth = tomllib.load(fh)
    deck = FRAME / "rig_frame_battery.bdf"
    model = load_model(deck)
    params = read_parameters(FRAME / "hammer_frame.params.toml", model)
    hidden = {p["name"]: p["true"] for p in truth["parameter"]}
    write_calibrated_deck(deck, params, np.array([hidden[p.name] for p in params]), path)
    springs = []
    for k, side in enumerate((1.0, -1.0)):
        target = np.array([truth["support_x_mm"], side * 430.0, 0.0])
        node = int(np.argmin(np.linalg.norm(model.xyz - target, axis=1)))
        grid = int(model.node_ids[node])
        for j, comp in enumerate((4, 6)):
            springs.append(f"CELAS2,{990001 + 2 * k + j},{truth['support_stiffness_nmm_per_rad']}"
                           f",{grid},{comp}")
    text = path.read_text().replace("ENDDATA", "\n".join(springs) + "\nENDDATA")
    path.write_text(text)
    return path


def road_drive(seconds: float, seed: int = 7) -> np.ndarray:
    rng = np.random.default_rng(seed)
    n = round(seconds / DT)
    f = np.fft.rfftfreq(n, DT)
    band = (f >= 0.5) & (f <= 40.0)
    S = np.zeros((len(LABELS), len(f)), complex)
    S[:, band] = np.exp(2j * np.pi * rng.uniform(size=(len(LABELS), int(band.sum()))))
    S[:, band] /= np.maximum(f[band], 2.0)
    d = np.fft.irfft(S, n, axis=1)
    return d * (0.5 / np.sqrt(np.mean(d**2, axis=1, keepdims=True)))


def femcal(*args: str) -> None:
    print("$ femcal " + " ".join(shlex.quote(a) for a in args), flush=True)
    subprocess.run([*FEMCAL, *args], check=True, cwd=ROOT)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--report", type=Path, default=ROOT / "out" / "report.json",
                    help="the hammer calibration's report (make demo writes out/report.json)")
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "_work" / "rig_study")
    ap.add_argument("--seconds", type=float, default=60.0)
    args = ap.parse_args()
    if not args.report.is_file():
        sys.exit(f"{args.report}: no calibration report; run `make demo` first")
    out = args.out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    truth = truth_deck(out / "physical_rig.bdf")
    write_time_data(out / "road_drive.rsp",
                    TimeData(DT, road_drive(args.seconds), LABELS, ("mm",) * len(LABELS)))
    rig = ["--actuators", str(FRAME / "rig_frame_battery.inputs.csv"),
           "--sensors", str(FRAME / "rig_frame_battery.sensors.csv")]  # fmt: skip
    femcal("rig", "simulate", str(truth), *rig, "--damping", "0.012", "--periodic",
           "--drive", str(out / "road_drive.rsp"), "--out", str(out / "measured.rsp"))
    femcal("rig", "compare", "--model", f"nominal={FRAME / 'rig_frame_battery.bdf'}",
           "--model", f"calibrated={FRAME / 'rig_frame_battery.bdf'}",
           "--values", f"calibrated={args.report}",
           "--params", str(FRAME / "hammer_frame.params.toml"),
           "--model", f"hidden={truth}", *rig, "--target", str(out / "measured.rsp"),
           "--control", *CONTROL, "--reference-drive", str(out / "road_drive.rsp"),
           "--out", str(out / "compare"))  # fmt: skip


if __name__ == "__main__":
    main()
