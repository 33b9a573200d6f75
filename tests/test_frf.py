"""Modal FRFs against a one-degree-of-freedom oscillator and the direct solution."""

from __future__ import annotations

import re

import numpy as np
import pytest

from femcal.deck import read_deck
from femcal.model.build import build_model
from femcal.response.frf import (
    Rayleigh,
    direct_frf,
    direction_matrix,
    modal_frf,
    point_matrix,
    residual_flexibility,
)
from femcal.solve.normal_modes import solve_normal_modes

from .conftest import solve_cantilever

OSCILLATOR = """SOL 103
CEND
SPC = 1
METHOD = 1
BEGIN BULK
EIGRL,1,,,1
GRID,1,,0.,0.,0.,,23456
CELAS2,10,400.,1,1
CONM2,20,1,,0.25
ENDDATA
"""


def test_one_mode_oscillator_is_the_textbook_receptance(write):
    deck = read_deck(write(OSCILLATOR))
    model = build_model(deck)
    modes, _ = solve_normal_modes(model)
    k, m, zeta = 400.0, 0.25, 0.02
    wn = np.sqrt(k / m)
    assert modes.radians[0] == pytest.approx(wn, rel=1e-12)
    f = np.linspace(0.5, 12.0, 40)
    w = 2 * np.pi * f
    P = point_matrix(model, [(1, 1)])
    H = modal_frf(modes.shapes, modes.radians, P, P.T, f, zeta)
    expected = 1.0 / (k - w**2 * m + 2j * zeta * wn * m * w)
    assert np.allclose(H[0, 0], expected, rtol=1e-12)
    A = modal_frf(modes.shapes, modes.radians, P, P.T, f, zeta, quantity="accelerance")
    V = modal_frf(modes.shapes, modes.radians, P, P.T, f, zeta, quantity="mobility")
    assert np.allclose(A[0, 0], -(w**2) * expected) and np.allclose(V[0, 0], 1j * w * expected)


@pytest.fixture(scope="module")
def cantilever():
    # coupled mass: the bars' rotations carry inertia, so every DOF has a finite mode (with
    # massless DOF the sum of the finite modes misses their static part)
    model, mats, modes, red = solve_cantilever(coupled_mass=True)
    assert modes.shapes.shape[1] == red.T.shape[1] == 20  # GRDSET leaves T2 and R3 free
    return model, mats, modes, red


def test_modal_sum_over_all_modes_equals_the_direct_solution(cantilever):
    model, mats, modes, red = cantilever
    points = [(11, 2), (11, 6), (6, 2), (3, 6)]
    C = point_matrix(model, points)
    damping = Rayleigh(alpha=2.0, beta=1e-6)
    f = np.concatenate([np.linspace(1.0, 400.0, 23), modes.frequencies_hz[:4] * 1.0001])
    for quantity in ("receptance", "accelerance"):
        Hm = modal_frf(modes.shapes, modes.radians, C, C.T, f, damping, quantity)
        Hd = direct_frf(red.reduce(mats.K), red.reduce(mats.M), red.T, C, C.T, f, damping,
                        quantity)  # fmt: skip
        scale = np.abs(Hd).max(axis=(0, 1))
        assert np.all(np.abs(Hm - Hd).max(axis=(0, 1)) <= 1e-6 * scale), quantity


def test_frfs_are_reciprocal(cantilever):
    model, _, modes, _ = cantilever
    C = point_matrix(model, [(11, 2), (4, 2), (8, 6)])
    H = modal_frf(modes.shapes, modes.radians, C, C.T, np.linspace(1.0, 300.0, 17), 0.01)
    assert np.allclose(H, np.swapaxes(H, 0, 1), rtol=1e-10, atol=0)


def test_points_are_checked(cantilever):
    model = cantilever[0]
    with pytest.raises(ValueError, match="no GRID or SPOINT 99"):
        point_matrix(model, [(99, 1)])
    with pytest.raises(ValueError, match="components 1-6"):
        point_matrix(model, [(11, 7)])
    with pytest.raises(ValueError, match="quantity"):
        modal_frf(np.zeros((66, 1)), np.ones(1), point_matrix(model, [(11, 1)]),
                  point_matrix(model, [(11, 1)]).T, [1.0], 0.01, quantity="velocity")  # fmt: skip


def test_residual_flexibility_completes_the_modes_of_massless_dof():
    """Lumped bar mass leaves the rotations massless: the 10 finite modes miss their static
    part, and the residual flexibility puts it back exactly."""
    model, mats, modes, red = solve_cantilever(coupled_mass=False)
    assert modes.shapes.shape[1] == 10 < red.T.shape[1]
    C = point_matrix(model, [(11, 2), (11, 6), (5, 6)])
    f = np.linspace(2.0, 500.0, 19)
    damping = Rayleigh(alpha=5.0)  # mass-proportional: the massless part is undamped too
    Kaa = red.reduce(mats.K)
    Hd = direct_frf(Kaa, red.reduce(mats.M), red.T, C, C.T, f, damping)
    Hm = modal_frf(modes.shapes, modes.radians, C, C.T, f, damping)
    R = residual_flexibility(Kaa, red.T, C, C.T, modes.shapes, modes.radians)
    Hr = modal_frf(modes.shapes, modes.radians, C, C.T, f, damping, residual=R)

    def worst(H):  # largest error of any output/input pair, relative to that pair's size
        return (np.abs(H - Hd).max(axis=2) / np.abs(Hd).max(axis=2)).max()

    assert worst(Hm) > 1e-3  # the finite modes alone fall short (0.3 %)
    assert worst(Hr) < 1e-8


def test_residual_flexibility_improves_a_truncated_frf(cantilever):
    model, mats, modes, red = cantilever
    C = point_matrix(model, [(11, 2), (8, 2)])
    f = np.linspace(1.0, 150.0, 30)  # below the fourth mode
    damping = 0.02
    full = modal_frf(modes.shapes, modes.radians, C, C.T, f, damping)
    keep = slice(0, 3)
    S, W = modes.shapes[:, keep], modes.radians[keep]
    R = residual_flexibility(red.reduce(mats.K), red.T, C, C.T, S, W)
    bare = modal_frf(S, W, C, C.T, f, damping)
    corrected = modal_frf(S, W, C, C.T, f, damping, residual=R)
    err_bare = np.abs(bare - full).max()
    err_corr = np.abs(corrected - full).max()
    assert err_corr < 0.1 * err_bare


def test_residual_flexibility_refuses_rigid_modes(cantilever):
    model, mats, modes, red = cantilever
    C = point_matrix(model, [(11, 2)])
    with pytest.raises(ValueError, match="restrained"):
        residual_flexibility(red.reduce(mats.K), red.T, C, C.T, modes.shapes[:, :2],
                             np.array([0.0, 1.0]))  # fmt: skip


ROTATED = """BEGIN BULK
CORD2R,5,,0.,0.,0.,0.,0.,1.
,1.,1.,0.
GRID,1,,0.,0.,0.
GRID,2,,1.,0.,0.,5
ENDDATA
"""


def test_direction_sensors_read_along_basic_directions_in_any_cd_frame(write):
    model = build_model(read_deck(write(ROTATED)))
    frame = model.cd_frames[1]  # GRID 2's displacement frame (rotated 45 deg about Z)
    assert not np.allclose(frame, np.eye(3))
    rng = np.random.default_rng(3)
    u = rng.normal(size=model.n_dof)  # g-set: GRID 2's components in its own frame
    v = np.array([0.0, 0.6, 0.8])
    C = direction_matrix(model, [(2, v), (1, 2 * v), (2, v)], rotation=False)
    basic_2 = frame @ u[6:9]
    assert C[0] @ u == pytest.approx(v @ basic_2, rel=1e-12)
    assert C[1] @ u == pytest.approx(v @ u[0:3], rel=1e-12)  # normalised; basic CD
    R = direction_matrix(model, [(2, v)], rotation=True)
    assert R[0] @ u == pytest.approx(v @ (frame @ u[9:12]), rel=1e-12)
    # along a CD axis it equals point_matrix
    assert np.allclose(direction_matrix(model, [(2, frame[:, 1])]).toarray(),
                       point_matrix(model, [(2, 2)]).toarray())  # fmt: skip
    with pytest.raises(ValueError, match=r"point 2: direction .* has no length"):
        direction_matrix(model, [(2, [0, 0, 0])])
    with pytest.raises(ValueError, match="point 9: no GRID 9"):
        direction_matrix(model, [(9, v)])


@pytest.mark.parametrize(("args", "expected"), [
    (["--damping", "-1"], r"--damping -1: expected a damping ratio 0 <= Z < 1"),
    (["--damping", "nan"], r"--damping nan: expected a damping ratio"),
    (["--damping", "1.5"], r"--damping 1.5: expected a damping ratio"),
    (["--freq", "1:inf:1"], r"--freq 1:inf:1: expected finite numbers"),
    (["--freq", "5:1:1"], r"--freq 5:1:1: expected 0 <= F1 < F2 and DF > 0"),
    (["--freq", "1:1e9:0.001"], r"--freq 1:1e9:0.001 \(999,999,999,001 frequencies\) for 1 "
     r"outputs x 1 inputs would need 21\.8 TiB of memory; .* is available"),
    (["--modes-to", "-5"], r"--modes-to -5: expected a frequency above 0 Hz"),
])  # fmt: skip
def test_frf_command_refuses_bad_options_in_one_line_before_reading(tmp_path, capsys, args,
                                                                    expected):  # fmt: skip
    from femcal.cli import main

    argv = ["frf", str(tmp_path / "not-read.bdf"), "--input", "1:3", "--output", "2:3",
            "--freq", "1:100:1", "--out", str(tmp_path / "h.npz"), *args]  # fmt: skip
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("femcal frf: ")
    assert re.search(expected, err[0]), err[0]
    assert not (tmp_path / "h.npz").exists()


def test_frf_command_refuses_an_out_directory_and_a_band_without_modes(tmp_path, capsys):
    from femcal.cli import main

    from .conftest import REFDECKS

    deck = str(REFDECKS / "cofe_cantilever_cbar" / "noReduction.dat")
    base = ["frf", deck, "--input", "11:2", "--output", "11:2", "--freq", "1:100:9"]
    assert main([*base, "--out", str(tmp_path)]) == 2
    assert "is a directory; expected a file name" in capsys.readouterr().err
    (tmp_path / "afile").write_text("")
    assert main([*base, "--out", str(tmp_path / "afile" / "h.npz")]) == 2
    assert f"{tmp_path / 'afile'} is a file, not a directory" in capsys.readouterr().err
    # the first mode lies above 200 Hz: modes up to twice 100 Hz are none, the FRF would be 0
    assert main([*base, "--out", str(tmp_path / "h.npz")]) == 2
    assert "no mode up to 200 Hz: every FRF would be zero" in capsys.readouterr().err
    assert not (tmp_path / "h.npz").exists()
    assert main([*base, "--modes-to", "1000", "--out", str(tmp_path / "h.npz")]) == 0
