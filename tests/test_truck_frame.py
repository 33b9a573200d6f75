"""The bundled truck frame: the committed files are what the generator writes, and the nominal
hammer frame has the reference study's pre-calibration modes (METHOD.md)."""

from __future__ import annotations

import csv
import tomllib
from pathlib import Path

import numpy as np
import pytest

from femcal.deck import read_deck
from femcal.examples.truck_frame import FrameDimensions, write_frame
from femcal.model.build import build_model
from femcal.solve.normal_modes import solve_normal_modes

from .conftest import ROOT

FRAME_DIR = ROOT / "models" / "truck_frame"
DECK = FRAME_DIR / "hammer_frame.bdf"


@pytest.mark.parametrize("variant", ["hammer", "rig", "rig-battery"])
def test_committed_files_regenerate_byte_identically(tmp_path: Path, variant: str):
    paths = write_frame(variant, tmp_path)
    assert len(paths) == (4 if variant == "hammer" else 3)
    for path in paths:
        assert path.read_bytes() == (FRAME_DIR / path.name).read_bytes(), path.name


@pytest.fixture(scope="module")
def solved():
    deck = read_deck(DECK)
    model = build_model(deck)
    modes, _ = solve_normal_modes(model)
    return deck, model, modes


def _shape_measures(model, modes, k: int) -> dict[str, float]:
    """How mode k moves the rails: the tops of the two webs, sampled along X."""
    d = FrameDimensions()
    X = model.xyz
    u = modes.grid_displacements(k)[:, :3]

    def rail(side: float) -> np.ndarray:
        sel = np.flatnonzero((np.abs(X[:, 1] - side * d.half_width) < 0.01)
                             & (np.abs(X[:, 2] - d.web / 2) < 0.01))  # fmt: skip
        return sel[np.argsort(X[sel, 0])]

    left, right = rail(1.0), rail(-1.0)
    assert len(left) == len(right) > 100
    zl, zr, yl, yr = u[left, 2], u[right, 2], u[left, 1], u[right, 1]
    rails = (u[left] ** 2).sum() + (u[right] ** 2).sum()
    behind = X[left, 0] > d.cross_x[-1]  # the rails behind the rear cross member
    return {
        # rails opposite in Z: (zl - zr) dominates
        "z_opposite": ((zl - zr) ** 2).sum() / (((zl - zr) ** 2).sum() + ((zl + zr) ** 2).sum()),
        "z_share": ((zl**2).sum() + (zr**2).sum()) / rails,
        # rails together in Y
        "y_together": ((yl + yr) ** 2).sum() / (((yl + yr) ** 2).sum() + ((yl - yr) ** 2).sum()),
        "y_share": ((yl**2).sum() + (yr**2).sum()) / rails,
        "rear_y": ((yl[behind] ** 2).sum() + (yr[behind] ** 2).sum())
        / ((yl**2).sum() + (yr**2).sum()),
    }


@pytest.fixture(scope="module")
def shapes(solved):
    _, model, modes = solved
    f = modes.frequencies_hz
    return f, [_shape_measures(model, modes, k) for k in range(len(f))]


def test_hammer_frame_size_and_bellows_modes(solved):
    _, model, modes = solved
    f = modes.frequencies_hz
    assert 50_000 < model.n_dof < 150_000
    assert np.all(f[:6] < 5.0) and f[6] > 10.0  # six modes on the bellows, then flexible


def _lateral(f, m, together: bool = True):
    """Flexible modes moving the rails mostly in Y, together (or against each other)."""
    return [k for k in range(6, len(f)) if m[k]["y_share"] > 0.7
            and (m[k]["y_together"] > 0.95 if together else m[k]["y_together"] < 0.05)]  # fmt: skip


def test_first_flexible_mode_is_torsion_near_the_studys(shapes):
    f, m = shapes
    assert m[6]["z_opposite"] > 0.95 and m[6]["z_share"] > 0.8  # rails opposite in Z
    assert abs(f[6] / 13.19 - 1) < 0.10, f[6]


def test_lateral_bending_near_the_studys(shapes):
    f, m = shapes
    first = _lateral(f, m)[0]
    assert m[first]["rear_y"] < 0.5  # the whole frame bends
    assert abs(f[first] / 46.70 - 1) < 0.10, f[first]


def test_lateral_bending_near_the_rear_near_the_studys(shapes):
    f, m = shapes
    rear = [k for k in _lateral(f, m) if m[k]["rear_y"] > 0.5]
    assert rear and abs(f[rear[0]] / 54.46 - 1) < 0.10, f[rear[:1]]
    assert rear[0] == _lateral(f, m)[1]  # the second lateral mode


def test_local_bending_at_the_rear_brackets_near_the_studys(shapes):
    """The rails' rear ends, with the rig brackets, swinging against each other."""
    f, m = shapes
    local = [k for k in _lateral(f, m, together=False) if m[k]["rear_y"] > 0.5]
    assert local and abs(f[local[0]] / 95.04 - 1) < 0.10, f[local[:1]]


def test_two_more_modes_between_100_and_120_hz(shapes):
    f, _ = shapes
    assert ((f > 100.0) & (f < 120.0)).sum() >= 2


def test_parameters_resolve_to_deck_entries(solved):
    _, model, _ = solved
    params = tomllib.loads((FRAME_DIR / "hammer_frame.params.toml").read_text())["parameter"]
    assert [p["name"] for p in params] == [f"p{i}" for i in range(1, 31)]
    kinds = [(p["card"], p["field"]) for p in params]
    assert kinds.count(("PSHELL", "T")) == 8 and kinds.count(("PBAR", "A")) == 9
    assert kinds.count(("MAT1", "E")) == 13
    tables = {"PSHELL": (model.properties, "pid", "t"), "PBAR": (model.properties, "pid", "a"),
              "MAT1": (model.materials, "mid", "e")}  # fmt: skip
    seen = set()
    for p in params:
        source, key, column = tables[p["card"]]
        table = source[p["card"]]
        rows = np.flatnonzero(table[key] == p["id"])
        assert len(rows) == 1, p
        assert table[column][rows[0]] == pytest.approx(p["nominal"], rel=1e-6), p
        assert p["lower"] < p["nominal"] < p["upper"]
        seen.add((p["card"], p["id"]))
    assert len(seen) == 30  # each parameter its own entry


def test_sensors_and_inputs_are_grids(solved):
    _, model, _ = solved
    for name, expected in (("hammer_frame.sensors.csv", 24), ("hammer_frame.inputs.csv", 2)):
        with open(FRAME_DIR / name, newline="") as fh:
            rows = list(csv.DictReader(fh))
        assert len(rows) == expected
        for r in rows:
            idx = np.searchsorted(model.node_ids, int(r["grid"]))
            assert model.node_ids[idx] == int(r["grid"])
            xyz = [float(r[c]) for c in "xyz"]
            assert np.allclose(model.xyz[idx], xyz, atol=0.01)
    with open(FRAME_DIR / "hammer_frame.inputs.csv", newline="") as fh:
        assert sorted(r["direction"] for r in csv.DictReader(fh)) == ["2", "3"]


@pytest.mark.parametrize("stem", ["rig_frame", "rig_frame_battery"])
def test_rig_frames_stand_on_seven_actuators_with_sensors_near_them(stem: str):
    deck = read_deck(FRAME_DIR / f"{stem}.bdf")
    model = build_model(deck)
    with open(FRAME_DIR / f"{stem}.inputs.csv", newline="") as fh:
        inputs = list(csv.DictReader(fh))
    assert sorted(int(r["direction"]) for r in inputs) == [-1, 2, 2, 3, 3, 3, 3]
    with open(FRAME_DIR / f"{stem}.sensors.csv", newline="") as fh:
        sensors = list(csv.DictReader(fh))
    assert len(sensors) == (8 if stem.endswith("battery") else 7)
    for r in inputs:
        a = np.array([float(r[c]) for c in "xyz"])
        near = [np.linalg.norm(a - [float(s[c]) for c in "xyz"]) for s in sensors]
        assert min(near) < 400.0, r["label"]
    for r in inputs + sensors:
        idx = np.searchsorted(model.node_ids, int(r["grid"]))
        assert model.node_ids[idx] == int(r["grid"])
    assert model.elements["CBUSH"].ids.size == 7
    if stem.endswith("battery"):
        assert "CONM2" in model.elements
    modes, _ = solve_normal_modes(model)
    assert modes.frequencies_hz[0] > 5.0  # held by the actuators: no rigid-body modes
