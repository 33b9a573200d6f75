"""Shell section resultants from PSHELL and PCOMP."""

from __future__ import annotations

import numpy as np
import pytest

from femcal.deck import read_deck
from femcal.markers import INT_BLANK
from femcal.model.build import build_model
from femcal.properties.materials import MaterialTables
from femcal.properties.shells import shell_sections

HEAD = "SOL 103\nCEND\nBEGIN BULK\nGRID,1\nGRID,2,,1.\nGRID,3,,1.,1.\nGRID,4,,0.,1.\n"


def sections(write, props: str, pid: int):
    model = build_model(read_deck(write(HEAD + props + f"CQUAD4,1,{pid},1,2,3,4\n")))
    return shell_sections(
        model.properties, MaterialTables(model.materials), np.array([pid]), np.array([1]),
        np.zeros(1), np.full((1, 4), np.nan), np.array([INT_BLANK]), "CQUAD4",
    )  # fmt: skip


def test_pshell_resultants(write):
    E, nu, t = 2.1e5, 0.3, 2.0
    s = sections(write, f"PSHELL,1,1,{t},1,,1\nMAT1,1,{E},,{nu},7.85-9\n", 1)
    Q = E / (1 - nu**2) * np.array([[1, nu, 0], [nu, 1, 0], [0, 0, (1 - nu) / 2]])
    assert np.allclose(s.A[0], t * Q) and np.allclose(s.D[0], t**3 / 12 * Q)
    assert np.allclose(s.S[0], 0.833333 * t * E / (2 * (1 + nu)) * np.eye(2))
    assert not s.shear_rigid[0] and s.rho_area[0] == pytest.approx(7.85e-9 * t)
    rigid = sections(write, f"PSHELL,1,1,{t},1\nMAT1,1,{E},,{nu}\n", 1)
    assert rigid.shear_rigid[0]  # no MID3: no transverse shear flexibility


def test_pcomp_symmetric_laminate_and_shear_rule(write):
    # Two 0/90 plies of MAT8, symmetric: B = 0, A = sum Q t, D from z^3 (classical lamination).
    mat8 = "MAT8,5,1.4+5,1.+4,.3,5.+3,{g},{g},1.6-9\n"
    ply = "PCOMP,7,,,,,,,SYM\n,5,.25,0.,,5,.25,90.\n"
    s = sections(write, ply + mat8.format(g="4.+3"), 7)
    assert np.allclose(s.B[0], 0.0, atol=1e-6 * abs(s.A[0]).max())
    assert s.A[0][0, 0] == pytest.approx(s.A[0][1, 1])  # as much 0 as 90 degree material
    assert not s.shear_rigid[0] and s.rho_area[0] == pytest.approx(1.6e-9 * 1.0)
    no_shear = sections(write, ply + mat8.format(g=""), 7)
    assert no_shear.shear_rigid[0]  # MAT8 without G1Z/G2Z: shear-rigid, as NASTRAN
