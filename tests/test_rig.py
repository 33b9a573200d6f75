"""The frame on displacement-driven actuators: the plant against the full model's direct
frequency-domain solution, the time simulation against the plant's frequency response, and
the errors for actuators a deck does not hold."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from femcal.assembly import Options, assemble
from femcal.assembly.constraints import build_reduction
from femcal.errors import ModelError, TimeDataError
from femcal.model.build import load_model
from femcal.response.frf import channel_matrix
from femcal.rig.plant import build_plant
from femcal.rig.simulate import periodic_response, simulate
from femcal.testdata.data import Channel
from femcal.testdata.points import point_label

from .rig_decks import ACTUATORS, SENSORS, small_rig_deck

DT = 1 / 512


@pytest.fixture(scope="module")
def deck(tmp_path_factory):
    return small_rig_deck(tmp_path_factory.mktemp("rig") / "small_rig.bdf")


@pytest.fixture(scope="module")
def plant(deck):
    return build_plant(load_model(deck), ACTUATORS, SENSORS, modes_to=150.0, damping=0.02)


def direct_solution(deck, f_hz: float) -> np.ndarray:
    """Outputs per unit drive (n_out, n_in) at f_hz by solving (K - w^2 M) u = B s on the
    whole model with the oil columns' grounded ends moved (no modes, no damping)."""
    model = load_model(deck)
    mats = assemble(model, Options())
    K, M = sp.csr_matrix(mats.K), sp.csr_matrix(mats.M)
    red = build_reduction(model)
    w = 2 * np.pi * f_hz
    n_in = len(ACTUATORS)
    B = np.zeros((model.n_dof, n_in))
    F = np.zeros((n_in, model.n_dof))
    k = np.zeros(n_in)
    for j, (_, _, code) in enumerate(ACTUATORS):
        g = model.node_index(101 + j)[0]  # the deck's grounded grids, in actuator order
        d = int(model.dof_start[g]) + abs(code) - 1
        e = np.sign(code)
        B[:, j] = -K[:, [d]].toarray().ravel() * e
        F[j] = K[[d]].toarray().ravel() * e
        k[j] = K[d, d]
    A = red.reduce(K - w**2 * M).tocsc()
    u = red.T @ spla.splu(A).solve(np.asarray(red.T.T @ B))
    C = channel_matrix(model, [Channel.parse(point_label(g, c)) for _, g, c in SENSORS])
    return np.vstack([np.eye(n_in), F @ u + np.diag(k), -(w**2) * (C @ u)])


def test_the_plant_with_every_mode_is_the_direct_solution(deck):
    full = build_plant(load_model(deck), ACTUATORS, SENSORS, modes_to=1e6, damping=0.0)
    for f in (3.0, 40.0, 130.0, 400.0):  # between the modes (45, 56, 102, 122 ... Hz)
        H = full.frf([f])[:, :, 0]
        Hd = direct_solution(deck, f)
        scale = np.abs(Hd).max(axis=1, keepdims=True)
        assert (np.abs(H - Hd) / scale).max() < 1e-8, f


def test_truncated_modes_enter_statically_with_their_first_inertia_term(deck, plant):
    model = load_model(deck)
    full = build_plant(model, ACTUATORS, SENSORS, modes_to=1e6, damping=0.0)
    cut = plant.with_damping(0.0)
    assert cut.n_modes < full.n_modes
    f = np.array([2.0, 10.0, 30.0])  # the first mode left out is at 188 Hz
    H, Hf = cut.frf(f), full.frf(f)
    scale = np.abs(Hf).max(axis=1, keepdims=True)
    err = np.abs(H - Hf) / scale
    # below the left-out modes (the first at 188 Hz) the frame moves nearly rigidly on its
    # columns; the forces are then its inertia, which the left-out modes' second-order
    # term carries (without it they would be 0); what is left is of relative size
    # (f / 188 Hz)^2, in the accelerations too
    bound = 2 * (f / 188.0) ** 2
    assert (err <= bound).all(), err.max(axis=(0, 1)) / bound
    D2 = cut.D2.copy()
    D2[: 2 * len(ACTUATORS)] = 0.0
    without = replace(cut, D2=D2)
    lost = np.abs(without.frf(f) - Hf) / scale
    assert lost[len(ACTUATORS):2 * len(ACTUATORS)].max() > 0.5  # the term matters


def test_a_sine_drive_settles_on_the_frequency_response(plant):
    t = np.arange(round(30 / DT)) * DT
    tail = slice(len(t) // 2, -8)
    for f0 in (7.0, 25.0):
        s = np.zeros((len(ACTUATORS), len(t)))
        s[0] = np.sin(2 * np.pi * f0 * t)
        s[4] = 0.5 * np.cos(2 * np.pi * f0 * t)
        y = simulate(plant, s, DT)
        H = plant.frf([f0])[:, :, 0]
        ref = (H[:, 0, None] * np.exp(2j * np.pi * f0 * t) / 1j
               + 0.5 * H[:, 4, None] * np.exp(2j * np.pi * f0 * t)).real  # fmt: skip
        size = np.abs(ref[:, tail]).max(axis=1)
        size[: len(ACTUATORS)] = 1.0  # the LVDTs of the drives left still: checked below
        err = np.abs(y[:, tail] - ref[:, tail]).max(axis=1) / size
        forces = slice(len(ACTUATORS), 2 * len(ACTUATORS))
        assert err[forces].max() < 1e-3, (f0, err)
        # sensors that move with the drives (weak cross-couplings far below their modes
        # carry the hold's aliasing amplified; see femcal.rig.simulate)
        accel = slice(2 * len(ACTUATORS), None)
        strong = size[accel] > 0.1 * size[accel].max()
        assert err[accel][strong].max() < 1e-3, (f0, err)
        assert np.allclose(y[: len(ACTUATORS)], s)  # the LVDTs read the drive


def test_periodic_simulation_matches_the_exact_periodic_response(plant):
    rng = np.random.default_rng(4)
    n = 8192
    S = np.zeros((len(ACTUATORS), n // 2 + 1), complex)
    band = (np.fft.rfftfreq(n, DT) > 0.5) & (np.fft.rfftfreq(n, DT) < 30)
    S[:, band] = np.exp(2j * np.pi * rng.uniform(size=(len(ACTUATORS), int(band.sum()))))
    s = np.fft.irfft(S, n, axis=1)
    exact = periodic_response(plant, s, DT)
    stepped = simulate(plant, s, DT, periodic=True)
    rms = np.sqrt(np.mean(exact**2, axis=1))
    assert (np.sqrt(np.mean((stepped - exact) ** 2, axis=1)) / rms).max() < 1e-3
    # and in blocks: a long drive stepped block by block is the same as in one go
    three = simulate(plant, np.tile(s, 3), DT)
    assert np.allclose(three[:, -n:-8], stepped[:, :-8], atol=2e-3 * rms[:, None])


def test_bad_drives_are_refused(plant):
    with pytest.raises(TimeDataError, match="6 actuators"):
        simulate(plant, np.zeros((2, 10)), DT)
    with pytest.raises(TimeDataError, match="NaN"):
        simulate(plant, np.full((6, 10), np.nan), DT)


@pytest.mark.parametrize("rows, message", [
    ([("A", 5, 3)], r"actuator A \(grid 5, direction 3\): expected one oil column"),
    ([("A", 1, 5)], "expected a translation 1-3"),
    ([("A", 999, 3)], "no GRID 999"),
    ([("A", 12, 2)], "found none"),
])  # fmt: skip
def test_actuators_the_deck_does_not_hold_are_named(deck, rows, message):
    with pytest.raises(ModelError, match=message):
        build_plant(load_model(deck), rows, SENSORS, modes_to=150.0)


def test_a_frame_the_actuators_do_not_hold_is_refused(tmp_path, deck):
    text = deck.read_text().replace("SPC1,1,123456,106\n", "")
    text = text.replace("CBUSH,205,21,1,106,,,,0\n", "")
    free = tmp_path / "free_in_x.bdf"
    free.write_text(text)
    with pytest.raises(ModelError, match="rigid-body mode"):
        build_plant(load_model(free), ACTUATORS[:5], SENSORS, modes_to=150.0)
