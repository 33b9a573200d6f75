"""Design studies (femcal.jobs.study, femcal study): the hammer frame's cross member 3 moved
from 2475 to 2275 mm, as in the reference study's Table 8.4."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest

from femcal.errors import ConfigError
from femcal.jobs.study import read_study_config, run_study, study_config, write_study
from femcal.parallel.progress import Step

ROOT = Path(__file__).resolve().parents[1]

BASE = {
    "model": {"generator": "truck-frame", "variant": "hammer"},
    "variable": [{"name": "cross_x_3", "values": [2475, 2275]}],
    "solve": {"band": [5, 120]},
    "pairing": {"min_mac": 0.8, "reference": 0},
}

#: Table 8.4 (elastic modes 3 and 4 of the study: 2475 mm -> 2275 mm).
TABLE_8_4 = {3: (58.70, 54.06), 4: (98.57, 93.46)}


@pytest.fixture(scope="module")
def study():
    messages = []
    res = run_study(study_config(BASE), progress=messages.append)
    return res, messages


def _track_near(res, hz: float):
    """The tracked mode whose frequency at the reference (2475 mm) is nearest ``hz``."""
    return min(res.tracks, key=lambda t: abs(t.frequencies[0] - hz))


def test_modes_of_table_8_4_are_tracked(study):
    res, messages = study
    assert [type(m) for m in messages] == [Step, Step]
    assert (messages[-1].done, messages[-1].total) == (2, 2)
    for p in res.points:
        assert np.all(p.frequencies >= 5.0)  # the six suspension modes (1-4 Hz) left out
    ref = res.points[0].frequencies
    np.testing.assert_allclose(ref[:5], [13.95, 35.70, 42.68, 57.68, 95.80], atol=0.05)
    shifts = {}
    for study_mode, (f_ref, _) in TABLE_8_4.items():
        t = _track_near(res, f_ref)
        assert t.mac[1] >= 0.8, (study_mode, t)
        assert math.isfinite(t.frequencies[1])
        shifts[study_mode] = t.frequencies[1] - t.frequencies[0]
    # the bundled frame's modes pairing to the study's 3 and 4 (elastic 4 and 5 here)
    assert _track_near(res, 58.70).reference_mode == 4
    assert _track_near(res, 98.57).reference_mode == 5
    # what the bundled model does (measured): 57.68 -> 57.44 Hz and 95.80 -> 96.86 Hz
    assert shifts[3] == pytest.approx(-0.25, abs=0.1)
    assert shifts[4] == pytest.approx(1.06, abs=0.2)


def test_two_modes_that_cross_are_each_followed_by_their_shape(tmp_path):
    """A known crossing: a cantilever bar whose I2 is swept through its I1 (400 -> 1600 mm^4,
    I1 = 800). Its first bending mode in the I2 plane rises as sqrt(I2) past the first
    bending mode in the I1 plane, which stays put; their shapes are orthogonal (MAC 0), so
    tracking by shape follows each through the crossing, where the order of the modes
    swaps. (The bundled frame's answer to Table 8.4 is a comparison in docs/truck-frame.md,
    not a test: the frame is a reconstruction of the study's.)"""
    from tests.test_pbar_blank import _cantilever

    (tmp_path / "bar.bdf").write_text(_cantilever("PBAR,1,1,100.,800.,400.,1500."))
    values = [400.0, 600.0, 1000.0, 1600.0]
    cfg = {"model": {"deck": "bar.bdf"},
           "variable": [{"name": "i2", "unit": "mm^4", "fields": [["PBAR", 1, "I2"]],
                         "values": values}],
           "solve": {"modes": 2, "rigid_below": 0.0}, "pairing": {"min_mac": 0.9}}  # fmt: skip
    res = run_study(study_config(cfg, "s.toml", folder=tmp_path))
    rising, steady = sorted(res.tracks[:2], key=lambda t: t.frequencies[0])
    assert all(m >= 0 for t in (rising, steady) for m in t.modes), res.tracks
    f = np.array(rising.frequencies)
    np.testing.assert_allclose(f / f[0], np.sqrt(np.array(values) / values[0]), rtol=1e-3)
    np.testing.assert_allclose(steady.frequencies, steady.frequencies[0], rtol=1e-6)
    # below the crossing the rising mode is the lower one, above it the higher
    assert rising.modes[0] == 0 and rising.modes[-1] == 1
    assert steady.modes[0] == 1 and steady.modes[-1] == 0
    assert min(rising.mac[1:] + steady.mac[1:]) > 0.999


def test_files_written(study, tmp_path):
    res, _ = study
    paths = write_study(res, tmp_path)
    assert [p.name for p in paths] == ["study.csv", "study.json", "frequencies.png"]
    rows = list(csv.DictReader((tmp_path / "study.csv").open()))
    assert len(rows) == len(res.tracks)
    assert rows[3]["reference_mode"] == "4"
    assert float(rows[3]["f_hz@cross_x_3=2475"]) == pytest.approx(57.68, abs=0.05)
    assert float(rows[3]["mac@cross_x_3=2275"]) >= 0.8
    assert rows[3]["mac@cross_x_3=2475"] == ""
    data = json.loads((tmp_path / "study.json").read_text())
    assert data["config"]["values"] == [2475.0, 2275.0]
    assert data["tracks"][3]["mac"][0] is None
    assert (tmp_path / "frequencies.png").read_bytes()[:4] == b"\x89PNG"


def _with(section: str, **changes) -> dict:
    cfg = {k: (list(v) if isinstance(v, list) else dict(v)) for k, v in BASE.items()}
    if section == "variable":
        cfg["variable"] = [dict(cfg["variable"][0], **changes)]
    else:
        cfg[section] = dict(cfg[section], **changes)
    return cfg


@pytest.mark.parametrize(("cfg", "message"), [
    (_with("model", generator="bus-frame"), "model.generator: unknown generator 'bus-frame'"),
    (_with("model", variant="boat"), "model.variant: unknown truck-frame variant 'boat'"),
    (_with("variable", name="cross_y_3"), "variable.name: unknown truck-frame variable "
                                          "'cross_y_3'"),
    (_with("variable", values=[]), "variable.values: expected a non-empty list"),
    (_with("variable", values=[2475, 3000]), "variable.values: cross_x_3 = 3000: expected"),
    # inside the 100 mm clearance, but the frame does not hold together there
    (_with("variable", values=[2475, 2725]), "variable.values: cross_x_3 = 2725: cross member "
                                             "3's end plates (x 2615 to 2835 mm) overlap cross "
                                             "member 4's"),
    (_with("variable", name="cross_x_4", values=[2825, 3400]),
     "variable.values: cross_x_4 = 3400: the frame cannot be built there: a bolt of the cross "
     "member lands off the plies it joins (the inner liner runs from x 150 to 3350 mm)"),
    (_with("solve", band=[120, 5]), "solve.band: expected [F1, F2]"),
    (_with("pairing", reference=2), "pairing.reference: expected a point index 0 to 1"),
    (_with("pairing", min_mac=1.5), "pairing.min_mac: expected a MAC in [0, 1]"),
    # a misspelt key would run the study on the default: refused with the nearest key
    (_with("solve", bands=[5, 50]), "solve.bands: unknown key 'bands' (expected one of band, "
                                    "modes, rigid_below); did you mean 'band'?"),
    (_with("pairing", minmac=0.9), "pairing.minmac: unknown key 'minmac' (expected one of "
                                   "max_frequency_ratio, min_mac, reference); did you mean "
                                   "'min_mac'?"),
    (_with("model", varient="rig"), "model.varient: unknown key 'varient'"),
    (_with("variable", valuse=[1]), "variable.valuse: unknown key 'valuse'"),
])  # fmt: skip
def test_config_errors_named(cfg, message):
    with pytest.raises(ConfigError) as e:
        study_config(cfg, "s.toml")
    assert str(e.value).startswith(f"s.toml: {message}"), str(e.value)


def test_bundled_config_and_cli_errors(tmp_path, capsys):
    from femcal import cli

    cfg = read_study_config(ROOT / "models/truck_frame/cross_member_study.toml")
    assert cfg.variable == "cross_x_3" and cfg.values == (2475.0, 2375.0, 2275.0)
    assert cfg.band == (5.0, 120.0) and cfg.min_mac == 0.8 and cfg.unit == "mm"
    bad = tmp_path / "bad.toml"
    bad.write_text('[model]\ngenerator = "nope"\n')
    assert cli.main(["study", str(bad), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "model.generator: unknown generator 'nope'" in err[0], err


@pytest.mark.parametrize("kind", ["local", "dask"])
def test_points_solved_side_by_side_give_the_same_study(tmp_path, kind):
    """Three points of a deck study on two workers (local processes, or a Dask
    LocalCluster): the same modes and tracks as one after another here, to the rounding of
    the eigensolver's BLAS (one thread per worker)."""
    if kind == "dask":
        pytest.importorskip("distributed", reason="the Dask engine needs distributed")
    from femcal.parallel.cluster import Engine

    cfg = study_config(_deck_study(tmp_path, values=[210000.0, 150000.0, 105000.0]), "s.toml",
                       tmp_path)  # fmt: skip
    serial = run_study(cfg)
    messages = []
    res = run_study(cfg, engine=Engine(kind, workers=2), progress=messages.append)
    assert sorted(m.done for m in messages) == [1, 2, 3]
    for a, b in zip(res.points, serial.points, strict=True):
        assert a.value == b.value
        np.testing.assert_allclose(a.frequencies, b.frequencies, rtol=1e-9)
    assert [t.modes for t in res.tracks] == [t.modes for t in serial.tracks]
    for a, b in zip(res.tracks, serial.tracks, strict=True):
        np.testing.assert_allclose(a.mac, b.mac, rtol=1e-7)


def _plate_deck(nx: int = 8, ny: int = 4) -> str:
    """A cantilever plate (mm, tonne, s) of two halves, each with its own PSHELL and MAT1 (both
    steel), clamped along x = 0; fixed-field cards, so the edits must keep the columns."""
    lines = ["SOL 103", "CEND", "METHOD = 1", "SPC = 1", "BEGIN BULK",
             "EIGRL   1                       8",
             "MAT1    1       210000.         .3      7.85-9",
             "MAT1    2       210000.         .3      7.85-9",
             "PSHELL  1       1       4.      1               1",
             "PSHELL  2       2       4.      2               2"]  # fmt: skip
    gid = lambda i, j: 1 + i + (nx + 1) * j  # noqa: E731
    for j in range(ny + 1):
        for i in range(nx + 1):
            lines.append(f"GRID,{gid(i, j)},,{50.0 * i!r},{40.0 * j!r},0.")
    for j in range(ny):
        for i in range(nx):
            lines.append(f"CQUAD4,{1 + i + nx * j},{1 if i < nx // 2 else 2},{gid(i, j)},"
                         f"{gid(i + 1, j)},{gid(i + 1, j + 1)},{gid(i, j + 1)}")  # fmt: skip
    lines.append("SPC1,1,123456," + ",".join(str(gid(0, j)) for j in range(ny + 1)))
    return "\n".join([*lines, "ENDDATA"]) + "\n"


def _deck_study(tmp_path, **variable) -> dict:
    (tmp_path / "plate.bdf").write_text(_plate_deck())
    var = {"name": "E", "unit": "MPa", "fields": [["MAT1", 1, "E"], ["MAT1", 2, "E"]],
           "values": [210000.0, 105000.0]} | variable  # fmt: skip
    return {"model": {"deck": "plate.bdf"}, "variable": [var], "solve": {"modes": 6},
            "pairing": {"min_mac": 0.9}}


def test_a_deck_whose_fields_are_the_variable(tmp_path):
    """A deck as the template: both materials' E set to each value, in the deck's own text.
    Halving E halves every stiffness (membrane, bending, shear, drilling) and leaves the mass:
    every frequency falls by sqrt(2) exactly, the shapes stay, and the tracks pair mode k to
    mode k."""
    cfg = study_config(_deck_study(tmp_path), "s.toml", tmp_path)
    assert cfg.deck == tmp_path / "plate.bdf" and cfg.unit == "MPa" and cfg.source == "plate.bdf"
    res = run_study(cfg)
    a, b = res.points
    assert len(res.tracks) == 6 and a.n_dof == b.n_dof
    np.testing.assert_allclose(a.frequencies / b.frequencies, np.sqrt(2.0), rtol=1e-9)
    for k, t in enumerate(res.tracks):
        assert t.modes == [k, k] and t.mac[1] > 1 - 1e-9
    paths = write_study(res, tmp_path / "out")
    assert json.loads(paths[1].read_text())["config"]["deck"] == str(tmp_path / "plate.bdf")
    # one field alone: the half with the softer material moves the modes less than sqrt(2)
    one = run_study(study_config(_deck_study(tmp_path, fields=[["MAT1", 2, "E"]]), "s.toml",
                                 tmp_path))  # fmt: skip
    ratio = one.points[0].frequencies / one.points[1].frequencies
    assert np.all(ratio > 1.0) and np.all(ratio < np.sqrt(2.0) - 1e-3)


@pytest.mark.parametrize(("variable", "message"), [
    ({"fields": [["MAT1", 9, "E"]]}, "variable.values: E = 210000: "),
    ({"fields": [["MAT1", 1]]}, "variable.fields: expected a list of [card, id, field]"),
    ({"name": ""}, "variable.name: expected a name for the variable"),
])  # fmt: skip
def test_deck_study_errors_named(tmp_path, variable, message):
    with pytest.raises(ConfigError) as e:
        study_config(_deck_study(tmp_path, **variable), "s.toml", tmp_path)
    assert str(e.value).startswith(f"s.toml: {message}"), str(e.value)
    if "MAT1" in str(variable) and "9" in str(variable):
        assert "MAT1 9" in str(e.value), str(e.value)


def test_deck_or_generator_not_both(tmp_path):
    data = _deck_study(tmp_path)
    data["model"]["generator"] = "truck-frame"
    with pytest.raises(ConfigError, match=r"give a generator .* or a deck, not both"):
        study_config(data, "s.toml", tmp_path)
    data = _deck_study(tmp_path)
    data["model"]["deck"] = "nope.bdf"
    with pytest.raises(ConfigError, match=r"model\.deck: no such file"):
        study_config(data, "s.toml", tmp_path)


def test_a_stopped_study_resumes_from_its_kept_points(tmp_path):
    """Each solved point is kept in the state folder with a key of what decides it: a second
    run solves none, the same result; a point whose file was spoilt, or a study with other
    solve settings, is solved again."""
    cfg = study_config(_deck_study(tmp_path, values=[210000.0, 180000.0, 150000.0]), "s.toml",
                       tmp_path)  # fmt: skip
    state = tmp_path / "points"
    first = run_study(cfg, state=state)
    assert sorted(f.name for f in state.iterdir()) == [f"point_00{k}.npz" for k in (1, 2, 3)]
    messages: list = []
    again = run_study(cfg, state=state, progress=messages.append)
    assert sum("solved earlier" in m for m in messages) == 3
    for a, b in zip(again.points, first.points, strict=True):
        np.testing.assert_array_equal(a.frequencies, b.frequencies)
        np.testing.assert_array_equal(a.shapes, b.shapes)
    (state / "point_002.npz").write_bytes(b"not a point")
    messages.clear()
    run_study(cfg, state=state, progress=messages.append)
    assert sum("solved earlier" in m for m in messages) == 2
    messages.clear()
    from dataclasses import replace

    run_study(replace(cfg, n_modes=4), state=state, progress=messages.append)
    assert not any("solved earlier" in m for m in messages)


def test_a_mode_moving_far_between_points_is_tracked_by_its_shape(tmp_path):
    """A PBAR I2 sweep 25 -> 81 -> 400 moves the cantilever's bending modes in that plane by
    1.8 and 2.2 times between points; their shapes do not change (MAC 1), so they are
    tracked throughout (frequencies as sqrt(I2)) unless a max_frequency_ratio says
    otherwise."""
    from tests.test_pbar_blank import _cantilever

    deck = tmp_path / "bar.bdf"
    deck.write_text(_cantilever("PBAR,1,1,100.,800.,25.,1500."))
    cfg = {"model": {"deck": "bar.bdf"},
           "variable": [{"name": "i2", "unit": "mm^4", "fields": [["PBAR", 1, "I2"]],
                         "values": [25.0, 81.0, 400.0]}],
           "solve": {"modes": 4}, "pairing": {"min_mac": 0.9}}  # fmt: skip
    res = run_study(study_config(cfg, "s.toml", folder=tmp_path))
    # the first bending mode in the I2 plane: the track whose frequency moves most
    moving = max(res.tracks, key=lambda t: t.frequencies[-1] / t.frequencies[0])
    assert all(m >= 0 for m in moving.modes), moving
    f = np.array(moving.frequencies)
    assert f[1:] / f[0] == pytest.approx(np.sqrt([81 / 25, 400 / 25]), rel=0.01)
    assert min(moving.mac[1:]) > 0.999
    k = res.tracks.index(moving)
    limited = run_study(study_config({**cfg, "pairing": {"min_mac": 0.9,
                                                         "max_frequency_ratio": 1.5}},
                                     "s.toml", folder=tmp_path))  # fmt: skip
    assert limited.tracks[k].modes[1:] == [-1, -1]  # the guard, when asked for, holds
    with pytest.raises(ConfigError, match=r"pairing\.max_frequency_ratio: expected a factor"):
        study_config({**cfg, "pairing": {"max_frequency_ratio": 0.5}}, "s.toml",
                     folder=tmp_path)  # fmt: skip


@pytest.mark.parametrize(("solve", "message"), [
    ({"band": [20000.0, 30000.0]}, r"solve\.band = \[20000, 30000\] Hz: the reference point "
                                   r"\(i2 = 81 mm\^4\) has no elastic mode in the band \(it "
                                   r"has none from 20000 to 36000 Hz\)"),
    ({"band": [6.0, 7.0]}, r"solve\.band = \[6, 7\] Hz: the reference point \(i2 = 81 mm\^4\) "
                           r"has no elastic mode in the band \(its lowest above 6 Hz is at "),
    ({"modes": 2, "rigid_below": 1e6}, r"solve\.modes = 2: the reference point \(i2 = 81 "
                                       r"mm\^4\) has no elastic mode above 1e\+06 Hz"),
])  # fmt: skip
def test_a_band_without_modes_is_refused_by_name(tmp_path, solve, message):
    """A band (or a rigid-body limit) that leaves the reference point no mode to track is a
    configuration error that says what the point has, not an empty study (or a crash)."""
    from tests.test_pbar_blank import _cantilever

    deck = tmp_path / "bar.bdf"
    deck.write_text(_cantilever("PBAR,1,1,100.,800.,25.,1500."))
    cfg = {"model": {"deck": "bar.bdf"},
           "variable": [{"name": "i2", "unit": "mm^4", "fields": [["PBAR", 1, "I2"]],
                         "values": [25.0, 81.0]}],
           "solve": solve, "pairing": {"reference": 1}}  # fmt: skip
    with pytest.raises(ConfigError, match=message):
        run_study(study_config(cfg, "s.toml", folder=tmp_path))


def test_a_band_below_the_rigid_body_limit_is_refused_when_read():
    with pytest.raises(ConfigError, match=r"s\.toml: solve\.band: \[0\.5, 4\] Hz lies below "
                                          r"rigid_below = 5 Hz"):
        study_config(_with("solve", band=[0.5, 4.0]), "s.toml")
