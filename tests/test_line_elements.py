"""Line elements, masses and springs: invariants and static checks against beam theory."""

from __future__ import annotations

import numpy as np
import pytest

from femcal.elements.line import bar_matrices, bush_matrices, line_frame, rod_matrices
from femcal.elements.mass import conm1_matrix, conm2_matrix
from femcal.properties.sections import section_properties, shear_factors

RNG = np.random.default_rng(7)


def rigid_modes(xyz: np.ndarray) -> np.ndarray:
    """(6*nodes, 6) rigid-body motions of nodes at xyz (nodes, 3), DOF [T R] per node."""
    n = len(xyz)
    R = np.zeros((6 * n, 6))
    for a, p in enumerate(xyz):
        R[6 * a : 6 * a + 3, 0:3] = np.eye(3)
        # u = theta x p  ->  columns for theta_x, theta_y, theta_z
        R[6 * a : 6 * a + 3, 3:6] = -np.array(
            [[0, -p[2], p[1]], [p[2], 0, -p[0]], [-p[1], p[0], 0]]
        )
        R[6 * a + 3 : 6 * a + 6, 3:6] = np.eye(3)
    return R


def random_bars(n: int):
    a = RNG.normal(size=(n, 3))
    b = a + RNG.normal(size=(n, 3)) * 3
    v = RNG.normal(size=(n, 3))
    return np.stack([a, b], axis=1), v


def check_invariants(K: np.ndarray, M: np.ndarray, xyz: np.ndarray, n_zero: int = 6) -> None:
    for k, m, x in zip(K, M, xyz, strict=True):
        assert np.allclose(k, k.T, atol=1e-9 * abs(k).max())
        assert np.allclose(m, m.T, atol=1e-12 * max(abs(m).max(), 1))
        w = np.linalg.eigvalsh(k)
        assert w.min() > -1e-9 * w.max()
        assert (w < 1e-9 * w.max()).sum() == n_zero
        R = rigid_modes(x)
        assert np.allclose(k @ R, 0.0, atol=1e-8 * abs(k).max() * max(1, abs(x).max()))


@pytest.mark.parametrize("coupled", [False, True])
def test_rod_invariants_and_mass(coupled):
    xyz, _ = random_bars(5)
    E, G, A, J = np.full(5, 2e5), np.full(5, 8e4), np.full(5, 3.0), np.full(5, 2.0)
    rho, nsm = np.full(5, 7.85e-9), np.full(5, 1e-6)
    K, M = rod_matrices(xyz, E, G, A, J, rho, nsm, coupled_mass=coupled)
    # a rod has stiffness only along and about its axis: 12 - 2 = 10 zero-energy modes
    check_invariants(K, M, xyz, n_zero=10)
    L = np.linalg.norm(xyz[:, 1] - xyz[:, 0], axis=1)
    R = rigid_modes(np.zeros((2, 3)))[:, :3]
    total = np.einsum("ki,nkl,lj->nij", R, M, R)
    assert np.allclose(total, ((rho * A + nsm) * L)[:, None, None] * np.eye(3))


@pytest.mark.parametrize("coupled", [False, True])
def test_bar_invariants_offsets_and_pins(coupled):
    n = 6
    xyz, v = random_bars(n)
    sec = np.column_stack(
        [np.full(n, 5.0), np.full(n, 4.0), np.full(n, 3.0), np.full(n, 0.5), np.full(n, 6.0)]
    )
    wa = RNG.normal(size=(n, 3)) * 0.3
    wb = RNG.normal(size=(n, 3)) * 0.3
    E, G = np.full(n, 2e5), np.full(n, 8e4)
    mpl = np.full(n, 4e-8)
    K, M = bar_matrices(
        xyz, v, wa, wb, E, G, sec, np.full(n, 5 / 6), np.full(n, np.nan), mpl, coupled_mass=coupled
    )
    check_invariants(K, M, xyz)
    # total translational mass is carried through the offsets: m L at the ends
    L = np.linalg.norm((xyz[:, 1] + wb) - (xyz[:, 0] + wa), axis=1)
    R = rigid_modes(np.zeros((2, 3)))[:, :3]
    assert np.allclose(np.einsum("ki,nkl,lj->nij", R, M, R), (mpl * L)[:, None, None] * np.eye(3))
    # a pin (moment release about z at end A) removes one deformation mode
    Kp, _ = bar_matrices(
        xyz,
        v,
        wa,
        wb,
        E,
        G,
        sec,
        np.full(n, 5 / 6),
        np.full(n, np.nan),
        mpl,
        pa=np.full(n, 6),
        pb=np.zeros(n, int),
    )
    check_invariants(Kp, M, xyz, n_zero=7)


def cantilever_tip(K: np.ndarray, load_dof: int) -> np.ndarray:
    """Tip displacements of one element clamped at end A under a unit load at end-B DOF."""
    kbb = K[6:, 6:]
    f = np.zeros(6)
    f[load_dof] = 1.0
    return np.linalg.solve(kbb, f)


def test_cbar_cantilever_matches_timoshenko_and_euler_bernoulli():
    # One element is exact for a tip load (cubic field); reference: Timoshenko beam theory.
    L, E, G, A, I1, I2, J = 1000.0, 2.1e5, 8.1e4, 200.0, 1.5e4, 4.0e3, 2.0e3
    xyz = np.array([[[0, 0, 0], [L, 0, 0]]], float)
    v = np.array([[0, 1.0, 0]])
    sec = np.array([[A, I1, I2, 0.0, J]])
    z = np.zeros((1, 3))
    for k1, shear in ((np.nan, 0.0), (5 / 6, L / (5 / 6 * G * A))):
        K, _ = bar_matrices(
            xyz,
            v,
            z,
            z,
            np.array([E]),
            np.array([G]),
            sec,
            np.array([k1]),
            np.array([k1]),
            np.array([0.0]),
        )
        d = cantilever_tip(K[0], 1)  # force along basic y = element y (plane 1, I1)
        assert d[1] == pytest.approx(L**3 / (3 * E * I1) + shear, rel=1e-10)
        assert d[5] == pytest.approx(L**2 / (2 * E * I1), rel=1e-10)
        d = cantilever_tip(K[0], 2)  # plane 2
        assert d[2] == pytest.approx(L**3 / (3 * E * I2) + shear, rel=1e-10)
        assert d[4] == pytest.approx(-(L**2) / (2 * E * I2), rel=1e-10)
        d = cantilever_tip(K[0], 3)
        assert d[3] == pytest.approx(L / (G * J), rel=1e-12)
        d = cantilever_tip(K[0], 0)
        assert d[0] == pytest.approx(L / (E * A), rel=1e-12)


def test_tapered_beam_flexibility_is_nastrans_three_point_rule():
    # Linear taper of I1 from 2 to 6: tip flexibility integral (L - x)^2 / (E I(x)) dx, which
    # NASTRAN's CBEAM evaluates with 3 Gauss points (matched on refdecks/pyn_fmondsp, whose
    # tapered tubes' 18 modes agree to 3e-7 with it and are 0.107 % off with the exact
    # integral; tests/test_conformance.py). The rule is computed here from its points.
    from femcal.elements.line import FLEX_X

    L, E = 100.0, 1.0e4
    ia, ib = 2.0, 6.0
    sec = np.zeros((1, len(FLEX_X), 5))
    sec[0, :, 0], sec[0, :, 1], sec[0, :, 2], sec[0, :, 4] = 1.0, ia + (ib - ia) * FLEX_X, 1.0, 1.0
    xyz = np.array([[[0, 0, 0], [L, 0, 0]]], float)
    K, _ = bar_matrices(
        xyz, np.array([[0, 1.0, 0]]), np.zeros((1, 3)), np.zeros((1, 3)), np.array([E]),
        np.array([E / 2.6]), sec, np.array([np.nan]), np.array([np.nan]), np.array([0.0]),
    )  # fmt: skip
    g, w = np.polynomial.legendre.leggauss(3)
    x = L * (g + 1) / 2
    three_point = (L * w / 2 * (L - x) ** 2 / (E * (ia + (ib - ia) * x / L))).sum()
    tip = cantilever_tip(K[0], 1)[1]
    assert tip == pytest.approx(three_point, rel=1e-12)
    xs = np.linspace(0, L, 200001)
    exact = np.trapezoid((L - xs) ** 2 / (E * (ia + (ib - ia) * xs / L)), xs)
    assert tip != pytest.approx(exact, rel=1e-4)  # the rule is not the exact integral here


@pytest.mark.parametrize("coupled", [False, True])
def test_tapered_beam_mass_keeps_total_mass_centre_and_rotary_inertia(coupled):
    # A linear taper of the mass per length from m_a to m_b along a member on x. Exact:
    # total mass L (m_a + m_b) / 2, first moment about end A L^2 (m_a + 2 m_b) / 6, and
    # (coupled, whose Hermite shapes hold the rigid rotation exactly) second moment
    # L^3 (m_a + 3 m_b) / 12. The lumped ends are the centre-keeping shares
    # L (2 m_a + m_b) / 6 and L (m_a + 2 m_b) / 6; the torsion inertia is shared the same way.
    from femcal.elements.line import MASS_X

    L, ma, mb, ja, jb = 2.5, 3.0, 11.0, 0.2, 0.9
    xyz = np.array([[[0, 0, 0], [L, 0, 0]]], float)
    sec = np.tile([1.0, 1.0, 1.0, 0.0, 1.0], (1, 1))
    _, M = bar_matrices(
        xyz, np.array([[0, 1.0, 0]]), np.zeros((1, 3)), np.zeros((1, 3)),
        np.array([1.0]), np.array([0.4]), sec, np.array([np.nan]), np.array([np.nan]),
        (ma + (mb - ma) * MASS_X)[None], coupled_mass=coupled,
        torsion_inertia=(ja + (jb - ja) * MASS_X)[None],
    )  # fmt: skip
    M = M[0]
    total = L * (ma + mb) / 2
    first = L**2 * (ma + 2 * mb) / 6
    ty = np.zeros(12)
    ty[[1, 7]] = 1.0  # rigid translation along y
    rz = np.zeros(12)
    rz[[5, 11]] = 1.0
    rz[7] = L  # rigid rotation about z through end A: v = x theta
    assert ty @ M @ ty == pytest.approx(total, rel=1e-12)
    assert ty @ M @ rz == pytest.approx(first, rel=1e-12)
    if coupled:
        assert rz @ M @ rz == pytest.approx(L**3 * (ma + 3 * mb) / 12, rel=1e-12)
    else:
        assert M[1, 1] == pytest.approx(L * (2 * ma + mb) / 6, rel=1e-12)
        assert M[7, 7] == pytest.approx(L * (ma + 2 * mb) / 6, rel=1e-12)
    assert M[3, 3] == pytest.approx(L * (2 * ja + jb) / 6, rel=1e-12)
    assert M[9, 9] == pytest.approx(L * (ja + 2 * jb) / 6, rel=1e-12)


def test_line_frame_errors():
    with pytest.raises(ValueError, match="zero-length"):
        line_frame(np.zeros((1, 3)), np.zeros((1, 3)), np.array([[0, 1.0, 0]]))
    with pytest.raises(ValueError, match="parallel"):
        line_frame(np.zeros((1, 3)), np.array([[1.0, 0, 0]]), np.array([[2.0, 0, 0]]))


def test_bush_rigid_modes_and_spring_rates():
    xyz = np.array([[[0, 0, 0], [10.0, 0, 0]], [[1, 2, 3], [1, 2, 3]]])
    R = np.tile(np.eye(3), (2, 1, 1))
    k = np.array([[1.0, 2, 3, 4, 5, 6], [10, 20, 30, 40, 50, 60]])
    K = bush_matrices(xyz, R, k, np.array([0.5, 0.5]), np.array([False, False]))
    check_invariants(K, np.zeros_like(K), xyz, n_zero=6)
    # coincident bush: pure springs between the two grids
    assert np.allclose(np.diag(K[1])[:6], k[1]) and np.allclose(K[1][:6, 6:], -np.diag(k[1]))
    Kg = bush_matrices(xyz[:1], R[:1], k[:1], np.array([0.0]), np.array([True]))
    assert np.allclose(np.diag(Kg[0])[:6], k[0]) and not Kg[0][6:].any()


def test_conm2_parallel_axis_and_sign_convention():
    m = np.array([2.0])
    r = np.array([[1.0, 2.0, 3.0]])
    inertia = np.array([[10.0, 1.0, 20.0, 2.0, 3.0, 30.0]])  # I11 I21 I22 I31 I32 I33
    M = conm2_matrix(m, r, inertia, np.eye(3)[None])[0]
    J = np.array([[10.0, -1.0, -2.0], [-1.0, 20.0, -3.0], [-2.0, -3.0, 30.0]])
    expected = J + 2.0 * (r[0] @ r[0] * np.eye(3) - np.outer(r[0], r[0]))
    assert np.allclose(M[3:, 3:], expected)
    # kinetic energy of a rigid rotation w about the grid equals that of the mass at r
    w = np.array([0.3, -0.2, 0.5])
    v = np.concatenate([np.zeros(3), w])
    vcg = np.cross(w, r[0])
    assert v @ M @ v == pytest.approx(2.0 * vcg @ vcg + w @ J @ w)
    assert np.allclose(M, M.T)


def test_conm1_rotated_frame():
    lower = np.arange(1, 22, dtype=float)[None]
    c, s = np.cos(0.4), np.sin(0.4)
    T = np.array([[[c, -s, 0], [s, c, 0], [0, 0, 1]]])
    M = conm1_matrix(lower, T)[0]
    M0 = conm1_matrix(lower, np.eye(3)[None])[0]
    T6 = np.kron(np.eye(2), T[0])
    assert np.allclose(M, T6 @ M0 @ T6.T) and np.allclose(M, M.T)


@pytest.mark.parametrize(
    ("kind", "dims", "props"),
    [
        ("ROD", [2.0], [np.pi * 4, np.pi * 4, np.pi * 4, 0.0, np.pi * 8]),
        ("TUBE", [2.0, 1.0], [np.pi * 3, np.pi * 15 / 4, np.pi * 15 / 4, 0.0, np.pi * 15 / 2]),
        ("BAR", [2.0, 4.0], [8.0, 2 * 64 / 12, 4 * 8 / 12, 0.0, None]),
        (
            "BOX",
            [4.0, 6.0, 1.0, 0.5],
            [4 * 6 - 3 * 4, (4 * 216 - 3 * 64) / 12, (6 * 64 - 4 * 27) / 12, 0.0, None],
        ),
    ],
)
def test_section_library(kind, dims, props):
    got = section_properties(kind, np.array([dims]))[0]
    for g, p in zip(got, props, strict=True):
        if p is not None:
            assert g == pytest.approx(p)
    assert np.isfinite(shear_factors(kind, np.array([dims]))).all()


def test_unknown_section_type_is_named():
    with pytest.raises(ValueError, match="HAT1 is not supported"):
        section_properties("HAT1", np.ones((1, 5)))
