"""Quadratic shell element kernels: NASTRAN CQUAD8 and CTRIA6, all elements of a type at once.

Inputs, outputs, sign conventions (``beta_x = Ry``, ``beta_y = -Rx``, curvature, resultants),
the drilling penalty, ``S=None``, ZOFFS and the rigid links for warped elements are those of
:mod:`femcal.elements.shell` (CQUAD4 / CTRIA3); see its module docstring. Only the
interpolation and the transverse-shear treatment differ.

Element frame (:func:`quadratic_shell_frame`)
---------------------------------------------
The CQUAD4 / CTRIA3 frame of the corner nodes (G1-G4 or G1-G3): for CQUAD8 ``z`` along
``(G3 - G1) x (G4 - G2)`` and ``x`` the bisector of the diagonals; for CTRIA6 ``x`` from G1 to
G2. Origin at the mean of the corner nodes.

Geometry: flat element in the mean plane
----------------------------------------
All nodes (corners and midside nodes) are projected onto the ``xy`` plane of the element
frame; the flat element is isoparametric there (a midside node off the chord gives a curved
edge in the plane). Each node's distance ``h_a`` from the plane (a warped CQUAD8, or the
midside nodes of a curved shell that do not lie on the chord plane) is bridged by a rigid
link along ``z`` exactly as in :mod:`~femcal.elements.shell`, together with ZOFFS:
``d_a = zoffs - h_a``. This keeps the six rigid-body modes exact for any geometry, but the
curvature of a curved shell is *not* represented inside an element (a faceted, flat-element
approximation; membrane-bending coupling of a curved element is lost).

Interpolation
-------------
Node DOFs ``[u v w Rx Ry Rz]`` in the element frame. ``u, v, w, Rx, Ry`` and ``Rz`` all use
the element's quadratic shape functions: 8-node serendipity (CQUAD8) in ``(xi, eta)`` with
nodes ``(-1,-1) (1,-1) (1,1) (-1,1) (0,-1) (1,0) (0,1) (-1,0)``; 6-node quadratic triangle
(CTRIA6) in ``(r, s)`` with corners ``(0,0) (1,0) (0,1)`` and midside nodes on edges 12, 23,
31. Membrane strains and curvatures from these fields (Reissner-Mindlin, flat).

Integration: 3x3 Gauss (CQUAD8) and the 7-point degree-5 rule (Radon / Dunavant) for
CTRIA6, for the membrane, bending, assumed shear, drilling penalty and mass.

Transverse shear: assumed covariant strains (MITC-type)
-------------------------------------------------------
Shear locking is removed by interpolating the covariant transverse shear strains
``e_r = w,r + beta . x,r`` from tying values; ``gamma = J^-1 e`` at each integration point.

* CQUAD8 (MITC8-type, after Bathe & Dvorkin 1986): ``e_xi`` tied at ``(+-1/sqrt3, -1|0|1)``,
  linear in ``xi`` and quadratic in ``eta``; ``e_eta`` likewise at ``(-1|0|1, +-1/sqrt3)``.
  ``w`` is enriched by an internal bubble ``(1 - xi^2)(1 - eta^2)`` that enters only the
  tied shear strains and is condensed statically. Reason: on a non-parallelogram element
  the serendipity space does not contain ``x^2, xy, y^2``, so without the bubble the
  quadratic ``w`` of a constant-curvature (zero-shear) state gives spurious shear at the
  interior tying points and the patch test fails; with it the ``w`` space contains every
  quadratic for straight-edged elements with midside nodes at the edge midpoints, the tied
  strains of that state vanish and the constant-curvature patch test is passed. (Plain 2x2
  reduced shear integration fails the distorted patch test for the same reason, and with
  the bubble it has a spurious ``(xi^2 - 1/3)(eta^2 - 1/3)`` mode; tying on the edges only,
  without the interior line, is free of both problems but much too flexible in plates.)
* CTRIA6 (MITC6-type): Nedelec first-kind degree-2 covariant field
  ``(e_r, e_s) = P1^2 + (s, -r)(d r + e s)`` (8 parameters), tied by the tangential strains
  at the two Gauss points of each edge and the element means of ``e_r`` and ``e_s``
  (3-point rule). Straight-edged CTRIA6 are affine, so quadratic ``w`` is exact.

Omitted midside nodes
---------------------
NASTRAN allows any midside node of a CQUAD8 or CTRIA6 to be left blank: that edge is
straight and every field is linear along it. The kernels take ``midside`` (n, 4) or (n, 3):
an omitted node is put at its edge's midpoint and tied to the mean of the two corners (its
rows and columns are zero), and the assumed shear field follows the linear edge: where a
field is linear along a line, the tangential shear there is tied once (the mean of the two
Gauss values) rather than twice. Tying it twice imposes the Kirchhoff condition on the
linear part of the rotation along a straight edge, which the linear ``w`` cannot follow:
the element locks on thin plates (a simply supported plate 400 thicknesses per element,
with a random half or all of the midside nodes omitted, is checked by
``tests/test_sol103_analytic.py::test_thin_plates_do_not_lock``). The fields, each with
exactly six zero modes:

* CQUAD8 (:func:`_quad8_tying`): per line of ``e_xi`` (eta = -1, 0, 1; the interior line
  only with G6 and G8, else ``e_xi`` is linear in eta), the part linear in xi is tied on an
  edge whose midside node is given and on the interior line only with both G5 and G7 (with
  one of them, the curvature along xi grows from one edge to the other and the interior
  line would lock); ``e_eta`` likewise. The bubble is used only by the full element. All
  four omitted gives MITC4's field, with the CQUAD4's residual bending flexibility
  (:mod:`femcal.elements.shell`: bilinear rotations miss the same energy).
* CTRIA6 (:func:`_tria6_tying`): with any node omitted, the lowest-order Nedelec (MITC3)
  field plus the gradients of the given edges' bubbles ``L_i L_j``, tied on the edges only
  (the interior means would see the gradient of the missing edge bubble and lock). All
  three omitted gives MITC3 with the CTRIA3's residual bending flexibility, as CTRIA3
  (without it MITC3 locks on coarse thin meshes).

A free element has exactly six zero-energy modes (verified by the tests for distorted,
curved and warped elements); both elements pass the membrane and constant-curvature patch
tests on distorted meshes and are nodally exact for a straight cantilever under tip load.

Drilling rotation
-----------------
Like the CQUAD4 / CTRIA3 membranes (and unlike the CQUADR / CTRIAR Allman membranes), the
quadratic membrane does not use ``Rz``. It enters only through the Hughes-Brezzi penalty
``1/2 alpha integral((Rz - (v,x - u,y) / 2)^2 dA)`` with
``alpha = (DRILL_GAMMA + k6rot * 1e-6) * A[2, 2]`` (shell.py's ``DRILL_GAMMA`` = 1, the
modulus of its Allman membranes, not the CQUAD4 / CTRIA3 ``PENALTY_GAMMA``), with the full
integration rule, which has more points than nodes, so a free element has exactly the six
rigid-body zero modes.

Mass
----
Translational only, ``m = rho_area + nsm`` per unit area, no rotary inertia in the reference
plane (the rigid links carry it to the grids). Coupled: consistent ``m integral(N_a N_b dA)``
on each translation. Lumped (default): HRZ (Hinton, Rock & Zienkiewicz 1976) diagonal,
``m area integral(N_a^2) / sum_b integral(N_b^2)``: positive at every node and exact in total
(the row sums of the consistent mass of these elements are negative or zero at the corners).
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cache

import numpy as np
from numpy.typing import ArrayLike

from femcal.elements import shell
from femcal.elements.shell import (
    _constitutive,
    _covariant_shear_rows,
    _shear_penalty,
    _to_basic,
    shell_frame,
)

__all__ = ["quad8_matrices", "quadratic_shell_frame", "tria6_matrices"]

#: Drilling penalty: ``alpha = (DRILL_GAMMA + k6rot * DRILL_SCALE) * A[2, 2]`` (as shell.py).
DRILL_GAMMA = shell.DRILL_GAMMA
DRILL_SCALE = shell.DRILL_SCALE

ShapeFn = Callable[[float, float], tuple[np.ndarray, np.ndarray]]

# ----------------------------------------------------------------------------------------
# Shape functions and quadrature
# ----------------------------------------------------------------------------------------

_Q8_XI = np.array([-1.0, 1.0, 1.0, -1.0, 0.0, 1.0, 0.0, -1.0])
_Q8_ETA = np.array([-1.0, -1.0, 1.0, 1.0, -1.0, 0.0, 1.0, 0.0])


def _quad8_shape(xi: float, eta: float) -> tuple[np.ndarray, np.ndarray]:
    """Serendipity shape functions (8,) and natural derivatives (2, 8) at (xi, eta)."""
    xa, ea = _Q8_XI, _Q8_ETA
    N = np.empty(8)
    dN = np.empty((2, 8))
    c = slice(0, 4)
    N[c] = 0.25 * (1 + xi * xa[c]) * (1 + eta * ea[c]) * (xi * xa[c] + eta * ea[c] - 1)
    dN[0, c] = 0.25 * xa[c] * (1 + eta * ea[c]) * (2 * xi * xa[c] + eta * ea[c])
    dN[1, c] = 0.25 * ea[c] * (1 + xi * xa[c]) * (xi * xa[c] + 2 * eta * ea[c])
    for a in (4, 6):  # midside on eta = +-1
        N[a] = 0.5 * (1 - xi * xi) * (1 + eta * ea[a])
        dN[0, a] = -xi * (1 + eta * ea[a])
        dN[1, a] = 0.5 * ea[a] * (1 - xi * xi)
    for a in (5, 7):  # midside on xi = +-1
        N[a] = 0.5 * (1 + xi * xa[a]) * (1 - eta * eta)
        dN[0, a] = 0.5 * xa[a] * (1 - eta * eta)
        dN[1, a] = -eta * (1 + xi * xa[a])
    return N, dN


def _tria6_shape(r: float, s: float) -> tuple[np.ndarray, np.ndarray]:
    """Quadratic triangle shape functions (6,) and natural derivatives (2, 6) at (r, s)."""
    t = 1.0 - r - s
    N = np.array(
        [t * (2 * t - 1), r * (2 * r - 1), s * (2 * s - 1), 4 * r * t, 4 * r * s, 4 * s * t]
    )
    dN = np.array(
        [
            [1 - 4 * t, 4 * r - 1, 0.0, 4 * (t - r), 4 * s, -4 * s],
            [1 - 4 * t, 0.0, 4 * s - 1, -4 * r, 4 * r, 4 * (t - s)],
        ]
    )
    return N, dN


_G3 = np.sqrt(0.6)
_GAUSS3 = ((-_G3, 5.0 / 9.0), (0.0, 8.0 / 9.0), (_G3, 5.0 / 9.0))
_QUAD_RULE = tuple((xi, eta, wx * we) for xi, wx in _GAUSS3 for eta, we in _GAUSS3)


def _tri7_rule() -> tuple[tuple[float, float, float], ...]:
    """7-point degree-5 triangle rule (Radon 1948) on (r, s); weights sum to 1/2."""
    r15 = np.sqrt(15.0)
    pts = [(1.0 / 3.0, 1.0 / 3.0, 9.0 / 80.0)]
    for a, b, w in (
        ((6 - r15) / 21, (9 + 2 * r15) / 21, (155 - r15) / 2400),
        ((6 + r15) / 21, (9 - 2 * r15) / 21, (155 + r15) / 2400),
    ):
        pts += [(a, a, w), (b, a, w), (a, b, w)]
    return tuple(pts)


_TRI_RULE = _tri7_rule()

# ----------------------------------------------------------------------------------------
# Assumed transverse shear: tying points on the edges and interpolation
# ----------------------------------------------------------------------------------------

_GE = 1.0 / np.sqrt(3.0)  # two-point Gauss abscissa on [-1, 1]

#: A tied strain value: sum of ``weight * tangent . (e_r, e_s)`` over natural points.
Tie = tuple[tuple[tuple[float, float], tuple[float, float], float], ...]
Tying = tuple[tuple[Tie, ...], np.ndarray]


def _tying_interpolation(
    ties: tuple[Tie, ...],
    basis: Callable[[float, float], np.ndarray],
    rule: tuple[tuple[float, float, float], ...],
) -> np.ndarray:
    """Interpolation E (Q, 2, n_tie): assumed ``(e_r, e_s)`` at each rule point from the tied
    values, for the field spanned by ``basis(r, s)`` (2, n_tie), unisolvent for the ties."""
    P = np.array(
        [sum(w * (np.array(t) @ basis(*p)) for p, t, w in tie) for tie in ties], dtype=float
    )
    Pinv = np.linalg.inv(P)
    return np.stack([basis(r, s) @ Pinv for r, s, _ in rule])


def _mean_tie(a: tuple[float, float], b: tuple[float, float], tangent: tuple[float, float]) -> Tie:
    """The mean of the tangential strain at two points: for a field linear between them, its
    value at their midpoint."""
    return ((a, tangent, 0.5), (b, tangent, 0.5))


def _lagrange(nodes: tuple[float, ...], k: int, x: float) -> float:
    """Lagrange polynomial of ``nodes[k]`` on ``nodes`` at x."""
    out = 1.0
    for j, xj in enumerate(nodes):
        if j != k:
            out *= (x - xj) / (nodes[k] - xj)
    return out


@cache
def _quad8_tying(present: tuple[bool, bool, bool, bool] = (True,) * 4) -> Tying:
    """CQUAD8 shear, MITC8-type, for the midside nodes ``present`` (G5-G8).

    With all four: ``e_xi`` tied at ``(+-g, -1 | 0 | 1)``, ``e_eta`` at ``(-1 | 0 | 1, +-g)``;
    ``e_xi`` linear in xi and quadratic in eta, and vice versa.

    An omitted midside node makes its edge straight and every field linear along it; the
    assumed strain follows, between MITC8 and MITC4 (all four omitted: MITC4's field).
    ``e_xi`` is tied on the lines eta = -1, 0, 1 (0 only when G6 and G8 are given: with one
    of them alone, a curvature along eta leaves the given node's ``w`` bump, whose slope
    along xi is a spurious ``e_xi`` quadratic in eta, and the interior line would lock); on
    each line either at ``xi = +-g`` (its part linear in xi) or by the mean of those two
    values (constant in xi). The linear part is tied on the edge
    eta = -1 when G5 is given, on eta = 1 when G7 is given, and on the interior line when
    both are; its variation in eta is the Lagrange interpolant over those lines only.
    ``e_eta`` likewise with (G5, G7) and (G6, G8) swapped.

    Why: tying the linear part where the fields along the line are linear imposes the
    Kirchhoff condition on the rotation's linear part, which a linear ``w`` cannot follow:
    it locks on thin plates. With G5 omitted and G7 given, the curvature of ``w`` along xi
    grows linearly from the edge eta = -1 to eta = 1, so the interior line would lock too:
    only the given edge is tied.
    """
    g5, g6, g7, g8 = present
    ties: list[Tie] = []
    terms: list[tuple[int, tuple[float, ...], int, int]] = []  # (component, lines, k, power)
    for c, (lo, hi, across) in enumerate(((g5, g7, g6 and g8), (g8, g6, g5 and g7))):
        lines = (-1.0, 0.0, 1.0) if across else (-1.0, 1.0)
        linear = {-1.0: lo, 0.0: lo and hi, 1.0: hi}
        slope_lines = tuple(x for x in lines if linear[x])
        tangent = (1.0, 0.0) if c == 0 else (0.0, 1.0)
        for k, x in enumerate(lines):

            def at(a: float, x: float = x, c: int = c) -> tuple[float, float]:
                return (a, x) if c == 0 else (x, a)

            terms.append((c, lines, k, 0))
            if linear[x]:
                ties += [((at(-_GE), tangent, 1.0),), ((at(_GE), tangent, 1.0),)]
                terms.append((c, slope_lines, slope_lines.index(x), 1))
            else:
                ties.append(_mean_tie(at(-_GE), at(_GE), tangent))

    def basis(xi: float, eta: float) -> np.ndarray:
        P = np.zeros((2, len(terms)))
        for m, (c, pos, k, power) in enumerate(terms):
            along, across = (xi, eta) if c == 0 else (eta, xi)
            P[c, m] = _lagrange(pos, k, across) * along**power
        return P

    return tuple(ties), _tying_interpolation(tuple(ties), basis, _QUAD_RULE)


_TRI_CORNERS = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
_TRI_EDGES = ((0, 1), (1, 2), (2, 0))


def _ned2_basis(r: float, s: float) -> np.ndarray:
    """Nedelec first-kind degree-2 covariant field: ``P1^2 + (s, -r)(d r + e s)``, (2, 8)."""
    P = np.zeros((2, 8))
    P[0, :3] = P[1, 3:6] = (1.0, r, s)
    P[0, 6:] = (s * r, s * s)
    P[1, 6:] = (-r * r, -r * s)
    return P


def _ned1_basis(r: float, s: float) -> np.ndarray:
    """Lowest-order Nedelec (MITC3) field ``(a + c s, b - c r)``, (2, 3)."""
    return np.array([[1.0, 0.0, s], [0.0, 1.0, -r]])


def _edge_gradients(r: float, s: float) -> np.ndarray:
    """Gradients in (r, s) of the edge bubbles ``L_i L_j`` of edges 12, 23, 31: (2, 3). Each
    has a tangential trace linear with zero mean on its own edge and zero on the others."""
    return np.array([[1 - 2 * r - s, s, -s], [-r, r, 1 - r - 2 * s]])


@cache
def _tria6_tying(present: tuple[bool, bool, bool] = (True,) * 3) -> Tying:
    """CTRIA6 shear, MITC6-type, for the midside nodes ``present`` (G4-G6).

    With all three: the Nedelec first-kind degree-2 covariant field
    ``(e_r, e_s) = P1^2 + (s, -r) (d r + e s)``, tied by the tangential strains at the two
    Gauss points of each edge (6) and the element means of ``e_r`` and ``e_s`` (2, exact by
    the 3-point rule for the quadratic strains of a straight-edged element).

    With a midside node omitted (its edge straight): the lowest-order Nedelec (MITC3) field
    plus, for each edge whose midside node is given, the gradient of that edge's bubble
    ``L_i L_j``; tied by the tangential strains at the two Gauss points of the given edges
    and by the mean tangential strain of the omitted ones, without interior ties. (The
    interior means would see the gradient of the missing edge bubble, which a curvature
    along the straight edge needs, and lock on thin plates.) All three omitted gives MITC3,
    as CTRIA3.
    """
    ties: list[Tie] = []
    for edge, (i, j) in enumerate(_TRI_EDGES):
        t = _TRI_CORNERS[j] - _TRI_CORNERS[i]
        tangent = (float(t[0]), float(t[1]))
        taus = (0.5 - 0.5 * _GE, 0.5 + 0.5 * _GE)
        a, b = (tuple(map(float, _TRI_CORNERS[i] + tau * t)) for tau in taus)
        if present[edge]:
            ties += [((a, tangent, 1.0),), ((b, tangent, 1.0),)]
        else:
            ties.append(_mean_tie(a, b, tangent))
    if all(present):
        pts3 = ((1.0 / 6.0, 1.0 / 6.0), (2.0 / 3.0, 1.0 / 6.0), (1.0 / 6.0, 2.0 / 3.0))
        for d in ((1.0, 0.0), (0.0, 1.0)):
            ties.append(tuple((p, d, 1.0 / 3.0) for p in pts3))
        return tuple(ties), _tying_interpolation(tuple(ties), _ned2_basis, _TRI_RULE)
    given = [e for e in range(3) if present[e]]

    def basis(r: float, s: float) -> np.ndarray:
        return np.hstack([_ned1_basis(r, s), _edge_gradients(r, s)[:, given]])

    return tuple(ties), _tying_interpolation(tuple(ties), basis, _TRI_RULE)


def _quad8_bubble(xi: float, eta: float) -> tuple[float, np.ndarray]:
    """Internal ``w`` bubble ``(1 - xi^2)(1 - eta^2)`` and its natural derivatives (2,)."""
    return (1 - xi * xi) * (1 - eta * eta), np.array(
        [-2 * xi * (1 - eta * eta), -2 * eta * (1 - xi * xi)]
    )


# ----------------------------------------------------------------------------------------
# Frame and input handling
# ----------------------------------------------------------------------------------------


def quadratic_shell_frame(xyz: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Element frame of CQUAD8 / CTRIA6 elements: :func:`shell_frame` of the corner nodes.

    Parameters
    ----------
    xyz : array_like, shape (n, 8, 3) or (n, 6, 3)
        Node coordinates in basic, NASTRAN order (corners first), length units.

    Returns
    -------
    T : ndarray, shape (n, 3, 3)
        Rows are the element x, y, z unit axes in basic.
    centre : ndarray, shape (n, 3)
        Frame origin in basic (mean of the corner nodes), length units.
    """
    xyz = np.asarray(xyz, dtype=float)
    if xyz.ndim != 3 or xyz.shape[2] != 3 or xyz.shape[1] not in (6, 8):
        raise ValueError(f"xyz must have shape (n, 6 or 8, 3), got {xyz.shape}")
    return shell_frame(xyz[:, :4] if xyz.shape[1] == 8 else xyz[:, :3])


def _prepare(
    xyz: ArrayLike,
    n_nodes: int,
    A: ArrayLike,
    D: ArrayLike,
    S: ArrayLike | None,
    B: ArrayLike | None,
    rho_area: ArrayLike,
    nsm: ArrayLike,
    zoffs: ArrayLike,
    k6rot: ArrayLike,
) -> tuple[np.ndarray, ...]:
    """Validate and broadcast inputs: ``T, xl, h, A, D, S (or None), B, m, zoffs, alpha``
    (shell.py's preparation, with the frame of the corner nodes)."""
    return shell._prepare(
        xyz, n_nodes, A, D, S, B, rho_area, nsm, zoffs, k6rot, frame=quadratic_shell_frame
    )


# ----------------------------------------------------------------------------------------
# Element-frame matrices
# ----------------------------------------------------------------------------------------


class _BadJacobian(ValueError):
    """Elements (positions in the kernel's input) whose Jacobian is not positive."""

    def __init__(self, name: str, positions: np.ndarray):
        self.name, self.positions = name, positions
        super().__init__(
            f"{name} with non-positive Jacobian (badly shaped, clockwise or misplaced midside "
            f"nodes) at element index(es) {positions[:10].tolist()}"
        )


def _local(
    xl: np.ndarray,
    A: np.ndarray,
    D: np.ndarray,
    S: np.ndarray | None,
    B: np.ndarray,
    alpha: np.ndarray,
    shape: ShapeFn,
    rule: tuple[tuple[float, float, float], ...],
    tying: Tying,
    bubble: Callable[[float, float], tuple[float, np.ndarray]] | None,
    name: str,
    residual_bending: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Element-frame K (n, 6nn, 6nn), HRZ lumped weights (n, nn) and int(N_a N_b) (n, nn, nn).

    The lumped weights are areas per node: ``m`` times them is the nodal mass. ``bubble``:
    an internal ``w`` function (natural coordinates), an extra DOF that enters only the
    tied shear strains and is condensed statically. ``residual_bending``: add the CQUAD4's /
    CTRIA3's residual bending flexibility to S (elements whose midside nodes are all omitted:
    linear rotations), with the area covariance of the corners.
    """
    n, nn, _ = xl.shape
    k6 = 6 * nn
    k = k6 + (bubble is not None)
    Nq, dNq = (np.stack(a) for a in zip(*(shape(r, s) for r, s, _ in rule), strict=True))
    wq = np.array([w for _, _, w in rule])
    J = np.einsum("qra,eai->eqri", dNq, xl)  # (n, Q, 2, 2): rows d(x, y)/d(r)
    detJ = np.linalg.det(J)
    if np.any(detJ <= 0.0):
        raise _BadJacobian(name, np.flatnonzero(np.any(detJ <= 0.0, axis=1)))
    Jinv = np.linalg.inv(J)
    dNxy = Jinv @ dNq[None]  # (n, Q, 2, nn)
    wdet = wq * detJ  # (n, Q)
    area = wdet.sum(axis=1)
    if S is None:
        S = _shear_penalty(D, area)
    if residual_bending:
        S = shell._with_residual_bending(S, shell._corner_covariance(xl[:, : nn // 2]), A, B, D)
    C9 = np.zeros((n, 9, 9))
    C9[:, :8, :8] = _constitutive(A, D, S, B)
    C9[:, 8, 8] = alpha

    # Tied covariant shear strains (n, n_tie, k) and the assumed field at each q.
    ties, E = tying
    tied = np.zeros((n, len(ties), k))
    for t, tie in enumerate(ties):
        for p, tang, w in tie:
            N_p, dN_p = shape(*p)
            tied[:, t, :k6] += w * np.einsum(
                "r,erk->ek", np.array(tang), _covariant_shear_rows(N_p, dN_p, xl)
            )
            if bubble is not None:
                tied[:, t, k6] += w * (np.array(tang) @ bubble(*p)[1])
    e_cov = np.einsum("qct,etk->eqck", E, tied)  # (n, Q, 2, k)

    Q = len(rule)
    rows = np.zeros((n, Q, 9, k))
    r6 = rows[..., :k6].reshape(n, Q, 9, nn, 6)
    dx, dy = dNxy[:, :, 0], dNxy[:, :, 1]
    r6[:, :, 0, :, 0] = dx
    r6[:, :, 1, :, 1] = dy
    r6[:, :, 2, :, 0] = dy
    r6[:, :, 2, :, 1] = dx
    r6[:, :, 3, :, 4] = dx  # beta_x = Ry
    r6[:, :, 4, :, 3] = -dy  # beta_y = -Rx
    r6[:, :, 5, :, 4] = dy
    r6[:, :, 5, :, 3] = -dx
    r6[:, :, 8, :, 0] = 0.5 * dy  # Rz - (v,x - u,y) / 2
    r6[:, :, 8, :, 1] = -0.5 * dx
    r6[:, :, 8, :, 5] = Nq[None]
    rows[..., :k6] = r6.reshape(n, Q, 9, k6)
    rows[:, :, 6:8] = Jinv @ e_cov
    rows *= np.sqrt(wdet)[:, :, None, None]

    CR = (C9[:, None] @ rows).reshape(n, Q * 9, k)
    # contiguous transpose: numpy's batched matmul only uses BLAS on contiguous operands
    K = np.ascontiguousarray(np.swapaxes(rows.reshape(n, Q * 9, k), 1, 2)) @ CR
    if bubble is not None:  # static condensation of the internal w bubble
        K = K[:, :k6, :k6] - K[:, :k6, k6:] * K[:, k6:, :k6] / K[:, k6:, k6:]

    Mcons = np.einsum("eq,qa,qb->eab", wdet, Nq, Nq)
    diag = np.einsum("eaa->ea", Mcons)
    lumped = area[:, None] * diag / diag.sum(axis=1, keepdims=True)
    return K, lumped, Mcons


#: Corner pairs of the midside nodes (NASTRAN order): CQUAD8 G5-G8, CTRIA6 G4-G6.
MIDSIDE_EDGES = {8: ((0, 1), (1, 2), (2, 3), (3, 0)), 6: ((0, 1), (1, 2), (2, 0))}


def _tie_midside(X: np.ndarray, j: int, a: int, b: int) -> np.ndarray:
    """Element matrices (n, 6k, 6k) with node j's motion tied to the mean of corners a and b
    (an omitted midside node: a straight edge); node j's rows and columns become zero."""
    X = X.copy()
    J, A, B = (slice(6 * i, 6 * i + 6) for i in (j, a, b))
    X[:, :, A] += 0.5 * X[:, :, J]
    X[:, :, B] += 0.5 * X[:, :, J]
    X[:, A, :] += 0.5 * X[:, J, :]
    X[:, B, :] += 0.5 * X[:, J, :]
    X[:, J, :] = 0.0
    X[:, :, J] = 0.0
    return X


def _matrices(
    xyz: ArrayLike,
    nn: int,
    A: ArrayLike,
    D: ArrayLike,
    S: ArrayLike | None,
    B: ArrayLike | None,
    rho_area: ArrayLike,
    nsm: ArrayLike,
    zoffs: ArrayLike,
    k6rot: ArrayLike,
    coupled_mass: bool,
    midside: ArrayLike | None,
) -> tuple[np.ndarray, np.ndarray]:
    nc = nn // 2
    edges = MIDSIDE_EDGES[nn]
    xyz = np.array(xyz, dtype=float)
    present = np.ones((len(xyz), nc), dtype=bool) if midside is None else np.array(midside, bool)
    if xyz.ndim != 3 or present.shape != (len(xyz), nc):
        raise ValueError(f"midside must have shape (n, {nc}) for xyz of shape (n, {nn}, 3)")
    for j, (a, b) in enumerate(edges):  # an omitted node sits at its edge's midpoint
        gone = ~present[:, j]
        xyz[gone, nc + j] = 0.5 * (xyz[gone, a] + xyz[gone, b])
    T, xl, h, A_, D_, S_, B_, m, zo, alpha = _prepare(
        xyz, nn, A, D, S, B, rho_area, nsm, zoffs, k6rot
    )
    K = np.empty((len(xl), 6 * nn, 6 * nn))
    lumped = np.empty((len(xl), nn))
    Mcons = np.empty((len(xl), nn, nn))
    patterns, which = np.unique(present, axis=0, return_inverse=True)
    for p, pattern in enumerate(patterns):
        sel = np.flatnonzero(which.ravel() == p)
        key = tuple(bool(x) for x in pattern)
        S_sel = None if S_ is None else S_[sel]
        # All omitted: linear rotations, with the CQUAD4's / CTRIA3's residual bending
        # flexibility (as those, the triangle on the shear-rigid penalty too: MITC3 locks).
        residual_bending = not any(key) and (S_sel is not None or nn == 6)
        if nn == 8:
            args = (_quad8_shape, _QUAD_RULE, _quad8_tying(key))
            # the bubble enters the tied strains only through the interior lines' linear
            # parts (_quad8_tying), which exist only with all four midside nodes
            bubble = _quad8_bubble if all(key) else None  # type: ignore[arg-type]
            name = "CQUAD8"
        else:
            args = (_tria6_shape, _TRI_RULE, _tria6_tying(key))  # type: ignore[assignment]
            bubble, name = None, "CTRIA6"
        try:
            K[sel], lumped[sel], Mcons[sel] = _local(
                xl[sel], A_[sel], D_[sel], S_sel, B_[sel], alpha[sel], *args, bubble, name,
                residual_bending,
            )  # fmt: skip
        except _BadJacobian as e:  # name the positions in the whole input, not the group
            raise _BadJacobian(e.name, sel[e.positions]) from None
    K, M = _to_basic(K, lumped, Mcons, m, T, zo[:, None] - h, coupled_mass)
    for j, (a, b) in enumerate(edges):
        gone = ~present[:, j]
        if gone.any():
            K[gone] = _tie_midside(K[gone], nc + j, a, b)
            M[gone] = _tie_midside(M[gone], nc + j, a, b)
    return K, M


_PARAMS_DOC = """
    Parameters
    ----------
    xyz : ndarray, shape (n, {nn}, 3)
        Node coordinates in basic, NASTRAN order ({order}), length.
    A : array_like, shape (n, 3, 3) or (3, 3)
        Membrane stiffness, ``N = A eps`` (force/length), element frame, order xx, yy, xy
        (engineering shear).
    D : array_like, shape (n, 3, 3) or (3, 3)
        Bending stiffness, ``M = D kappa`` (force length / length), element frame.
    S : array_like, shape (n, 2, 2) or (2, 2), or None
        Transverse shear stiffness, ``Q = S gamma`` (force/length), order xz, yz. None:
        shear-rigid by the penalty ``1e4 trace(D) / area I`` (as CQUAD4).
    B : array_like, shape (n, 3, 3) or (3, 3), optional
        Membrane-bending coupling, ``N = A eps + B kappa``, ``M = B^T eps + D kappa``.
    rho_area, nsm : array_like, shape (n,) or scalar
        Structural and non-structural mass per unit area, mass/length^2.
    zoffs : array_like, shape (n,) or scalar
        Offset of the reference plane from the grid plane along element z (ZOFFS), length.
    k6rot : array_like, shape (n,) or scalar
        NASTRAN PARAM K6ROT: drilling modulus ``(1 + k6rot * 1e-6) * A[2, 2]``.
    coupled_mass : bool
        False: HRZ lumped translational mass. True: consistent translational mass.
    midside : array_like of bool, shape (n, {nc}), optional
        Which midside nodes are given (default: all). An omitted one is placed at its edge's
        midpoint, its motion is tied to the mean of the edge's corners (a straight edge; its
        rows and columns of K and M are zero) and the assumed shear follows the linear edge
        (see "Omitted midside nodes" in the module docstring); its coordinates in xyz are
        ignored.

    Returns
    -------
    K, M : ndarray, shape (n, {k}, {k})
        Stiffness and mass in basic, DOFs ``[T1 T2 T3 R1 R2 R3]`` node by node. Symmetric.
"""


def quad8_matrices(
    xyz: np.ndarray,
    A: ArrayLike,
    D: ArrayLike,
    S: ArrayLike | None,
    B: ArrayLike | None = None,
    *,
    rho_area: ArrayLike,
    nsm: ArrayLike = 0.0,
    zoffs: ArrayLike = 0.0,
    k6rot: ArrayLike = 100.0,
    coupled_mass: bool = False,
    midside: ArrayLike | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness and mass of CQUAD8 elements (see the module docstring)."""
    return _matrices(xyz, 8, A, D, S, B, rho_area, nsm, zoffs, k6rot, coupled_mass, midside)


def tria6_matrices(
    xyz: np.ndarray,
    A: ArrayLike,
    D: ArrayLike,
    S: ArrayLike | None,
    B: ArrayLike | None = None,
    *,
    rho_area: ArrayLike,
    nsm: ArrayLike = 0.0,
    zoffs: ArrayLike = 0.0,
    k6rot: ArrayLike = 100.0,
    coupled_mass: bool = False,
    midside: ArrayLike | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness and mass of CTRIA6 elements (see the module docstring)."""
    return _matrices(xyz, 6, A, D, S, B, rho_area, nsm, zoffs, k6rot, coupled_mass, midside)


quad8_matrices.__doc__ = (quad8_matrices.__doc__ or "") + _PARAMS_DOC.format(
    nn=8, nc=4, order="G1-G4 corners counter-clockwise, G5-G8 midside of 12, 23, 34, 41", k=48
)
tria6_matrices.__doc__ = (tria6_matrices.__doc__ or "") + _PARAMS_DOC.format(
    nn=6, nc=3, order="G1-G3 corners counter-clockwise, G4-G6 midside of 12, 23, 31", k=36
)
