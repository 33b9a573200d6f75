"""Two-node line elements: rods (CROD, CONROD, CTUBE), bars and beams (CBAR, CBEAM), bushes
(CBUSH).

Bars and beams use one flexibility-based formulation: the 6 x 6 flexibility of the element
clamped at end A is integrated along its length (Gauss-Legendre) from the section compliance
(axial, shear with factors K1/K2, torsion, bending with I1, I2, I12), inverted, and expanded to
12 DOF through the rigid-body relation between the ends. For a uniform section this is the exact
Timoshenko (or, with no shear flexibility, Euler-Bernoulli) stiffness. For a tapered section
(PBEAM stations, PBEAML dimensions, properties interpolated linearly between the stations) the
flexibility is integrated with the 3-point Gauss rule, as NASTRAN's CBEAM does: with it femcal
reproduces all 18 modes of refdecks/pyn_fmondsp (tapered tubes, section ratios up to 20) to
3e-7: the rule is part of NASTRAN's element, not an approximation of the exact integral.

Element frame (NASTRAN CBAR/CBEAM): x from end A to end B (after offsets), y in the plane of
x and the orientation vector v, z = x cross y. Plane 1 is x-y (bending about z, moment of
inertia I1, shear factor K1), plane 2 is x-z (I2, K2).

Local DOF order at each end: u, v, w (translations along x, y, z), rx, ry, rz.
"""

from __future__ import annotations

import numpy as np


def _gauss01(n: int) -> tuple[np.ndarray, np.ndarray]:
    x, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (x + 1.0), 0.5 * w


#: Gauss-Legendre stations on [0, 1] at which a member's mass per length is integrated (exact
#: for the linear taper with the cubic shapes of the coupled mass).
MASS_X, MASS_W = _gauss01(8)
#: Stations of the flexibility integral: NASTRAN's 3-point rule (exact for a uniform member).
FLEX_X, FLEX_W = _gauss01(3)


def skew(v: np.ndarray) -> np.ndarray:
    """(..., 3) -> (..., 3, 3) matrices S with S @ w = v x w."""
    s = np.zeros((*v.shape[:-1], 3, 3))
    s[..., 0, 1], s[..., 0, 2] = -v[..., 2], v[..., 1]
    s[..., 1, 0], s[..., 1, 2] = v[..., 2], -v[..., 0]
    s[..., 2, 0], s[..., 2, 1] = -v[..., 1], v[..., 0]
    return s


def line_frame(a: np.ndarray, b: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Element frames of line elements.

    Parameters
    ----------
    a, b : (n, 3) end points in basic.
    v : (n, 3) orientation vectors in basic (need not be unit or normal to x).

    Returns
    -------
    R : (n, 3, 3) rows are the element x, y, z axes in basic.
    length : (n,)

    Raises
    ------
    ValueError
        If an element has zero length or v is parallel to its axis (positions listed).
    """
    d = b - a
    length = np.linalg.norm(d, axis=1)
    bad = np.flatnonzero(length <= 0.0)
    if len(bad):
        raise ValueError(f"zero-length elements at positions {bad[:20].tolist()}")
    x = d / length[:, None]
    y = v - np.einsum("ni,ni->n", v, x)[:, None] * x
    ny = np.linalg.norm(y, axis=1)
    bad = np.flatnonzero(ny <= 1e-9 * np.maximum(np.linalg.norm(v, axis=1), 1e-300))
    if len(bad):
        raise ValueError(
            f"orientation vector parallel to the element axis at positions {bad[:20].tolist()}"
        )
    y = y / ny[:, None]
    z = np.cross(x, y)
    return np.stack([x, y, z], axis=1), length


def _block_rotation(R: np.ndarray, nodes: int) -> np.ndarray:
    """(n, 3, 3) -> (n, 6*nodes, 6*nodes) block-diagonal rotation (local = T @ basic)."""
    n = len(R)
    T = np.zeros((n, 6 * nodes, 6 * nodes))
    for k in range(2 * nodes):
        T[:, 3 * k : 3 * k + 3, 3 * k : 3 * k + 3] = R
    return T


def _to_basic(k_local: np.ndarray, R: np.ndarray) -> np.ndarray:
    T = _block_rotation(R, 2)
    return np.einsum("nki,nkl,nlj->nij", T, k_local, T)


def _offset_matrix(wa: np.ndarray, wb: np.ndarray) -> np.ndarray:
    """(n, 12, 12) map from grid DOF to element-end DOF for rigid offsets wa, wb (basic)."""
    n = len(wa)
    T = np.tile(np.eye(12), (n, 1, 1))
    T[:, 0:3, 3:6] = -skew(wa)
    T[:, 6:9, 9:12] = -skew(wb)
    return T


# ------------------------------------------------------------------------------ rods


def rod_matrices(
    xyz: np.ndarray,
    E: np.ndarray,
    G: np.ndarray,
    A: np.ndarray,
    J: np.ndarray,
    rho: np.ndarray,
    nsm: np.ndarray,
    *,
    coupled_mass: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """CROD / CONROD / CTUBE: axial and torsional stiffness, translational mass.

    Parameters
    ----------
    xyz : (n, 2, 3) end points in basic.
    E, G, A, J, rho, nsm : (n,) modulus, shear modulus, area, torsion constant, density,
        non-structural mass per length.
    coupled_mass : False: half the mass m = (rho A + nsm) L at each end in all three
        directions. True: NASTRAN's coupled rod mass: along the axis the mean of the lumped
        and the consistent matrices, m [[5/12, 1/12], [1/12, 5/12]]; across it, lumped. (Matched
        to MSC Nastran 2019 on refdecks/cofe_ten_bar_truss to 1e-5 relative.)

    Returns
    -------
    K, M : (n, 12, 12) in basic, DOF [T1 T2 T3 R1 R2 R3] at each end.
    """
    d = xyz[:, 1] - xyz[:, 0]
    L = np.linalg.norm(d, axis=1)
    bad = np.flatnonzero(L <= 0.0)
    if len(bad):
        raise ValueError(f"zero-length rods at positions {bad[:20].tolist()}")
    e = d / L[:, None]
    ee = np.einsum("ni,nj->nij", e, e)
    sign = np.array([[1.0, -1.0], [-1.0, 1.0]])
    K = np.zeros((len(L), 12, 12))
    ka = (E * A / L)[:, None, None] * ee
    kt = (G * J / L)[:, None, None] * ee
    for i in range(2):
        for j in range(2):
            K[:, 6 * i : 6 * i + 3, 6 * j : 6 * j + 3] = sign[i, j] * ka
            K[:, 6 * i + 3 : 6 * i + 6, 6 * j + 3 : 6 * j + 6] = sign[i, j] * kt
    m = (rho * A + nsm) * L
    M = np.zeros_like(K)
    axial = np.array([[5.0, 1.0], [1.0, 5.0]]) / 12.0 if coupled_mass else np.eye(2) / 2.0
    across = np.eye(3) - ee
    for i in range(2):
        for j in range(2):
            block = axial[i, j] * ee + (0.5 * across if i == j else 0.0)
            M[:, 6 * i : 6 * i + 3, 6 * j : 6 * j + 3] = m[:, None, None] * block
    return K, M


# ------------------------------------------------------------------------------ bars / beams

#: A zero A, I1, I2 or J (or a zero E or G) is taken as this fraction of the section's
#: (material's) largest (see :func:`beam_stiffness_local`).
ZERO_STIFFNESS = 1e-9


def beam_stiffness_local(
    L: np.ndarray,
    E: np.ndarray,
    G: np.ndarray,
    section: np.ndarray,
    k1: np.ndarray,
    k2: np.ndarray,
) -> np.ndarray:
    """Local 12 x 12 stiffness of straight bars/beams from their section along the length.

    Parameters
    ----------
    L : (n,) lengths.
    E, G : (n,) moduli.
    section : (n, 3, 5) section properties A, I1, I2, I12, J at the stations ``FLEX_X``,
        or (n, 5) for a uniform section.
    k1, k2 : (n,) shear factors (shear stiffness K A G); 0 or NaN = no shear flexibility.

    Returns
    -------
    (n, 12, 12) in the element frame.

    Raises
    ------
    ValueError
        For a negative A, I1, I2, J, E or G, or an I12 with I1 * I2 <= I12^2 (positions
        listed).
    """
    n = len(L)
    if section.ndim == 2:
        section = np.broadcast_to(section[:, None, :], (n, len(FLEX_X), 5))
    A, I1, I2, I12, J = (section[..., i] for i in range(5))
    # QRG PBAR: A, I1, I2, J default 0.0 (I1*I2 > I12^2 where I12 is given); QRG MAT1: E,
    # G >= 0. A negative one would be a negative stiffness, which femcal does not solve.
    bad = np.flatnonzero(((A < 0) | (J < 0) | (I1 < 0) | (I2 < 0)).any(axis=1))
    if len(bad):
        raise ValueError(f"bars/beams need A, I1, I2, J >= 0 (positions {bad[:20].tolist()})")
    bad = np.flatnonzero((E < 0) | (G < 0))
    if len(bad):
        raise ValueError("bars/beams need materials with E >= 0 and G >= 0 (positions "
                         f"{bad[:20].tolist()})")  # fmt: skip
    bad = np.flatnonzero(((I12 != 0) & (I1 * I2 <= I12**2)).any(axis=1))
    if len(bad):
        raise ValueError(f"bars/beams with an I12 need I1*I2 > I12^2 (positions "
                         f"{bad[:20].tolist()})")  # fmt: skip
    # A zero A, I1, I2 or J (a blank field) is no stiffness in that direction, and so is a
    # zero E or G (QRG MAT1: a blank G with NU blank is 0.0): NASTRAN's bar then has none
    # there, and the deck holds those motions by constraints where it matters. The
    # compliance takes each as ZERO_STIFFNESS of the largest of its kind (the stiffness so
    # made is that small, and the flexibility stays invertible); a shear factor with a zero
    # A or G so gives no transverse stiffness, as NASTRAN's K1*A*G of 0 does. An element
    # with no modulus or no section at all has no stiffness.
    scale = np.maximum.reduce([I1, I2, J, A * L[:, None] ** 2 / 12.0])
    modulus = np.maximum(E, G)
    dead = (modulus <= 0) | (scale <= 0).any(axis=1)
    scale = np.where(dead[:, None], 1.0, scale)
    modulus = np.where(dead, 1.0, modulus)
    floor = ZERO_STIFFNESS * scale
    I1, I2, J = (np.where(v > 0, v, floor) for v in (I1, I2, J))
    A = np.where(A > 0, A, 12.0 * floor / L[:, None] ** 2)
    E, G = (np.where(v > 0, v, ZERO_STIFFNESS * modulus) for v in (E, G))
    det = I1 * I2 - I12**2
    # Compliance of the section, (n, q, 6, 6) on [N, Vy, Vz, T, My, Mz].
    Cs = np.zeros((*A.shape, 6, 6))
    Cs[..., 0, 0] = 1.0 / (E[:, None] * A)
    for idx, k in ((1, k1), (2, k2)):
        k = np.where(np.isnan(k), 0.0, k)
        with np.errstate(divide="ignore"):
            shear = np.where(k[:, None] > 0, 1.0 / (k[:, None] * G[:, None] * A), 0.0)
        Cs[..., idx, idx] = shear
    Cs[..., 3, 3] = 1.0 / (G[:, None] * J)
    # Bending: Mz = E (I1 kz + I12 ky), My = E (I12 kz + I2 ky)  ->  inverse on (My, Mz).
    Cs[..., 4, 4] = I1 / (E[:, None] * det)
    Cs[..., 5, 5] = I2 / (E[:, None] * det)
    Cs[..., 4, 5] = Cs[..., 5, 4] = -I12 / (E[:, None] * det)
    # Section forces at x from end-B forces: My(x) = My_B - (L - x) Vz_B, Mz = Mz_B + (L - x) Vy_B.
    s = L[:, None] * (1.0 - FLEX_X[None, :])  # (n, q) distance to end B
    P = np.zeros((*A.shape, 6, 6))
    for i in range(6):
        P[..., i, i] = 1.0
    P[..., 4, 2] = -s
    P[..., 5, 1] = s
    w = (L[:, None] * FLEX_W[None, :])[..., None, None]
    F = np.einsum("nqki,nqkl,nqlj->nij", P, Cs * w, P)
    Kbb = np.linalg.inv(F)
    # Relative displacement of B with respect to the rigid motion of A (local frame).
    H = np.zeros((n, 6, 12))
    H[:, :, 6:12] = np.eye(6)
    H[:, :, 0:6] = -np.eye(6)
    H[:, 1, 5] = -L  # v_B - (v_A + L rz_A)
    H[:, 2, 4] = L  # w_B - (w_A - L ry_A)
    K = np.einsum("nki,nkl,nlj->nij", H, Kbb, H)
    K[dead] = 0.0
    return K


def _along(values: np.ndarray, n: int) -> np.ndarray:
    """(n,) uniform or (n, q) values at the Gauss stations ``MASS_X`` -> (n, q)."""
    values = np.asarray(values, dtype=float)
    if values.ndim == 1:
        return np.broadcast_to(values[:, None], (n, len(MASS_X)))
    return values


def _end_shares(L: np.ndarray, per_length: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lumped end values of a quantity per length (n, q): the shares that keep its total and
    its centre, int q (1 - x/L) dx at end A and int q x/L dx at end B; (n,) each."""
    wl = L[:, None] * MASS_W[None, :] * per_length
    return (wl * (1.0 - MASS_X)).sum(axis=1), (wl * MASS_X).sum(axis=1)


def beam_mass_local(
    L: np.ndarray,
    mass_per_length: np.ndarray,
    *,
    coupled: bool,
    torsion_inertia: np.ndarray | None = None,
) -> np.ndarray:
    """Local 12 x 12 mass of bars/beams.

    ``mass_per_length``: (n,) uniform, or (n, q) at the Gauss stations ``MASS_X`` of a
    tapered member (mass/length). ``torsion_inertia``: mass moment of inertia per length about
    the axis, (n,) or (n, q) (CBEAM: rho (I1 + I2) + NSI); None for CBAR, which NASTRAN gives
    none.

    Lumped: each end gets the share of the mass that keeps the member's total mass and centre
    of mass, int m (1 - x/L) dx at end A and int m x/L dx at end B, on the translations; half
    each for a uniform member. (A linear taper from m_A to m_B gives L (2 m_A + m_B) / 6 at
    end A. NASTRAN lumps so: with these shares femcal's rigid-body mass matrix of
    refdecks/pyn_fmondsp, whose tubes taper, is NASTRAN's grid point weight generator output to
    7e-7; tests/test_conformance.py.) The torsion inertia is shared the same way, lumped or
    coupled.
    Coupled: along the axis the mean of the lumped and the linear consistent matrices, across
    it the cubic Hermite consistent mass, both integrated with the varying mass per length.
    (These masses match NASTRAN on refdecks/cofe_svanberg_bar and _beam, ekm_swept_plane and
    yeti_full_cbar_rbe2.)
    """
    n = len(L)
    mq = _along(mass_per_length, n)
    end_a, end_b = _end_shares(L, mq)
    M = np.zeros((n, 12, 12))
    if torsion_inertia is not None:
        M[:, 3, 3], M[:, 9, 9] = _end_shares(L, _along(torsion_inertia, n))
    if not coupled:
        for k in (0, 1, 2):
            M[:, k, k] = end_a
            M[:, k + 6, k + 6] = end_b
        return M
    x = MASS_X
    wl = L[:, None] * MASS_W[None, :] * mq  # (n, q)
    # axial: the mean of lumped and consistent (m [[5, 1], [1, 5]] / 12 when uniform), as
    # NASTRAN's coupled mass has it (all 278 modes of refdecks/yeti_full_cbar_rbe2 to 5e-7)
    lin = np.stack([1.0 - x, x])  # (2, q)
    axial = np.einsum("nq,aq,bq->nab", wl, lin, lin)
    axial[:, 0, 0] += end_a
    axial[:, 1, 1] += end_b
    M[:, 0::6, 0::6] = axial / 2.0
    # transverse, plane 1 (v, rz) and plane 2 (w, -ry): cubic Hermite consistent mass
    herm = np.stack([1 - 3 * x**2 + 2 * x**3, x - 2 * x**2 + x**3, 3 * x**2 - 2 * x**3,
                     -(x**2) + x**3])  # (4, q), slopes per unit x/L  # fmt: skip
    Mt = np.einsum("nq,aq,bq->nab", wl, herm, herm)
    scale = np.stack([np.ones(n), L, np.ones(n), L], axis=1)  # slopes in rad: times L
    Mt *= scale[:, :, None] * scale[:, None, :]
    for dofs, sgn in (((1, 5, 7, 11), (1, 1, 1, 1)), ((2, 4, 8, 10), (1, -1, 1, -1))):
        s = np.array(sgn, float)
        M[:, np.array(dofs)[:, None], np.array(dofs)[None, :]] = Mt * np.outer(s, s)
    return M


def bar_matrices(
    xyz: np.ndarray,
    v: np.ndarray,
    wa: np.ndarray,
    wb: np.ndarray,
    E: np.ndarray,
    G: np.ndarray,
    section: np.ndarray,
    k1: np.ndarray,
    k2: np.ndarray,
    mass_per_length: np.ndarray,
    *,
    pa: np.ndarray | None = None,
    pb: np.ndarray | None = None,
    coupled_mass: bool = False,
    torsion_inertia: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """CBAR / CBEAM stiffness and mass in basic.

    Parameters
    ----------
    xyz : (n, 2, 3) grid positions GA, GB (basic).
    v : (n, 3) orientation vector (basic).
    wa, wb : (n, 3) offsets from GA and GB to the element ends (basic).
    E, G : (n,) moduli.
    section : (n, 5) uniform A, I1, I2, I12, J, or (n, 3, 5) at the stations ``FLEX_X``.
    k1, k2 : (n,) shear factors (0 or NaN: no shear flexibility).
    mass_per_length : (n,) rho A + nsm, or (n, 8) at the Gauss stations ``MASS_X``.
    pa, pb : (n,) pin-flag codes (e.g. 456: release rotations at that end, element frame);
        0 or None for none. Released DOF carry no force: statically condensed out of K.
    coupled_mass : NASTRAN COUPMASS (see :func:`beam_mass_local`).
    torsion_inertia : (n,) or (n, 8) mass moment of inertia per length about the axis
        (CBEAM), or None.

    Returns
    -------
    K, M : (n, 12, 12) in basic, DOF [T1 T2 T3 R1 R2 R3] at GA then GB.
    """
    a = xyz[:, 0] + wa
    b = xyz[:, 1] + wb
    R, L = line_frame(a, b, v)
    k_loc = beam_stiffness_local(L, E, G, section, k1, k2)
    if pa is not None or pb is not None:
        k_loc = _release_pins(k_loc, pa, pb)
    m_loc = beam_mass_local(
        L, mass_per_length, coupled=coupled_mass, torsion_inertia=torsion_inertia
    )
    Toff = _offset_matrix(wa, wb)
    K = np.einsum("nki,nkl,nlj->nij", Toff, _to_basic(k_loc, R), Toff)
    M = np.einsum("nki,nkl,nlj->nij", Toff, _to_basic(m_loc, R), Toff)
    return K, M


def _release_pins(k: np.ndarray, pa: np.ndarray | None, pb: np.ndarray | None) -> np.ndarray:
    """Condense out released end DOF (pin flags), one group of equal flags at a time."""
    n = len(k)
    pa = np.zeros(n, np.int64) if pa is None else np.asarray(pa)
    pb = np.zeros(n, np.int64) if pb is None else np.asarray(pb)
    out = k.copy()
    for fa, fb in {(int(x), int(y)) for x, y in zip(pa, pb, strict=True)}:
        if fa <= 0 and fb <= 0:
            continue
        rel = [int(c) - 1 for c in str(fa)] if fa > 0 else []
        rel += [6 + int(c) - 1 for c in str(fb)] if fb > 0 else []
        keep = [i for i in range(12) if i not in rel]
        # an element without stiffness (see beam_stiffness_local) has nothing to release
        sel = np.flatnonzero((pa == fa) & (pb == fb) & np.abs(k).any(axis=(1, 2)))
        kk = k[sel]
        krr = kk[:, keep][:, :, keep]
        krp = kk[:, keep][:, :, rel]
        kpp = kk[:, rel][:, :, rel]
        cond = krr - krp @ np.linalg.solve(kpp, np.swapaxes(krp, 1, 2))
        block = np.zeros((len(sel), 12, 12))
        block[:, np.ix_(keep, keep)[0], np.ix_(keep, keep)[1]] = cond
        out[sel] = block
    return out


# ------------------------------------------------------------------------------ bushes


def bush_matrices(
    xyz: np.ndarray,
    R: np.ndarray,
    k: np.ndarray,
    s: np.ndarray,
    grounded: np.ndarray,
) -> np.ndarray:
    """CBUSH: six springs between GA and GB in the element frame R, acting at a point S of the
    way from GA to GB (rigidly connected to both grids).

    Parameters
    ----------
    xyz : (n, 2, 3) GA, GB positions (GB may equal GA; for grounded bushes GB is ignored).
    R : (n, 3, 3) rows are the spring axes in basic.
    k : (n, 6) stiffnesses K1..K6 (translations then rotations, element frame).
    s : (n,) location of the spring from GA (0) to GB (1).
    grounded : (n,) True where GB is blank (ground).

    Returns
    -------
    K : (n, 12, 12) in basic; rows/columns of GB are zero for grounded bushes.
    """
    n = len(k)
    p = xyz[:, 0] + s[:, None] * (xyz[:, 1] - xyz[:, 0])
    # relative motion at p, element frame: R [u_B + th_B x (p - b) - u_A - th_A x (p - a)]
    D = np.zeros((n, 6, 12))
    ra = p - xyz[:, 0]
    rb = p - xyz[:, 1]
    D[:, 0:3, 0:3] = -R
    D[:, 0:3, 3:6] = R @ skew(ra)  # -(th x r) = r x th = skew(r) th
    D[:, 0:3, 6:9] = R
    D[:, 0:3, 9:12] = -R @ skew(rb)
    D[:, 3:6, 3:6] = -R
    D[:, 3:6, 9:12] = R
    D[grounded, :, 6:12] = 0.0
    kd = np.einsum("nk,nkj->nkj", k, D)
    return np.einsum("nki,nkj->nij", D, kd)
