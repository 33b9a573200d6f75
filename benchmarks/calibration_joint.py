"""Issue 22's way forward, measured: calibrate the hammer frame and the rig frame together, the
hammer test and a rig test of the same hidden frame, and check the result as
calibration_trust.py checks the hammer calibration alone.

    .venv/bin/python benchmarks/calibration_joint.py --tests ship        # ~15 min on 2 cores
    .venv/bin/python benchmarks/calibration_joint.py --tests s11_x2825 s5_x600

For each hidden test (calibration_trust.TESTS): its hammer test; a synthetic rig test of the
same hidden frame (`femcal synth-rig-test --truth`, the rig frame with the same hidden values
and cross support: 4 periods of 68 s); its H1 FRFs per column force (`femcal timedata frf
--per-force`, 16 s segments, 0.5-40 Hz); a configuration file with both configurations (the
rig's parameter file is the hammer frame's without its bellows mounts, which the rig frame
lacks); `femcal calibrate`. Then the rig check (the calibrated values in rig_frame.bdf against
the hidden values', modes below 100 Hz), the identifiable parameters closer to their hidden
values, and each configuration's test modes closer, beside the hammer-only calibration's
figures when calibration_trust.py has them (benchmarks/_work/trust/trust.json).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT / "src"))

from calibration_trust import FRAME, TESTS, WORK, Rig, hidden_test  # noqa: E402

JOINT = ROOT / "benchmarks" / "_work" / "joint"
ACTS = ["V_front_left", "V_front_right", "V_rear_left", "V_rear_right", "L_front", "L_rear",
        "X_rear"]  # fmt: skip
SENSORS = ["S_V_front_left:+Z", "S_V_front_right:+Z", "S_V_rear_left:+Z",
           "S_V_rear_right:+Z", "S_L_front:+Y", "S_L_rear:+Y", "S_X_rear:-X"]  # fmt: skip


def femcal(*args: str) -> None:
    subprocess.run([sys.executable, "-m", "femcal", *args], check=True, cwd=ROOT)


def rig_params(path: Path) -> Path:
    """The hammer frame's parameters without those no element of the rig frame uses."""
    import femcal as fc
    from femcal.calibrate.derivatives import affected_elements
    from femcal.calibrate.parameters import read_parameters

    model = fc.load_model(FRAME / "rig_frame.bdf")
    used = {p.name for p in read_parameters(FRAME / "hammer_frame.params.toml", model)
            if affected_elements(model, p)}  # fmt: skip
    text = (FRAME / "hammer_frame.params.toml").read_text()
    head, *blocks = text.split("\n[[parameter]]")
    keep = [b for b in blocks if b.split('name = "', 1)[1].split('"', 1)[0] in used]
    path.write_text(head + "".join("\n[[parameter]]" + b for b in keep))
    return path


def configuration(name: str, uff: Path, truth: Path, rig_frf: Path, params: Path) -> Path:
    text = f"""[[configuration]]
name = "hammer"
deck = "{FRAME / 'hammer_frame.bdf'}"
parameters = "{FRAME / 'hammer_frame.params.toml'}"
units = "mm/s^2/N"
frf = "{uff}"
truth = "{truth}"
sensors = "{FRAME / 'hammer_frame.sensors.csv'}"
inputs = "{FRAME / 'hammer_frame.inputs.csv'}"
band = [10.0, 100.0]

[configuration.identify]
band = [10.0, 120.0]
splits = [50.0, 80.0]

[[configuration]]
name = "rig"
deck = "{FRAME / 'rig_frame.bdf'}"
parameters = "{params}"
units = "mm/s^2/N"
frf = "{rig_frf}"
truth = "{truth}"
sensors = "{FRAME / 'rig_frame.sensors.csv'}"
inputs = "{FRAME / 'rig_frame.inputs.csv'}"
band = [10.0, 39.0]

[configuration.identify]
band = [2.0, 39.0]
splits = [25.0]

[calibration]
zeta0 = "median"
metric = "complex-log"
reduction_modes = 100
enrich_hz = 0.0
starts = 24
workers = 2
seed = 1
max_iterations = 30
max_cycles = 10
settle = 2e-3
crlb_bands = [[10.0, 40.0], [40.0, 100.0]]

[output]
pictures = false
"""
    path = JOINT / f"{name}.toml"
    path.write_text(text)
    return path


def check(name: str, rig: Rig) -> dict:
    from femcal.calibrate.parameters import read_truth

    uff, truth_file = hidden_test(name)
    JOINT.mkdir(parents=True, exist_ok=True)
    rsp = JOINT / f"{name}_rig.rsp"
    if not rsp.is_file():
        femcal("synth-rig-test", str(FRAME / "rig_frame.bdf"), "--params",
               str(FRAME / "hammer_frame.params.toml"), "--actuators",
               str(FRAME / "rig_frame.inputs.csv"), "--sensors",
               str(FRAME / "rig_frame.sensors.csv"), "--truth", str(truth_file), "--period",
               "68", "--cycles", "4", "--out", str(JOINT), "--name", f"{name}_rig")  # fmt: skip
    rig_frf = JOINT / f"{name}_rig_frf.npz"
    femcal("timedata", "frf", str(rsp), "--inputs", *[f"{a}:displacement" for a in ACTS],
           "--outputs", *SENSORS, "--segment", "16", "--band", "0.5", "40", "--points",
           str(FRAME / "rig_frame.sensors.csv"), str(FRAME / "rig_frame.inputs.csv"),
           "--per-force", str(FRAME / "rig_frame.bdf"), "--out", str(rig_frf))  # fmt: skip
    params = rig_params(JOINT / "rig_frame.params.toml")
    cfg = configuration(name, uff, truth_file, rig_frf, params)
    out = JOINT / name
    femcal("calibrate", str(cfg), "--out", str(out), "--fresh")
    rep = json.loads((out / "report.json").read_text())
    truth = read_truth(truth_file, rig.params)
    nominal = np.array([q.nominal for q in rig.params])
    by_name = {p["name"]: p for p in rep["parameters"]}
    values = np.array([by_name[q.name]["calibrated"] for q in rig.params])
    ident = np.array([by_name[q.name]["identifiable"] for q in rig.params])
    p_true, p_cal = truth / nominal - 1, values / nominal - 1
    closer = np.abs(p_cal - p_true) < np.abs(p_true)
    e_nom, e_cal = rig.errors(nominal, truth), rig.errors(values, truth)
    modes = {c["name"]: [abs(m["frequency_error_after_pct"]) < abs(m["frequency_error_before_pct"])
                         for m in c.get("modes", []) if m.get("frequency_error_after_pct")
                         is not None] for c in rep["configurations"]}  # fmt: skip
    return {"name": name, "rig_nominal": (float(e_nom.mean()), float(e_nom.max())),
            "rig_calibrated": (float(e_cal.mean()), float(e_cal.max())),
            "identifiable": [q.name for q, i in zip(rig.params, ident, strict=True) if i],
            "identifiable_closer": int(closer[ident].sum()), "n_identifiable": int(ident.sum()),
            "modes_closer": {k: (sum(v), len(v)) for k, v in modes.items()},
            "deviation": (rep["deviation"]["before"], rep["deviation"]["after"])}  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tests", nargs="+", default=["ship"], choices=list(TESTS))
    args = ap.parse_args()
    rig = Rig()
    alone = {}
    trust = WORK / "trust.json"
    if trust.is_file():
        alone = {r["name"]: r for r in json.loads(trust.read_text())}
    print("| hidden test | rig mean / worst %: nominal | hammer alone | hammer + rig | "
          "identifiable closer: alone | joint | test modes closer (joint) |")
    print("|---|---|---|---|---|---|---|")
    for name in args.tests:
        r = check(name, rig)
        a = alone.get(name)
        alone_rig = (f"{a['rig_calibrated'][0]:.3f} / {a['rig_calibrated'][1]:.3f}" if a
                     else "-")  # fmt: skip
        alone_id = f"{a['identifiable_closer']}/{a['n_identifiable']}" if a else "-"
        modes = ", ".join(f"{k} {c}/{n}" for k, (c, n) in r["modes_closer"].items())
        print(f"| {name} | {r['rig_nominal'][0]:.3f} / {r['rig_nominal'][1]:.3f} | {alone_rig} "
              f"| {r['rig_calibrated'][0]:.3f} / {r['rig_calibrated'][1]:.3f} | {alone_id} | "
              f"{r['identifiable_closer']}/{r['n_identifiable']} ({', '.join(r['identifiable'])})"
              f" | {modes} |", flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
