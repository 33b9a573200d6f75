"""The drilling rotation of CQUAD4 / CTRIA3 where a bar meets a shell corner (issue 26).

What NASTRAN puts on it:

* [QRG] MSC Nastran Quick Reference Guide, PARAM K6ROT (default 100): the penalty on the
  normal rotation, ``1e-6 K6ROT G t`` times the element's area (G of MID1, t the thickness),
  none for a shell with MID1 alone.
* [MYSTRAN] MYSTRAN ``CALC_K6ROT.f90`` (MIT licence), whose authors matched MSC's matrices:
  one corner's normal rotation alone costs ``1e-6 K6ROT G t A`` on a CQUAD4 and ``1e-6 K6ROT
  G t 2A`` on a CTRIA3 ("actual area is half this but using this value gives the same
  stiffness as MSC").
* [SNORM] MSC QRG, PARAM SNORM (default 20): a grid's normal is the mean of its shells'
  normals when each lies within SNORM degrees of it; none at folds.

The decks: a flat CQUAD4 or CTRIA3 whose grids are fixed but for the corner rotation ``R3`` of
grid 1; a CBAR from grid 1 along the normal to a clamped grid twists that corner, a CONM2 of
inertia ``I33`` sits on it. The one mode is ``sqrt((k_corner + G J / L) / I33) / 2 pi``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from femcal.deck import read_deck
from femcal.elements.shell import grid_normals
from femcal.errors import FemcalWarning
from femcal.model.build import build_model
from femcal.solve.normal_modes import solve_normal_modes

E, NU, RHO = 2.1e5, 0.3, 7.85e-9
G = E / (2 * (1 + NU))
I33 = 1.0


def corner_deck(shape: str, t: float, k6rot: float | None, j_bar: float) -> str:
    """The deck of the module docstring: a 100 x 50 shell (``shape`` quad or tria) of
    thickness ``t``, a CBAR of length 100 and torsion constant ``j_bar`` along z at grid 1."""
    lines = ["SOL 103", "CEND", "METHOD = 1", "BEGIN BULK"]
    if k6rot is not None:
        lines.append(f"PARAM,K6ROT,{k6rot}")
    lines += [
        "EIGRL,1,,,1",
        "GRID,1,,0.,0.,0.,,12345",
        "GRID,2,,100.,0.,0.,,123456",
        "GRID,3,,100.,50.,0.,,123456",
        "GRID,4,,0.,50.,0.,,123456",
        "GRID,5,,0.,0.,100.,,123456",
        f"MAT1,1,{E},,{NU},{RHO}",
        f"PSHELL,1,1,{t},1,,1",
        "CQUAD4,10,1,1,2,3,4" if shape == "quad" else "CTRIA3,10,1,1,2,4",
        "CBAR,20,2,1,5,1.,0.,0.",
        f"PBAR,2,1,10.,1.,1.,{j_bar}",
        f"CONM2,30,1,,0.,,,,,\n,,,,,,{I33}",
        "ENDDATA",
    ]
    return "\n".join(lines) + "\n"


def corner_frequency(tmp_path, shape: str, t: float, k6rot: float | None, j_bar: float) -> float:
    path = tmp_path / f"corner_{shape}_{t}_{k6rot}_{j_bar}.bdf"
    path.write_text(corner_deck(shape, t, k6rot, j_bar))
    modes, _ = solve_normal_modes(build_model(read_deck(path)))
    assert len(modes.frequencies_hz) == 1
    return float(modes.frequencies_hz[0])


@pytest.mark.parametrize("shape", ["quad", "tria"])
@pytest.mark.parametrize(
    ("t", "k6rot"), [(2.0, None), (2.0, 1000.0), (5.0, None), (2.0, 1.0)]
)
def test_bar_twisting_a_shell_corner(tmp_path, shape: str, t: float, k6rot: float | None) -> None:
    area = 100.0 * 50.0 * (1.0 if shape == "quad" else 0.5)
    k_corner = 1e-6 * (100.0 if k6rot is None else k6rot) * G * t * area
    k_corner *= 2.0 if shape == "tria" else 1.0  # [MYSTRAN]
    j_bar = k_corner * 100.0 / G  # the bar as stiff in torsion as the corner
    want = math.sqrt((k_corner + G * j_bar / 100.0) / I33) / (2 * math.pi)
    got = corner_frequency(tmp_path, shape, t, k6rot, j_bar)
    # quad: the condensed incompatible modes relax the corner's penalty in proportion to it
    # (measured 2e-5 of the frequency at K6ROT 100, 2e-4 at 1000; see test_shell)
    assert got == pytest.approx(want, rel=1e-9 if shape == "tria" else 1e-3)


def test_shell_without_bending_gets_no_k6rot(tmp_path) -> None:
    """PSHELL with MID1 alone: NASTRAN sets K6ROT to 0 [QRG], so the corner is the bar's."""
    deck = corner_deck("quad", 2.0, None, 1.0).replace(f"PSHELL,1,1,{2.0},1,,1",
                                                       "PSHELL,1,1,2.0")  # fmt: skip
    path = tmp_path / "membrane.bdf"
    path.write_text(deck)
    modes, _ = solve_normal_modes(build_model(read_deck(path)))
    want = math.sqrt(G * 1.0 / 100.0 / I33) / (2 * math.pi)
    assert modes.frequencies_hz[0] == pytest.approx(want, rel=1e-9)


def test_grid_normals_follow_snorm() -> None:
    """[SNORM]: the mean of the normals where all lie within SNORM of it, none at a fold or
    with SNORM <= 0."""
    conn = np.array([[0, 1], [1, 2]])  # grid 1 shared by two shells
    tilt = np.radians(15.0)
    normals = np.array([[0.0, -np.sin(tilt), np.cos(tilt)], [0.0, np.sin(tilt), np.cos(tilt)]])
    n = grid_normals(3, [conn], [normals], 20.0)
    np.testing.assert_allclose(n[1], [0.0, 0.0, 1.0], atol=1e-15)  # 15 degrees each side
    np.testing.assert_allclose(n[0], normals[0])
    assert np.isnan(grid_normals(3, [conn], [normals], 14.0)[1]).all()  # a fold at SNORM 14
    assert np.isnan(grid_normals(3, [conn], [normals], 0.0)).all()


def test_given_grid_normals_are_named_not_passed_by(tmp_path) -> None:
    """A SNORM bulk card sets a grid's normal in NASTRAN; femcal makes its own and says so."""
    deck = corner_deck("quad", 2.0, None, 1.0).replace("ENDDATA", "SNORM,1,,0.,0.,1.\nENDDATA")
    path = tmp_path / "snorm.bdf"
    path.write_text(deck)
    with pytest.warns(FemcalWarning, match=r"snorm.bdf:\d+: SNORM \(1 card\): grid normals "
                      "given are not used"):  # fmt: skip
        build_model(read_deck(path))
