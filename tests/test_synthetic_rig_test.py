"""The synthetic rig test: its time histories, processed as the study did, give the rig
frame's FRFs as ``femcal frf`` computes them, and its files read back."""

from __future__ import annotations

import numpy as np
import pytest

from femcal.cli import main
from femcal.jobs.synthetic_rig_test import RigTestSettings, make_rig_test, read_truth
from femcal.testdata.formats import read_frf
from femcal.testdata.formats.rpc3 import read_rpc3
from femcal.testdata.points import read_points
from femcal.testdata.signal import frf

from .conftest import ROOT

FRAME = ROOT / "models" / "truck_frame"
DECK, PARAMS = FRAME / "rig_frame.bdf", FRAME / "hammer_frame.params.toml"
ACTUATORS, SENSORS = FRAME / "rig_frame.inputs.csv", FRAME / "rig_frame.sensors.csv"


@pytest.fixture(scope="module")
def nominal_test():
    """The deck itself on the rig: no hidden values, no cross support, 2 % damping."""
    settings = RigTestSettings(spread=0.0, support_stiffness=0.0, damping=(0.02, 0.02),
                               period_s=32.0, cycles=8, noise=0.02)  # fmt: skip
    return make_rig_test(DECK, PARAMS, ACTUATORS, SENSORS, settings)


def test_channels_are_the_studys(nominal_test):
    d = nominal_test.data
    acts = [lab for lab, _, _ in read_points(ACTUATORS)]
    assert d.names[:7] == tuple(f"{a}:displacement" for a in acts)
    assert d.names[7:14] == tuple(f"{a}:force" for a in acts)
    assert d.names[14:] == ("S_V_front_left:+Z", "S_V_front_right:+Z", "S_V_rear_left:+Z",
                            "S_V_rear_right:+Z", "S_L_front:+Y", "S_L_rear:+Y",
                            "S_X_rear:-X")  # fmt: skip
    assert d.units[:14] == ("mm",) * 7 + ("N",) * 7 and set(d.units[14:]) == {"mm/s^2"}
    assert d.n_samples == 8 * 32 * 512
    # the drives are periodic: every cycle of the LVDTs is the drive plus noise
    cycles = d.values[:7].reshape(7, 8, -1)
    noise = cycles - nominal_test.drive[:, None, :]
    assert np.allclose(noise.std(axis=(1, 2)), 0.02 * 0.2, rtol=0.05)


def test_h1_of_the_rig_test_is_the_rig_frames_frf(nominal_test, tmp_path):
    """H1 of the accelerations on the actuator displacements, against ``femcal frf`` of the
    deck with a force at each actuator's frame grid: moving a column's grounded end by s
    loads the frame with k s, so H1 = k x accelerance."""
    d = nominal_test.data
    est = frf(d.values[:7], d.values[14:], d.dt, segment=4096, estimator="H1")
    f = est.frequency_hz
    lines = np.flatnonzero((f >= 2.0) & (f <= 38.0))
    out = tmp_path / "rig.npz"
    sensors = read_points(SENSORS)
    acts = read_points(ACTUATORS)
    args = ["frf", str(DECK), "--freq", f"{f[lines[0]]}:{f[lines[-1]] + 1e-6}:{f[1]}",
            "--damping", "0.02", "--quantity", "accelerance", "--residual",
            "--modes-to", "200", "--out", str(out)]  # fmt: skip
    for _, g, c in acts:
        args += ["--input", f"{g}:{abs(c)}"]
    for _, g, c in sensors:
        args += ["--output", f"{g}:{abs(c)}"]
    assert main(args) == 0
    ref = read_frf(out).H  # per N, in the grids' +axes
    k = np.array([a.stiffness for a in nominal_test.plant.actuators])
    sign_in = np.sign([c for _, _, c in acts])
    sign_out = np.sign([c for _, _, c in sensors])
    expected = ref * (k * sign_in)[None, :, None] * sign_out[:, None, None]
    H = est.H[:, :, lines]
    assert np.allclose(f[lines], read_frf(out).frequency_hz)
    coherent = est.multiple_coherence[:, lines] > 0.95
    err = np.abs(H - expected) / np.abs(expected).max(axis=1, keepdims=True)
    good = np.broadcast_to(coherent[:, None, :], err.shape)
    assert coherent.mean() > 0.7
    assert np.median(err[good]) < 0.05
    # and the diagonal (each sensor on its own actuator) closely
    diag = np.abs(H[np.arange(7), np.arange(7)] - expected[np.arange(7), np.arange(7)])
    diag /= np.abs(expected[np.arange(7), np.arange(7)])
    assert np.median(diag[coherent]) < 0.05


def test_truth_file_gives_the_hidden_values(tmp_path):
    truth = tmp_path / "t.toml"
    truth.write_text('support_x_mm = 2000.0\n[[parameter]]\nname = "p1"\ntrue = 7.5\n')
    values, settings = read_truth(truth)
    assert values == {"p1": 7.5} and settings == {"support_x_mm": 2000.0}
    with pytest.raises(ValueError, match="'p2' has no hidden value"):
        make_rig_test(DECK, PARAMS, ACTUATORS, SENSORS, truth_path=truth)
    truth.write_text('[[parameter]]\nname = "p1"\ntrue = "x"\n')
    with pytest.raises(ValueError, match=r"\[\[parameter\]\] 1: expected a name and a numeric"):
        read_truth(truth)


@pytest.mark.parametrize("kwargs, message", [
    ({"period_s": 0.01}, "period_s"),
    ({"drive_band": (30.0, 10.0)}, "drive_band"),
    ({"drive_band": (1.0, 300.0)}, "Nyquist"),
    ({"cycles": 0}, "cycles"),
    ({"noise": -1.0}, "noise"),
])  # fmt: skip
def test_bad_settings_are_named(kwargs, message):
    with pytest.raises(ValueError, match=message):
        RigTestSettings(**kwargs)


def test_command_writes_rpc_files_that_read_back(tmp_path, capsys):
    out = tmp_path / "rig"
    assert main(["synth-rig-test", str(DECK), "--params", str(PARAMS), "--actuators",
                 str(ACTUATORS), "--sensors", str(SENSORS), "--period", "4", "--cycles", "2",
                 "--out", str(out)]) == 0  # fmt: skip
    data = read_rpc3(out / "rig_test.rsp")
    drive = read_rpc3(out / "rig_test.drv")
    assert data.n_channels == 21 and data.n_samples == 2 * 4 * 512
    assert drive.n_channels == 7 and drive.n_samples == 4 * 512
    # 16-bit integers: within half a step of the drive's peak / 32767
    step = np.abs(drive.values).max(axis=1, keepdims=True) / 32767
    first = data.values[:7, : drive.n_samples]
    assert (np.abs(first - drive.values) < 0.02 * 0.2 * 6 + step).all()  # noise 2 % of RMS
    values, _ = read_truth(out / "rig_test.truth.toml")
    assert len(values) == 30
    # the console says what the hidden frame has that the deck lacks
    said = capsys.readouterr().out
    assert "the hidden frame: 30 parameters drawn within 50 % of their bounds" in said
    assert "a cross support the deck lacks, 2e+08 N mm/rad about X and Z at each rail at " \
           "x = 2475 mm" in said
    assert main(["synth-rig-test", str(DECK), "--params", str(PARAMS), "--actuators",
                 str(ACTUATORS), "--sensors", str(SENSORS), "--period", "0.001",
                 "--out", str(out)]) == 2  # fmt: skip
    assert "period_s = 0.001: expected a positive period" in capsys.readouterr().err


def test_sensor_files_give_triaxial_or_one_signed_direction(tmp_path):
    path = tmp_path / "s.csv"
    path.write_text("label,grid,x,y,z,directions\nA,1,0,0,0,123\nB,2,0,0,0,-1\nC,3,0,0,0,2\n")
    assert read_points(path) == [("A", 1, 1), ("A", 1, 2), ("A", 1, 3), ("B", 2, -1),
                                 ("C", 3, 2)]  # fmt: skip
    path.write_text("label,grid,x,y,z,directions\nB,2,0,0,0,-12\n")
    with pytest.raises(ValueError, match=r"s.csv:2: directions '-12': expected codes 1-6"):
        read_points(path)


SHIPPED = FRAME / "rig_test.rsp"


def test_the_shipped_rig_test_is_what_its_command_makes():
    from femcal.jobs.synthetic_rig_test import read_truth

    shipped = read_rpc3(SHIPPED)
    assert SHIPPED.stat().st_size < 10e6
    _, made = read_truth(FRAME / "rig_test.truth.toml")
    settings = RigTestSettings(period_s=68.0, cycles=4)
    again = make_rig_test(DECK, PARAMS, ACTUATORS, SENSORS, settings,
                          truth_path=FRAME / "hammer_test.truth.toml")  # fmt: skip
    assert shipped.names == again.data.names and shipped.units == again.data.units
    step = np.abs(again.data.values).max(axis=1, keepdims=True) / 32767  # 16-bit storage
    # each sample rounds to the code nearest the simulation; a simulation that differs in
    # the last digits (another BLAS, the eigensolver's rounding) may put a sample that lay
    # half-way onto the neighbouring code: within one code always, within half of it nearly
    # always
    off = np.abs(shipped.values - again.data.values)
    assert (off <= step * (1 + 1e-6)).all()
    assert (off <= 0.5 * step * (1 + 1e-6)).mean() > 0.9999
    assert made["support_x_mm"] == again.support_x
    # its H1 FRFs are the hidden frame's where the coherence is high
    from femcal.testdata.estimate import FRFSettings, estimate_frfs

    result = estimate_frfs(shipped, list(shipped.names[:7]), list(shipped.names[14:]),
                           FRFSettings(segment_s=8.0, band=(0.5, 40.0)))  # fmt: skip
    f = result.frf.frequency_hz
    exact = again.plant.frf(f)[14:]
    good = np.broadcast_to((result.frf.coherence > 0.95)[:, None, :], exact.shape)
    err = np.abs(result.frf.H - exact) / np.abs(exact).max(axis=1, keepdims=True)
    assert good.mean() > 0.6 and np.median(err[good]) < 0.03


def test_identification_of_the_shipped_rig_test_finds_the_rig_frames_modes(tmp_path):
    """H1 of the 7 accelerations on the 7 actuator displacements (16 s segments), identified
    in two parts: every mode of the hidden frame in 2-39 Hz within 0.5 %."""
    import json
    import tomllib

    from femcal.testdata.estimate import FRFSettings, estimate_frfs
    from femcal.testdata.formats import write_frf

    data = read_rpc3(SHIPPED)
    result = estimate_frfs(data, list(data.names[:7]), list(data.names[14:]),
                           FRFSettings(segment_s=16.0, band=(0.5, 40.0)),
                           points=[SENSORS, ACTUATORS])  # fmt: skip
    assert [c.label for c in result.frf.inputs][-1] == "17559:-X"
    npz = write_frf(tmp_path / "rig_h1.npz", result.frf)
    summary = tmp_path / "identify.json"
    assert main(["identify", str(npz), "--band", "2", "39", "--split", "25", "--json",
                 str(summary)]) == 0  # fmt: skip
    found = np.array([p["frequency_hz"] for p in json.loads(summary.read_text())["poles"]])
    with open(FRAME / "rig_test.truth.toml", "rb") as fh:
        truth = np.array(tomllib.load(fh)["modes"]["frequency_hz"])
    for f in truth[(truth > 2) & (truth < 39)]:
        assert np.abs(found / f - 1).min() < 0.005, (f, found)


def test_frfs_per_column_force_are_the_decks_force_frfs(nominal_test, tmp_path):
    """timedata frf --per-force: H1 on the actuator displacements over each oil column's
    stiffness is the deck's accelerance per newton at the actuators' frame grids, labelled
    as femcal frf and the calibration label them."""
    from femcal.testdata.formats import write_time_data

    write_time_data(tmp_path / "rig.rsp", nominal_test.data)
    acts = [f"{lab}:displacement" for lab, _, _ in read_points(ACTUATORS)]
    sensors = list(nominal_test.data.names[14:])
    out = tmp_path / "per_force.npz"
    assert main(["timedata", "frf", str(tmp_path / "rig.rsp"), "--inputs", *acts,
                 "--outputs", *sensors, "--segment", "8", "--band", "2", "38", "--points",
                 str(SENSORS), str(ACTUATORS), "--per-force", str(DECK), "--out",
                 str(out)]) == 0  # fmt: skip
    data = read_frf(out)
    assert data.units == "mm/s^2/N" and data.quantity == "accelerance"
    assert data.inputs[0].label == "17547:+Z"
    ref = tmp_path / "ref.npz"
    f = data.frequency_hz
    args = ["frf", str(DECK), "--freq", f"{f[0]}:{f[-1] + 1e-6}:{f[1] - f[0]}", "--damping",
            "0.02", "--quantity", "accelerance", "--residual", "--modes-to", "200", "--out",
            str(ref)]  # fmt: skip
    for _, g, c in read_points(ACTUATORS):
        args += ["--input", f"{g}:{abs(c)}"]
    for _, g, c in read_points(SENSORS):
        args += ["--output", f"{g}:{abs(c)}"]
    assert main(args) == 0
    signs_in = np.sign([c for _, _, c in read_points(ACTUATORS)])
    signs_out = np.sign([c for _, _, c in read_points(SENSORS)])
    expected = read_frf(ref).H * signs_in[None, :, None] * signs_out[:, None, None]
    good = np.broadcast_to((data.coherence > 0.95)[:, None, :], expected.shape)
    err = np.abs(data.H - expected) / np.abs(expected).max(axis=1, keepdims=True)
    assert np.median(err[good]) < 0.05
