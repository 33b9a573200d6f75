"""Time histories of a known rig (the small frame on six displacement-driven actuators) to
FRF data, as the study processed its rig test: cycle averaging, detrending, band-pass and
Welch H1, against the plant's exact frequency response."""

from __future__ import annotations

import numpy as np
import pytest

from femcal.errors import TimeDataError
from femcal.model.build import load_model
from femcal.rig.plant import build_plant
from femcal.rig.simulate import periodic_response
from femcal.testdata.estimate import FRFSettings, channel_labels, estimate_frfs
from femcal.testdata.timedata import TimeData

from .rig_decks import ACTUATORS, SENSORS, small_rig_deck

DT = 1 / 512
PERIOD = 16384  # 32 s


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    """The plant, and 6 cycles of periodic random drives and responses with 3 % noise."""
    deck = small_rig_deck(tmp_path_factory.mktemp("est") / "rig.bdf")
    plant = build_plant(load_model(deck), ACTUATORS, SENSORS, modes_to=300.0, damping=0.03)
    rng = np.random.default_rng(7)
    f = np.fft.rfftfreq(PERIOD, DT)
    lines = (f >= 1) & (f <= 120)
    S = np.zeros((len(ACTUATORS), len(f)), complex)
    S[:, lines] = np.exp(2j * np.pi * rng.uniform(size=(len(ACTUATORS), int(lines.sum()))))
    drive = np.fft.irfft(S, PERIOD, axis=1)
    cycle = periodic_response(plant, drive, DT)
    values = np.tile(cycle, (1, 6))
    values += 0.03 * values.std(axis=1, keepdims=True) * rng.standard_normal(values.shape)
    values += np.linspace(0, 1e-3, values.shape[1])  # a drift to detrend
    data = TimeData(DT, values, plant.outputs, plant.output_units)
    return plant, data


def test_h1_of_cycle_averaged_data_is_the_exact_frf(rig):
    plant, data = rig
    ins = [f"{a}:displacement" for a, _, _ in ACTUATORS]
    outs = list(data.names[12:])
    result = estimate_frfs(data, ins, outs, FRFSettings(period_s=None, segment_s=2.0,
                                                        band=(2.0, 100.0)))  # fmt: skip
    frf = result.frf
    assert frf.quantity == "accelerance" and frf.units == "mm/s^2/mm"
    assert frf.frequency_hz[0] >= 2.0 and frf.frequency_hz[-1] <= 100.0
    exact = plant.frf(frf.frequency_hz)[12:]
    strong = np.abs(exact) > 0.1 * np.abs(exact).max(axis=1, keepdims=True)
    err = np.abs(frf.H - exact) / np.abs(exact)
    assert np.median(err[strong]) < 0.03
    assert frf.coherence.shape == (len(outs), len(frf.frequency_hz))
    assert np.median(frf.coherence) > 0.95
    # averaging the 6 cycles first leaves one cycle: fewer segments, the noise down by 6^0.5
    avg = estimate_frfs(data, ins, outs, FRFSettings(period_s=32.0, segment_s=2.0,
                                                     band=(2.0, 100.0)))  # fmt: skip
    assert avg.cycles == 6 and avg.x.shape[1] == PERIOD
    assert np.median(avg.frf.coherence) > np.median(frf.coherence)


def test_force_outputs_and_mixed_units_and_bad_periods(rig):
    _, data = rig
    ins = [f"{a}:displacement" for a, _, _ in ACTUATORS]
    forces = estimate_frfs(data, ins, [f"{a}:force" for a, _, _ in ACTUATORS])
    assert forces.frf.quantity == "receptance" and forces.frf.units == "N/mm"
    with pytest.raises(TimeDataError, match="different units"):
        estimate_frfs(data, ins, ["A_z1:force", "S3:+Z"])
    with pytest.raises(TimeDataError, match="not whole cycles"):
        estimate_frfs(data, ins, ["S3:+Z"], FRFSettings(period_s=31.0))
    with pytest.raises(TimeDataError, match="whole number of samples"):
        estimate_frfs(data, ins, ["S3:+Z"], FRFSettings(period_s=1.0001))
    with pytest.raises(TimeDataError, match="no channel 'nope'"):
        estimate_frfs(data, ins, ["nope"])
    with pytest.raises(TimeDataError, match="given more than once"):
        estimate_frfs(data, ins, ins[:1])
    with pytest.raises(TimeDataError, match="longer than the averaged cycle"):
        estimate_frfs(data, ins, ["S3:+Z"], FRFSettings(period_s=32.0, segment_s=64.0))
    with pytest.raises(TimeDataError, match="estimator 'H3'"):
        FRFSettings(estimator="H3")


def test_channel_names_become_grid_labels_through_position_files(tmp_path):
    sensors = tmp_path / "s.csv"
    sensors.write_text("label,grid,x,y,z,directions\nS1,16799,0,0,0,3\nS2,55,0,0,0,123\n")
    acts = tmp_path / "a.csv"
    acts.write_text("label,grid,x,y,z,direction\nV1,17547,0,0,0,3\nX1,17559,0,0,0,-1\n")
    names = ["S1:+Z", "S2:-Y", "V1:displacement", "X1:force"]
    assert channel_labels(names) == names
    assert channel_labels(names, [sensors, acts]) == ["16799:+Z", "55:-Y", "17547:+Z",
                                                      "17559:-X"]  # fmt: skip
    with pytest.raises(TimeDataError, match="channel 'S9:\\+Z': the position files place"):
        channel_labels(["S9:+Z"], [sensors])


# ----------------------------------------------------------------------------- command line

def _rig_test_args():
    from .conftest import ROOT

    frame = ROOT / "models" / "truck_frame"
    acts = ["V_front_left", "V_front_right", "V_rear_left", "V_rear_right", "L_front",
            "L_rear", "X_rear"]  # fmt: skip
    outs = ["S_V_front_left:+Z", "S_V_front_right:+Z", "S_V_rear_left:+Z",
            "S_V_rear_right:+Z", "S_L_front:+Y", "S_L_rear:+Y", "S_X_rear:-X"]  # fmt: skip
    return frame, [f"{a}:displacement" for a in acts], outs


def test_timedata_frf_writes_labelled_frfs_with_coherence(tmp_path, capsys):
    from femcal.cli import main
    from femcal.testdata.formats import read_frf

    frame, ins, outs = _rig_test_args()
    out = tmp_path / "h1.npz"
    assert main(["timedata", "frf", str(frame / "rig_test.rsp"), "--inputs", *ins,
                 "--outputs", *outs, "--band", "0.5", "40", "--segment", "8", "--period",
                 "68", "--points", str(frame / "rig_frame.sensors.csv"),
                 str(frame / "rig_frame.inputs.csv"), "--out", str(out),
                 "--pictures", str(tmp_path / "pics")]) == 0  # fmt: skip
    text = capsys.readouterr().out
    assert "7 outputs x 7 inputs" in text and "4 cycles averaged" in text
    frf = read_frf(out)
    assert frf.outputs[0].label == "16799:+Z" and frf.inputs[-1].label == "17559:-X"
    assert frf.coherence is not None and np.median(frf.coherence) > 0.95
    assert frf.frequency_hz[0] >= 0.5 and frf.frequency_hz[-1] <= 40
    for name in ("input_psd", "singular_values", "coherence", "frf"):
        assert (tmp_path / "pics" / f"{name}.png").stat().st_size > 10_000


@pytest.mark.parametrize("extra, message", [
    (["--outputs", "nope"], "no channel 'nope'"),
    (["--outputs", "S_X_rear:-X", "--period", "67"], "not whole cycles"),
    (["--outputs", "S_X_rear:-X", "--estimator", "H7"], "estimator 'H7'"),
    (["--outputs", "S_X_rear:-X", "--out", "x.txt"], "unknown FRF file type '.txt'"),
    (["--outputs", "S_X_rear:-X", "--points", "missing.csv"], "missing.csv"),
])  # fmt: skip
def test_timedata_frf_refuses_bad_requests_in_one_line(tmp_path, capsys, extra, message):
    from femcal.cli import main

    frame, ins, _ = _rig_test_args()
    args = ["timedata", "frf", str(frame / "rig_test.rsp"), "--inputs", *ins,
            "--out", str(tmp_path / "h.npz")]  # fmt: skip
    assert main(args + extra) == 2
    err = capsys.readouterr().err
    assert message in err.strip().splitlines()[-1] and "Traceback" not in err


def test_timedata_plot_draws_time_psd_and_frf_pictures(tmp_path):
    from femcal.cli import main

    frame, ins, outs = _rig_test_args()
    assert main(["timedata", "plot", str(frame / "rig_test.rsp"), "--seconds", "5",
                 "--inputs", *ins[:2], "--outputs", *outs[:3], "--band", "0.5", "40",
                 "--out", str(tmp_path)]) == 0  # fmt: skip
    for name in ("time", "psd", "input_psd", "singular_values", "coherence", "frf"):
        assert (tmp_path / f"{name}.png").stat().st_size > 10_000
    assert main(["timedata", "plot", str(frame / "rig_test.rsp"), "--inputs", *ins[:2],
                 "--out", str(tmp_path)]) == 2  # fmt: skip


def test_resampled_channels_give_the_same_frfs_below_the_new_nyquist(rig):
    plant, data = rig
    ins = [f"{a}:displacement" for a, _, _ in ACTUATORS]
    outs = list(data.names[12:])
    settings = FRFSettings(segment_s=2.0, band=(2.0, 60.0), rate_hz=256.0)
    result = estimate_frfs(data, ins, outs, settings)
    assert result.x.shape[1] == data.n_samples // 2
    exact = plant.frf(result.frf.frequency_hz)[12:]
    strong = np.abs(exact) > 0.1 * np.abs(exact).max(axis=1, keepdims=True)
    assert np.median((np.abs(result.frf.H - exact) / np.abs(exact))[strong]) < 0.03
    with pytest.raises(TimeDataError, match="rate"):
        FRFSettings(rate_hz=-1.0)


def test_two_inputs_with_one_average_are_refused_saying_why():
    """One segment per period cannot tell two inputs apart (their cross-spectral matrix is
    of rank one at every line): said, not 'no frequency line with excitation'."""
    rng = np.random.default_rng(11)
    values = rng.standard_normal((3, 4096))
    data = TimeData(1 / 512, values, ("a", "b", "y"), ("N", "N", "mm/s^2"))
    with pytest.raises(TimeDataError, match=r"2 inputs need at least 2 averaged segments to "
                                            r"be told apart; 8 s segments"):  # fmt: skip
        estimate_frfs(data, ["a", "b"], ["y"], FRFSettings(period_s=8.0, segment_s=8.0,
                                                           overlap=0.0))  # fmt: skip


def test_every_channel_is_drawn_and_a_long_record_over_a_window_that_shows_it(tmp_path):
    """21 channels over 60 s: the time histories go on over two pictures (12 and 9 panels),
    the PSD holds every channel, and the default window is 5 s around the largest peak."""
    from femcal.viz import timedata as pictures

    rng = np.random.default_rng(3)
    dt = 1 / 256
    n = round(60 / dt)
    x = rng.standard_normal((21, n))
    x[4, 9000] = 40.0  # the record's largest peak (relative to its channel's RMS), at 35.2 s
    names = tuple(f"ch{k:02d}" for k in range(21))
    data = TimeData(dt, x, names, ("mm",) * 7 + ("N",) * 7 + ("mm/s^2",) * 7)
    start, m = pictures.time_window(data, range(21))
    assert m == round(5.0 / dt) + 1 and start <= 9000 < start + m
    assert abs((start + m // 2) - 9000) <= 1
    assert pictures.time_window(data, range(21), seconds=2.0) == (0, round(2.0 / dt) + 1)
    short = TimeData(dt, x[:, :512], names, data.units)
    assert pictures.time_window(short, range(21)) == (0, 512)
    paths = pictures.time_histories(tmp_path / "time.png", data)
    assert [p.name for p in paths] == ["time.png", "time_2.png"]
    assert all(p.stat().st_size > 10_000 for p in paths)
    fig = pictures.power_spectra(tmp_path / "psd.png", np.arange(1, 65.0), np.ones((21, 64)),
                                 names, data.units)  # fmt: skip
    curves = [line.get_label() for ax in fig.axes for line in ax.get_lines()]
    assert sorted(curves) == sorted(names)  # every channel, 7 to a unit's panel
    assert [ax.get_ylabel() for ax in fig.axes] == ["PSD (mm²/Hz)", "PSD (N²/Hz)",
                                                    "PSD ((mm/s^2)²/Hz)"]  # fmt: skip
