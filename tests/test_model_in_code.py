"""Models built in code (femcal.model.builder): no deck, no cards, solved like any other.

The cantilever is checked against Euler-Bernoulli; the mixed model against the same model
read from the equivalent deck (K and M bit for bit, and its modes)."""

from __future__ import annotations

import numpy as np
import pytest

from femcal.assembly import assemble
from femcal.errors import ModelError
from femcal.model import Params
from femcal.model.build import load_model
from femcal.model.builder import ModelBuilder
from femcal.solve.normal_modes import solve_normal_modes

E, NU, RHO = 210000.0, 0.3, 7.85e-9  # MPa, -, t/mm^3


def test_a_cantilever_built_in_code_has_euler_bernoulli_frequencies():
    L, n = 1000.0, 40
    A, I = 100.0, 100.0**2 / 12.0 * 10.0  # a 10 x 10 mm bar: I = 833.3 mm^4
    b = ModelBuilder()
    x = np.linspace(0.0, L, n + 1)
    b.grids(np.arange(1, n + 2), np.column_stack([x, np.zeros_like(x), np.zeros_like(x)]))
    b.material(1, E=E, nu=NU, rho=RHO)
    b.bar_section(7, 1, A=A, I1=I, I2=I, J=2 * I)
    b.bars(np.arange(1, n + 1), 7, np.column_stack([np.arange(1, n + 1), np.arange(2, n + 2)]),
           orientation=[0.0, 0.0, 1.0])  # fmt: skip
    b.fix([1])
    b.eigen(nd=4)
    b.params(Params(coupled_mass=True))
    modes, red = solve_normal_modes(b.build())
    # bending in both planes: pairs of equal roots, beta L = 1.87510, 4.69409
    f = modes.frequencies_hz
    unit = np.sqrt(E * I / (RHO * A * L**4)) / (2 * np.pi)
    np.testing.assert_allclose(f[[0, 1]], 1.875104**2 * unit, rtol=2e-5)
    np.testing.assert_allclose(f[[2, 3]], 4.694091**2 * unit, rtol=2e-5)
    assert len(red.a_dofs) == 6 * n  # the clamped node's six DOF are gone


MIXED_DECK = """SOL 103
CEND
METHOD = 1
SPC = 1
BEGIN BULK
EIGRL,1,,,12
MAT1,1,210000.,80769.23,0.3,7.85-9
MAT1,2,70000.,26923.08,0.3,2.7-9
PBAR,10,1,80.,600.,900.,1000.,2.
PROD,11,2,30.
PSHELL,12,2,3.,2,,2,0.833333
PSOLID,13,1
GRID,1,,0.,0.,0.
GRID,2,,100.,0.,0.
GRID,3,,100.,80.,0.
GRID,4,,0.,80.,0.
GRID,5,,200.,0.,0.
GRID,6,,200.,80.,0.
GRID,7,,0.,0.,50.
GRID,8,,100.,0.,50.
GRID,9,,100.,80.,50.
GRID,10,,0.,80.,50.
GRID,11,,300.,40.,0.
GRID,12,,250.,40.,-40.
CQUAD4,1,12,1,2,3,4
CTRIA3,2,12,2,5,6
CTRIA3,3,12,2,6,3
CHEXA,4,13,1,2,3,4,7,8,+
+,9,10
CTETRA,5,13,5,6,11,12
CBAR,6,10,10,3,1.,0.,0.
CROD,7,11,8,9
CONM2,8,11,,0.002
CELAS2,9,500.,12,3
RBE2,10,5,123,11
SPC1,1,123456,1,4
ENDDATA
"""


def _mixed_in_code() -> ModelBuilder:
    b = ModelBuilder()
    b.grids(range(1, 13), [[0, 0, 0], [100, 0, 0], [100, 80, 0], [0, 80, 0], [200, 0, 0],
                           [200, 80, 0], [0, 0, 50], [100, 0, 50], [100, 80, 50], [0, 80, 50],
                           [300, 40, 0], [250, 40, -40]])  # fmt: skip
    b.material(1, E=210000.0, G=80769.23, nu=0.3, rho=7.85e-9)
    b.material(2, E=70000.0, G=26923.08, nu=0.3, rho=2.7e-9)
    b.bar_section(10, 1, A=80.0, I1=600.0, I2=900.0, J=1000.0, nsm=2.0)
    b.rod_section(11, 2, A=30.0)
    b.shell_section(12, 2, t=3.0)
    b.solid_section(13, 1)
    b.quads(1, 12, [1, 2, 3, 4])
    b.trias([2, 3], 12, [[2, 5, 6], [2, 6, 3]])
    b.hexas(4, 13, [1, 2, 3, 4, 7, 8, 9, 10])
    b.tetras(5, 13, [5, 6, 11, 12])
    b.bars(6, 10, [10, 3], orientation=[1.0, 0.0, 0.0])
    b.rods(7, 11, [8, 9])
    b.masses(8, 11, 0.002)
    b.spring(9, 500.0, (12, 3))
    b.rigid(10, 5, [11], "123")
    b.fix([1, 4])
    b.eigen(nd=12)
    return b


def test_a_model_built_in_code_is_the_deck_built_one(write):
    from_deck = load_model(write(MIXED_DECK))
    in_code = _mixed_in_code().build()
    a, b = assemble(from_deck), assemble(in_code)
    for X, Y in ((a.K, b.K), (a.M, b.M)):
        assert (X != Y).nnz == 0  # every entry the same, bit for bit
    assert np.abs(a.K).max() > 0 and np.abs(a.M).max() > 0
    modes_deck, _ = solve_normal_modes(from_deck)
    modes_code, _ = solve_normal_modes(in_code)
    assert len(modes_code.frequencies_hz) == 12
    np.testing.assert_allclose(modes_code.frequencies_hz, modes_deck.frequencies_hz, rtol=1e-12)
    np.testing.assert_array_equal(in_code.constraints.fixed, from_deck.constraints.fixed)


def test_bad_parts_are_named():
    b = _mixed_in_code()
    b.quads(20, 12, [1, 2, 3, 99])
    with pytest.raises(ModelError, match=r"CQUAD4: nodes \[99\] do not exist"):
        b.build()
    b = _mixed_in_code()
    b.bars(21, 77, [1, 2], orientation=[0.0, 0.0, 1.0])
    with pytest.raises(ModelError, match=r"CBAR: sections \[77\] are not defined"):
        b.build()
    b = _mixed_in_code()
    b.rods(6, 11, [1, 2])  # 6 is the bar's id
    with pytest.raises(ModelError, match="element 6 is defined twice"):
        b.build()
    b = _mixed_in_code()
    with pytest.raises(ModelError, match="components '127'"):
        b.fix([2], "127")
    with pytest.raises(ModelError, match="the model has no nodes"):
        ModelBuilder().build()
    b = ModelBuilder()
    b.grids([1], [[0.0, 0.0, 0.0]])
    b.shell_section(1, 5, t=1.0)
    with pytest.raises(ModelError, match="PSHELL 1: material 5 is not defined"):
        b.build()
