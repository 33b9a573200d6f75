"""The shipped synthetic hammer test: its layout, its truth, and that it shows the modes."""

from __future__ import annotations

import csv
import re
import tomllib

import numpy as np
import pytest

from femcal.jobs.synthetic_test import make_hammer_test
from femcal.testdata.formats.matlab import read_mat
from femcal.testdata.formats.uff import read_uff

from .conftest import ROOT

FRAME = ROOT / "models" / "truck_frame"


@pytest.fixture(scope="module")
def shipped():
    return read_mat(FRAME / "hammer_test.mat"), tomllib.loads(
        (FRAME / "hammer_test.truth.toml").read_text()
    )


def test_shipped_set_is_72_outputs_by_2_inputs_at_0_05_hz(shipped):
    data, _ = shipped
    assert data.H.shape == (72, 2, 3000) and data.quantity == "accelerance"
    assert np.allclose(data.frequency_hz, 0.05 * np.arange(1, 3001))
    with open(FRAME / "hammer_frame.sensors.csv", newline="") as fh:
        grids = [int(r["grid"]) for r in csv.DictReader(fh)]
    assert [c.label for c in data.outputs] == [f"{g}:+{a}" for g in grids for a in "XYZ"]
    assert [c.direction for c in data.inputs] == ["+Y", "+Z"]
    uff = read_uff(FRAME / "hammer_test.uff")  # the same numbers in the universal file
    assert np.array_equal(uff.H, data.H)
    assert [(c.grid, c.direction) for c in uff.outputs[:3]] == [(grids[0], d) for d in "123"]


def test_truth_lists_the_hidden_parameters_within_their_bounds(shipped):
    _, truth = shipped
    params = tomllib.loads((FRAME / "hammer_frame.params.toml").read_text())["parameter"]
    hidden = {p["name"]: p for p in truth["parameter"]}
    assert len(hidden) == 30
    for p in params:
        t = hidden[p["name"]]["true"]
        assert p["lower"] <= t <= p["upper"] and t != p["nominal"]


def test_every_mode_of_the_real_frame_shows_in_the_data(shipped):
    """The sum of |H|^2 over all channels peaks at each of the hidden frame's flexible modes
    from 10 to 120 Hz, over noise and the other modes."""
    data, truth = shipped
    f = data.frequency_hz
    indicator = (np.abs(data.H) ** 2).sum(axis=(0, 1))
    modes = np.array(truth["modes"]["frequency_hz"])
    modes = modes[(modes > 10) & (modes < 120)]
    assert len(modes) >= 6
    for fm in modes:
        near = (f > fm * 0.985) & (f < fm * 1.015)
        band = (f > fm * 0.9) & (f < fm * 1.1)
        assert indicator[near].max() > 2.0 * np.median(indicator[band]), fm


@pytest.mark.slow
def test_the_shipped_set_regenerates():
    made = make_hammer_test(FRAME / "hammer_frame.bdf", FRAME / "hammer_frame.params.toml",
                            FRAME / "hammer_frame.sensors.csv", FRAME / "hammer_frame.inputs.csv")  # fmt: skip
    shipped = read_mat(FRAME / "hammer_test.mat").H
    # the same to the eigen solver's accuracy: a change of K by rounding alone (3.6e-16 of its
    # largest entry, when the bars' flexibility rule went from 8 to 3 Gauss points) moved H by
    # 4.7e-7 of each channel's peak, as the Lanczos iterates converge elsewhere within their
    # tolerance; a change of the model moves it by far more (the six CTRIA3's new bending
    # moved the modes by 2e-6, and H near the peaks by Q times that)
    scale = np.abs(shipped).max(axis=2, keepdims=True)
    assert np.all(np.abs(made.data.H - shipped) <= 1e-5 * scale)


def test_bad_sensor_and_parameter_files_are_named(tmp_path):
    from femcal.testdata.points import read_points

    bad = tmp_path / "s.csv"
    bad.write_text("label,grid,directions\nA,1,123\nB,x1,123\n")
    with pytest.raises(ValueError, match=r"s\.csv:3: grid 'x1'"):
        read_points(bad)
    bad.write_text("label,directions\nA,123\n")
    with pytest.raises(ValueError, match=r"s\.csv:1: missing column\(s\) grid"):
        read_points(bad)
    bad.write_text("label,grid,direction\nA,1,9\n")
    with pytest.raises(ValueError, match="expected codes 1-6"):
        read_points(bad)
    toml = tmp_path / "p.toml"
    toml.write_text('[[parameter]]\nname = "p1"\ncard = "PSHELL"\n')
    with pytest.raises(ValueError, match=r"p\.toml: parameter p1: missing id, field"):
        make_hammer_test(FRAME / "hammer_frame.bdf", toml, FRAME / "hammer_frame.sensors.csv",
                         FRAME / "hammer_frame.inputs.csv")  # fmt: skip


def _plate(tmp_path, params_text: str):
    """The calibration tests' plate deck and a parameter file beside it; their paths."""
    from .calib_decks import plate_deck

    (tmp_path / "plate.bdf").write_text(plate_deck())
    (tmp_path / "p.toml").write_text(params_text)
    return tmp_path / "plate.bdf", tmp_path / "p.toml"


def test_hidden_values_lie_within_the_bounds(tmp_path):
    """Every hidden value is drawn within its bounds, relative bounds and every parameter
    field (PBUSH, PELAS, CONM2 ...) included, even at the widest spread."""
    from femcal.calibrate.parameters import read_parameters
    from femcal.jobs.synthetic_test import SynthSettings, hidden_frame
    from femcal.model.build import load_model

    from .calib_decks import PARAMS_TOML

    deck, toml = _plate(tmp_path, PARAMS_TOML)
    params = read_parameters(toml, load_model(deck))
    for seed in range(3):
        model, _, truth = hidden_frame(deck, toml, SynthSettings(spread=1.0, modes_to=300.0),
                                       np.random.default_rng(seed))  # fmt: skip
        for par, t in zip(params, truth, strict=True):
            assert t["name"] == par.name and par.lower <= t["true"] <= par.upper
            assert t["true"] == pytest.approx(par.nominal * (1 + t["p"]), rel=1e-14)
        from femcal.calibrate.parameters import current_value

        assert [current_value(model, p.card, p.id, p.field) for p in params] == [
            t["true"] for t in truth]  # the hidden frame carries them
    with pytest.raises(ValueError, match=r"spread = 1.5: expected a fraction in \[0, 1\]"):
        SynthSettings(spread=1.5)


@pytest.mark.parametrize("bounds, error", [
    ("nominal = 6.0\nlower = 4.0\nupper = 7.0", r"nominal 6.0 but the deck has 5.0"),
    ("lower = 5.5\nupper = 6.0", r"bounds \[5.5, 6.0\] must hold the nominal 5.0"),
    ("lower = 6.0\nupper = 4.0", r"lower = 6.0 is above upper = 4.0"),
])  # fmt: skip
def test_a_parameter_file_a_calibration_refuses_makes_no_test(tmp_path, capsys, bounds, error):
    """A nominal other than the deck's, or bounds that do not hold it, once made a truth
    outside the bounds: now the command stops with one line naming the file and parameter."""
    from femcal.cli import main

    deck, toml = _plate(tmp_path, '[[parameter]]\nname = "t"\ncard = "PSHELL"\nid = 1\n'
                                  f'field = "T"\n{bounds}\n')  # fmt: skip
    (tmp_path / "s.csv").write_text("label,grid,directions\nA,7,123\n")
    (tmp_path / "i.csv").write_text("label,grid,direction\nH,28,3\n")
    code = main(["synth-test", str(deck), "--params", str(toml), "--sensors",
                 str(tmp_path / "s.csv"), "--inputs", str(tmp_path / "i.csv"), "--out",
                 str(tmp_path / "out")])  # fmt: skip
    err = capsys.readouterr().err
    assert code == 2 and not (tmp_path / "out").exists()
    assert re.search(r"femcal synth-test: .*p\.toml: parameter t: " + error, err), err
    assert err.count("\n") == 2  # the progress line, then the error


def test_an_added_mass_is_the_one_difference_it_makes(tmp_path):
    """The added mass lands on the three translations of the grid nearest the point and
    nowhere else; every mode of the hidden frame is then lower or equal (adding mass lowers
    each eigenvalue, Courant-Fischer), some markedly."""
    from femcal.assembly import Options, assemble
    from femcal.jobs.synthetic_test import SynthSettings, hidden_frame, with_added_mass
    from femcal.model.build import load_model

    from .calib_decks import PARAMS_TOML

    deck, toml = _plate(tmp_path, PARAMS_TOML)
    model = load_model(deck)
    mats = assemble(model, Options())
    assert with_added_mass(model, mats, (0.0, 0.0, 0.0), 0.0) is mats
    at = (310.0, 140.0, 3.0)
    new = with_added_mass(model, mats, at, 2e-3)
    grids = np.flatnonzero(model.is_grid)
    node = grids[np.argmin(np.linalg.norm(model.xyz[grids] - np.array(at), axis=1))]
    diff = (new.M - mats.M).tocoo()
    dofs = model.dof_start[node] + np.arange(3)
    assert sorted(diff.row) == sorted(diff.col) == list(dofs)
    assert np.all(diff.row == diff.col) and np.allclose(diff.data, 2e-3, rtol=1e-12)
    assert (new.K != mats.K).nnz == 0
    plain = SynthSettings(modes_to=300.0, support_stiffness=0.0)
    heavy = SynthSettings(modes_to=300.0, support_stiffness=0.0, added_mass=2e-3,
                          added_mass_at=at)  # fmt: skip
    _, m0, _ = hidden_frame(deck, toml, plain, np.random.default_rng(0))
    _, m1, _ = hidden_frame(deck, toml, heavy, np.random.default_rng(0))
    n = min(len(m0.frequencies_hz), len(m1.frequencies_hz))
    assert np.all(m1.frequencies_hz[:n] <= m0.frequencies_hz[:n] * (1 + 1e-9))
    assert (1 - m1.frequencies_hz[:n] / m0.frequencies_hz[:n]).max() > 0.01


@pytest.mark.parametrize("setting, error", [
    (dict(added_mass=-1e-3), r"added_mass = -0.001: expected a mass, 0 or more"),
    (dict(added_mass=float("nan")), r"added_mass = nan: expected a mass, 0 or more"),
    (dict(added_mass_at=(1.0, 2.0)), r"added_mass_at = \(1.0, 2.0\): expected three"),
    (dict(support_stiffness=-5.0), r"support_stiffness = -5.0: expected a stiffness"),
    (dict(support_x=float("inf")), r"support_x = inf: expected a position"),
])  # fmt: skip
def test_model_form_settings_out_of_range_are_named(setting, error):
    from femcal.jobs.synthetic_test import SynthSettings

    with pytest.raises(ValueError, match=r"synthetic test: " + error):
        SynthSettings(**setting)


def test_the_command_makes_a_test_with_a_mass_the_model_lacks(tmp_path, capsys):
    """``--added-mass`` and ``--added-mass-at`` reach the test: its truth file records them
    and the hidden frame's modes are lower than without; a negative mass is one line."""
    from femcal.cli import main

    from .calib_decks import PARAMS_TOML

    deck, toml = _plate(tmp_path, PARAMS_TOML)
    (tmp_path / "s.csv").write_text("label,grid,directions\nA,7,123\nB,21,123\n")
    (tmp_path / "i.csv").write_text("label,grid,direction\nH,28,3\n")
    common = ["synth-test", str(deck), "--params", str(toml), "--sensors",
              str(tmp_path / "s.csv"), "--inputs", str(tmp_path / "i.csv"),
              "--support-stiffness", "0"]  # fmt: skip
    assert main([*common, "--out", str(tmp_path / "plain")]) == 0
    assert main([*common, "--out", str(tmp_path / "heavy"), "--added-mass", "0.002",
                 "--added-mass-at", "310", "140", "3"]) == 0  # fmt: skip
    plain = tomllib.loads((tmp_path / "plain" / "hammer_test.truth.toml").read_text())
    heavy = tomllib.loads((tmp_path / "heavy" / "hammer_test.truth.toml").read_text())
    assert "added_mass" not in plain and plain["support_stiffness_nmm_per_rad"] == 0.0
    assert heavy["added_mass"] == 0.002 and heavy["added_mass_at_mm"] == [310.0, 140.0, 3.0]
    f0 = np.array(plain["modes"]["frequency_hz"])
    f1 = np.array(heavy["modes"]["frequency_hz"])
    n = min(len(f0), len(f1))
    assert np.all(f1[:n] <= f0[:n] * (1 + 1e-6)) and (f1[:n] < f0[:n] * 0.99).any()
    capsys.readouterr()
    code = main([*common, "--out", str(tmp_path / "bad"), "--added-mass", "-1"])
    err = capsys.readouterr().err
    assert code == 2 and not (tmp_path / "bad").exists()
    assert "femcal synth-test: synthetic test: added_mass = -1.0: expected a mass" in err
    assert err.count("\n") == 2
