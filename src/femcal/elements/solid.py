"""Solid elements: CHEXA (8/20 nodes), CPENTA (6/15), CTETRA (4/10) and CPYRAM (5/13).

Every kernel is isoparametric in a reference element, works on all elements of one kind at once
(loops run over quadrature points only) and returns the stiffness ``K`` and the mass ``M`` in the
basic frame, DOFs ``[T1 T2 T3]`` node by node in NASTRAN's node order.

Reference elements (natural coordinates ``r, s, t``)
----------------------------------------------------
* hexahedron: the cube ``[-1, 1]^3``, G1-G4 at ``t = -1``, G5-G8 at ``t = +1``;
* pentahedron (wedge): the triangle ``r, s >= 0, r + s <= 1`` times ``t`` in ``[-1, 1]``;
* tetrahedron: ``r, s, t >= 0, r + s + t <= 1``;
* pyramid: the square base ``[-1, 1]^2`` at ``t = 0`` and the apex at ``(0, 0, 1)``.

Midside nodes sit at the midpoints of their edges in natural coordinates. Shape functions are
obtained once per kind by inverting the interpolation (Vandermonde) matrix of the kind's function
space at the nodes:

* HEXA8 trilinear, HEXA20 20-term serendipity, PENTA6 ``{1, r, s} x {1, t}``, PENTA15 the 15-term
  quadratic wedge ``{1, r, s, r^2, rs, s^2} x {1, t} + t^2 {1, r, s}``, TETRA4 linear, TETRA10
  complete quadratic.
* Pyramids use Bedrosian's rational shape functions (Bedrosian, IJNME 35, 1992): PYRAM5 spans
  ``{1, r, s, t, rs/(1-t)}``; PYRAM13 spans the complete quadratics plus ``rst/(1-t)``,
  ``r^2 s/(1-t)``, ``r s^2/(1-t)``. Their traces are the 8-node serendipity quadrilateral on the
  base and the 6-node quadratic triangle on the sides, so they conform to HEXA20, PENTA15 and
  TETRA10 faces (and PYRAM5 to HEXA8, PENTA6 and TETRA4 faces). They are integrated with
  collapsed (Duffy) Gauss rules, ``r = a (1 - t)``, ``s = b (1 - t)``, which make the rational
  integrands polynomial; PYRAM5 with 2x2x2 points is the same element as a hexahedron collapsed
  to a point.

Stiffness
---------
* HEXA8: Wilson-Taylor incompatible modes: the 9 bubble displacements ``(1 - r^2)``,
  ``(1 - s^2)``, ``(1 - t^2)`` in each direction, their derivatives taken with the Jacobian at the
  centre and scaled by ``det J0 / det J`` (Taylor, Beresford & Wilson, IJNME 10, 1976) so that
  their strains integrate to zero and the element passes the patch test on any geometry;
  2x2x2 Gauss; the modes are condensed per element (batched solve). The element does not lock
  in bending.
* PENTA6: 3 triangle points x 2 Gauss points, with 12 condensed incompatible modes: ``(1 - t^2)``
  (bending along the wedge's axis, out of the triangle plane) and the triangle's quadratic
  edge bubbles ``4 L1 L2, 4 L2 L3, 4 L3 L1`` (constant along the axis), in each direction, their
  gradients taken with the centre Jacobian and made mean-free (the same patch-test condition as
  Taylor's). The bubbles relieve bending in which the axial derivatives vary over the triangle
  (and Poisson stiffening), but cannot relieve bending *in* the triangle plane: the in-plane
  strain of the linear triangle is constant, so mean-free modes decouple from it. A mesh whose
  triangles lie in the bending plane is as stiff as constant-strain triangles (cantilever
  20 x 4 x 4 cells: 33 % too stiff); with the triangles across the beam it is as good as HEXA8.
* TETRA4: constant strain (1 point). TETRA10: the 5-point degree-3 rule (centre weight -4/5;
  exact for straight edges, as the 4-point rule is). It is NASTRAN's: on a curved element
  (pyn_tet10_simple, both elements slightly curved) it reproduces NASTRAN's static response to
  print precision (1e-7; tests/test_conformance.py), which a different rule does not: on
  curved geometry the rule is part of NASTRAN's element. Its centre weight is negative, so a
  strongly curved element can get an indefinite K; such elements are integrated with the
  collapsed 4^3 Gauss rule instead (:func:`_stable_tetra10`).
* HEXA20: full 3x3x3 Gauss (some NASTRAN versions use a reduced 2x2x2 rule; the full rule has no
  spurious modes and passes the patch test even with curved edges).
* PENTA15: 7-point (degree 5) triangle rule x 3 Gauss points.
* PYRAM5: collapsed 2x2x2; PYRAM13: collapsed 3x3x3.

Mass
----
The consistent mass ``rho * int N_a N_b dV`` is integrated with a rule exact for straight-edged
elements: HEXA8 3^3 and HEXA20 4^3 Gauss, PENTA6 7-point x 3 and PENTA15 7-point x 4, TETRA4 the
4-point rule, TETRA10 a 125-point collapsed (Duffy) rule (exact for curved edges as well),
PYRAM5 / PYRAM13 collapsed 3^3 / 4^3. ``coupled_mass=False`` (default) lumps it: row sums for
the linear elements, HRZ lumping (the diagonal scaled to the element mass; Hinton, Rock &
Zienkiewicz, Earthquake Eng. Struct. Dyn. 4, 1976) for the quadratic ones, whose row sums give
zero or negative corner masses. Both give a total mass ``rho * V`` in each direction.

Orientation
-----------
Elements numbered in either orientation are accepted: the sign of the Jacobian at the centre is
taken as the element's orientation and ``|det J|`` is used. If the Jacobian changes sign inside an
element (at a quadrature point or a node), or the element has no volume, ``ValueError`` names the
element positions.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache

import numpy as np

__all__ = ["SOLID_KINDS", "isotropic_C", "solid_matrices", "solid_volume"]

SOLID_KINDS = ("HEXA8", "HEXA20", "PENTA6", "PENTA15", "TETRA4", "TETRA10", "PYRAM5", "PYRAM13")

_SQUARE = ((-1, -1), (1, -1), (1, 1), (-1, 1))
_CORNERS: dict[str, list[tuple[float, float, float]]] = {
    "hex": [(r, s, t) for t in (-1, 1) for r, s in _SQUARE],
    "wedge": [(r, s, t) for t in (-1, 1) for r, s in ((0, 0), (1, 0), (0, 1))],
    "tet": [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)],
    "pyr": [(r, s, 0) for r, s in _SQUARE] + [(0, 0, 1)],
}


def _edges(text: str) -> list[tuple[int, int]]:
    """'1-2 2-3' (NASTRAN grid numbers) -> [(0, 1), (1, 2)]."""
    return [(int(a) - 1, int(b) - 1) for a, b in (e.split("-") for e in text.split())]


# Midside nodes in NASTRAN order, as the edges (pairs of corners) they sit on.
_EDGES: dict[str, list[tuple[int, int]]] = {
    "hex": _edges("1-2 2-3 3-4 4-1 1-5 2-6 3-7 4-8 5-6 6-7 7-8 8-5"),
    "wedge": _edges("1-2 2-3 3-1 1-4 2-5 3-6 4-5 5-6 6-4"),
    "tet": _edges("1-2 2-3 3-1 1-4 2-4 3-4"),
    "pyr": _edges("1-2 2-3 3-4 4-1 1-5 2-5 3-5 4-5"),
}

_CENTRE: dict[str, tuple[float, float, float]] = {
    "hex": (0.0, 0.0, 0.0),
    "wedge": (1 / 3, 1 / 3, 0.0),
    "tet": (0.25, 0.25, 0.25),
    "pyr": (0.0, 0.0, 0.25),
}

Term = tuple[int, int, int, int]  # r^a s^b t^c / (1 - t)^d


def _poly_terms(exps: list[tuple[int, int, int]]) -> tuple[Term, ...]:
    return tuple((a, b, c, 0) for a, b, c in exps)


_HEX8 = [(a, b, c) for c in range(2) for b in range(2) for a in range(2)]
_HEX20 = _HEX8 + [
    e
    for e in ((a, b, c) for c in range(3) for b in range(3) for a in range(3))
    if max(e) == 2 and sorted(e)[1] < 2
]
_TRI1 = [(0, 0), (1, 0), (0, 1)]
_TRI2 = [*_TRI1, (2, 0), (1, 1), (0, 2)]
_P2 = [(a, b, c) for c in range(3) for b in range(3) for a in range(3) if a + b + c <= 2]

_TERMS: dict[str, tuple[Term, ...]] = {
    "HEXA8": _poly_terms(_HEX8),
    "HEXA20": _poly_terms(_HEX20),
    "PENTA6": _poly_terms([(a, b, c) for c in range(2) for a, b in _TRI1]),
    "PENTA15": _poly_terms(
        [(a, b, c) for c in range(2) for a, b in _TRI2] + [(a, b, 2) for a, b in _TRI1]
    ),
    "TETRA4": _poly_terms([(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]),
    "TETRA10": _poly_terms(_P2),
    "PYRAM5": (*_poly_terms([(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]), (1, 1, 0, 1)),
    "PYRAM13": (*_poly_terms(_P2), (1, 1, 1, 1), (2, 1, 0, 1), (1, 2, 0, 1)),
}

_FAMILY = {
    "HEXA8": "hex", "HEXA20": "hex", "PENTA6": "wedge", "PENTA15": "wedge",
    "TETRA4": "tet", "TETRA10": "tet", "PYRAM5": "pyr", "PYRAM13": "pyr",
}  # fmt: skip

# Quadrature per kind: (stiffness rule, mass rule); see _rule for the meaning of the numbers.
_RULES: dict[str, tuple[tuple[str, int, int], tuple[str, int, int]]] = {
    "HEXA8": (("hex", 2, 0), ("hex", 3, 0)),
    "HEXA20": (("hex", 3, 0), ("hex", 4, 0)),
    "PENTA6": (("wedge", 3, 2), ("wedge", 7, 3)),
    "PENTA15": (("wedge", 7, 3), ("wedge", 7, 4)),
    "TETRA4": (("tet", 1, 0), ("tet", 4, 0)),
    "TETRA10": (("tet", 5, 0), ("tetc", 5, 0)),
    "PYRAM5": (("pyr", 2, 0), ("pyr", 3, 0)),
    "PYRAM13": (("pyr", 3, 0), ("pyr", 4, 0)),
}

_QUADRATIC = {"HEXA20", "PENTA15", "TETRA10", "PYRAM13"}


# --------------------------------------------------------------------------------------------
# Quadrature rules on the reference elements: points (q, 3), weights (q,)
# --------------------------------------------------------------------------------------------


def _gauss01(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre points and weights on [0, 1]."""
    x, w = np.polynomial.legendre.leggauss(n)
    return (x + 1.0) / 2.0, w / 2.0


def _triangle_rule(n: int) -> tuple[np.ndarray, np.ndarray]:
    """3-point (degree 2) or 7-point (degree 5, Radon) rule on the unit triangle (area 1/2)."""
    if n == 3:
        pts = np.array([[1 / 6, 1 / 6], [2 / 3, 1 / 6], [1 / 6, 2 / 3]])
        return pts, np.full(3, 1 / 6)
    r15 = math.sqrt(15.0)
    a1, b1 = (9 - 2 * r15) / 21, (6 + r15) / 21
    a2, b2 = (9 + 2 * r15) / 21, (6 - r15) / 21
    w1, w2 = (155 + r15) / 2400, (155 - r15) / 2400
    pts = np.array([[1 / 3, 1 / 3], [b1, b1], [a1, b1], [b1, a1], [b2, b2], [a2, b2], [b2, a2]])
    return pts, np.array([9 / 80, w1, w1, w1, w2, w2, w2])


@cache
def _rule(shape: str, n: int, m: int) -> tuple[np.ndarray, np.ndarray]:
    if shape == "hex":  # n^3 Gauss
        x, w = np.polynomial.legendre.leggauss(n)
        g = np.stack(np.meshgrid(x, x, x, indexing="ij"), -1).reshape(-1, 3)
        return g, np.einsum("i,j,k->ijk", w, w, w).ravel()
    if shape == "wedge":  # n-point triangle x m-point Gauss
        tp, tw = _triangle_rule(n)
        x, w = np.polynomial.legendre.leggauss(m)
        pts = np.array([[a, b, c] for a, b in tp for c in x])
        return pts, np.outer(tw, w).ravel()
    if shape == "tet":
        if n == 1:
            return np.full((1, 3), 0.25), np.array([1 / 6])
        if n == 5:  # degree 3: the centre (weight -4/5) and (1/2, 1/6, 1/6, 1/6) (9/20 each)
            a, b = 0.5, 1 / 6
            pts = np.array([[0.25, 0.25, 0.25], [b, b, b], [a, b, b], [b, a, b], [b, b, a]])
            return pts, np.array([-4 / 5, 9 / 20, 9 / 20, 9 / 20, 9 / 20]) / 6
        a, b = (5 + 3 * math.sqrt(5)) / 20, (5 - math.sqrt(5)) / 20
        pts = np.array([[b, b, b], [a, b, b], [b, a, b], [b, b, a]])
        return pts, np.full(4, 1 / 24)
    if shape == "tetc":  # collapsed n^3 Gauss (Duffy): exact for degree 2n - 3
        x, w = _gauss01(n)
        u, v, z = (a.ravel() for a in np.meshgrid(x, x, x, indexing="ij"))
        wt = np.einsum("i,j,k->ijk", w, w, w).ravel()
        pts = np.stack([u, v * (1 - u), z * (1 - u) * (1 - v)], -1)
        return pts, wt * (1 - u) ** 2 * (1 - v)
    if shape == "pyr":  # collapsed n^3 Gauss: r = a (1 - t), s = b (1 - t)
        x, w = np.polynomial.legendre.leggauss(n)
        a, b, c = (g.ravel() for g in np.meshgrid(x, x, x, indexing="ij"))
        wt = np.einsum("i,j,k->ijk", w, w, w).ravel()
        t = (1 + c) / 2
        pts = np.stack([a * (1 - t), b * (1 - t), t], -1)
        return pts, wt * (1 - t) ** 2 / 2
    raise ValueError(shape)


# --------------------------------------------------------------------------------------------
# Shape functions
# --------------------------------------------------------------------------------------------


def _pw(x: np.ndarray, k: int) -> np.ndarray:
    """x**k, and 0 for negative k (the coefficient in front is then 0 as well)."""
    return x**k if k >= 0 else np.zeros_like(x)


def _basis(terms: tuple[Term, ...], p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Values (q, m) and gradients (q, m, 3) of the terms at points p (q, 3).

    Rational terms are 0 at the pyramid apex (their numerators vanish there faster than the
    denominator); their gradients are only requested inside the element.
    """
    r, s, t = p[:, 0], p[:, 1], p[:, 2]
    den = 1.0 - t
    inv = np.divide(1.0, den, out=np.zeros_like(den), where=den != 0)
    val = np.empty((p.shape[0], len(terms)))
    grad = np.empty((p.shape[0], len(terms), 3))
    for m, (a, b, c, d) in enumerate(terms):
        R, S, T, D = _pw(r, a), _pw(s, b), _pw(t, c), inv**d
        val[:, m] = R * S * T * D
        grad[:, m, 0] = a * _pw(r, a - 1) * S * T * D
        grad[:, m, 1] = b * R * _pw(s, b - 1) * T * D
        grad[:, m, 2] = R * S * (c * _pw(t, c - 1) * D + d * T * D * inv)
    return val, grad


@dataclass(frozen=True)
class _Element:
    kind: str
    family: str
    nodes: np.ndarray  # (a, 3) natural coordinates
    coef: np.ndarray  # (m, a): N = basis @ coef
    k_pts: np.ndarray
    k_w: np.ndarray
    m_pts: np.ndarray
    m_w: np.ndarray
    check_pts: np.ndarray  # points where the Jacobian must keep the centre's sign
    modes: bool  # incompatible modes

    @property
    def n_nodes(self) -> int:
        return self.nodes.shape[0]

    def shape(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """N (q, a) and dN/d(r, s, t) (q, a, 3) at points p (q, 3)."""
        val, grad = _basis(_TERMS[self.kind], p)
        return val @ self.coef, np.einsum("qmj,ma->qaj", grad, self.coef)


@cache
def _element(kind: str) -> _Element:
    if kind not in _TERMS:
        raise ValueError(f"unknown solid element kind {kind!r}; expected one of {SOLID_KINDS}")
    family = _FAMILY[kind]
    corners = np.array(_CORNERS[family], dtype=float)
    nodes = corners
    if kind in _QUADRATIC:
        mid = np.array([(corners[i] + corners[j]) / 2 for i, j in _EDGES[family]])
        nodes = np.vstack([corners, mid])
    V, _ = _basis(_TERMS[kind], nodes)
    coef = np.linalg.inv(V)
    (ks, kn, km), (ms, mn, mm) = _RULES[kind]
    k_pts, k_w = _rule(ks, kn, km)
    m_pts, m_w = _rule(ms, mn, mm)
    node_pts = nodes
    if family == "pyr":  # the apex (node 5) is singular for the rational functions
        node_pts = np.delete(nodes, 4, axis=0)
    check = np.vstack([node_pts, k_pts, m_pts])
    return _Element(
        kind=kind,
        family=family,
        nodes=nodes,
        coef=coef,
        k_pts=k_pts,
        k_w=k_w,
        m_pts=m_pts,
        m_w=m_w,
        check_pts=check,
        modes=kind in ("HEXA8", "PENTA6"),
    )


@cache
def _shape_at(kind: str, which: str) -> tuple[np.ndarray, np.ndarray]:
    el = _element(kind)
    pts = {
        "k": el.k_pts,
        "m": el.m_pts,
        "check": el.check_pts,
        "centre": np.array([_CENTRE[el.family]]),
    }[which]
    return el.shape(pts)


# --------------------------------------------------------------------------------------------
# Geometry
# --------------------------------------------------------------------------------------------


def _jacobian(xyz: np.ndarray, dN: np.ndarray) -> np.ndarray:
    """J[e, q, i, j] = dx_i / dr_j from xyz (e, a, 3) and dN (q, a, 3)."""
    e, a, _ = xyz.shape
    q = dN.shape[0]
    J = xyz.transpose(0, 2, 1) @ dN.transpose(1, 0, 2).reshape(a, 3 * q)  # (e, i, (q, j))
    return J.reshape(e, 3, q, 3).transpose(0, 2, 1, 3)


def _prepare(kind: str, xyz: np.ndarray) -> tuple[_Element, np.ndarray]:
    """Validate the geometry; return the element and xyz as floats.

    The sign of the Jacobian at the centre is the element's orientation (either is accepted,
    the kernels use |det J|); the Jacobian must keep that sign at every quadrature point of
    the stiffness and mass rules (strictly) and at the nodes (0 allowed; not at the pyramid
    apex, where the rational shape functions have no derivative).
    """
    el = _element(kind)
    xyz = np.asarray(xyz, dtype=float)
    if xyz.ndim != 3 or xyz.shape[1:] != (el.n_nodes, 3):
        raise ValueError(f"{kind}: xyz must have shape (n, {el.n_nodes}, 3), got {xyz.shape}")
    _, dN0 = _shape_at(kind, "centre")
    det0 = np.linalg.det(_jacobian(xyz, dN0)[:, 0])
    size = np.ptp(xyz, axis=1).max(axis=1) if xyz.shape[0] else np.zeros(0)
    flat = ~(np.abs(det0) > 1e-12 * size**3)
    if flat.any():
        raise ValueError(
            f"{kind}: elements at positions {np.flatnonzero(flat).tolist()} have no volume"
        )
    sign = np.sign(det0)
    _, dNc = _shape_at(kind, "check")
    detc = np.linalg.det(_jacobian(xyz, dNc)) * sign[:, None]
    n_node_pts = el.check_pts.shape[0] - el.k_pts.shape[0] - el.m_pts.shape[0]
    tol = 1e-10 * np.abs(det0)[:, None]
    bad = np.zeros(xyz.shape[0], dtype=bool)
    bad |= (detc[:, :n_node_pts] < -tol).any(axis=1)  # nodes: zero allowed
    bad |= (detc[:, n_node_pts:] <= tol).any(axis=1)  # quadrature points: strictly positive
    if bad.any():
        raise ValueError(
            f"{kind}: the Jacobian changes sign inside the elements at positions "
            f"{np.flatnonzero(bad).tolist()} (badly distorted)"
        )
    return el, xyz


# Voigt index of the strain component (i, k): xx, yy, zz, xy, yz, zx.
_VOIGT = np.array([[0, 3, 5], [3, 1, 4], [5, 4, 2]])


def _kmat(Ct: np.ndarray, ga: np.ndarray, gb: np.ndarray, w: np.ndarray) -> np.ndarray:
    """sum_q w B_a^T C B_b for fields with gradients ga (e, q, A, 3) and gb (e, q, B, 3).

    With the elasticity tensor Ct[e, i, k, j, l] = C[voigt(i, k), voigt(j, l)] (engineering shear
    strains), K[(a, i), (b, j)] = sum_kl Ct[i, k, j, l] P_kl[a, b] with
    P_kl[a, b] = sum_q w ga[q, a, k] gb[q, b, l]: two batched matrix products, no B matrix.
    """
    e, _, A, _ = ga.shape
    B = gb.shape[2]
    gwa = (ga * w[..., None, None]).transpose(0, 3, 2, 1)  # (e, k, A, q)
    P = gwa[:, :, None] @ gb.transpose(0, 3, 1, 2)[:, None]  # (e, k, l, A, B)
    Cm = Ct.transpose(0, 1, 3, 2, 4).reshape(e, 9, 9)  # ((i, j), (k, l))
    K = (Cm @ P.reshape(e, 9, A * B)).reshape(e, 3, 3, A, B)
    return K.transpose(0, 3, 1, 4, 2).reshape(e, 3 * A, 3 * B)


def _mode_gradients(family: str, pts: np.ndarray, w: np.ndarray) -> np.ndarray:
    """d/d(r, s, t) of the incompatible modes at the quadrature points pts, weights w:
    (q, n_modes, 3), with their mean over the reference element removed so that the mode
    strains integrate to zero over any element (the patch-test condition)."""
    q = pts.shape[0]
    r, s, t = pts.T
    if family == "hex":  # 1 - r^2, 1 - s^2, 1 - t^2 (mean already zero)
        out = np.zeros((q, 3, 3))
        for i in range(3):
            out[:, i, i] = -2.0 * pts[:, i]
    else:  # wedge: 1 - t^2, and 4 L1 L2, 4 L2 L3, 4 L3 L1 (L1 = 1 - r - s, L2 = r, L3 = s)
        L1 = 1.0 - r - s
        out = np.zeros((q, 4, 3))
        out[:, 0, 2] = -2.0 * t
        out[:, 1, 0], out[:, 1, 1] = 4 * (L1 - r), -4 * r
        out[:, 2, 0], out[:, 2, 1] = 4 * s, 4 * r
        out[:, 3, 0], out[:, 3, 1] = -4 * s, 4 * (L1 - s)
    return out - np.einsum("q,qmj->mj", w, out) / w.sum()


def _stiffness(
    el: _Element,
    xyz: np.ndarray,
    C: np.ndarray,
    rule: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """sum_q w_q |det J| B^T C B, with the incompatible modes condensed out (HEXA8, PENTA6).

    ``rule``: points and weights in place of the kind's stiffness rule (not for the kinds with
    incompatible modes)."""
    if rule is None:
        _, dN = _shape_at(el.kind, "k")
        weights = el.k_w
    else:
        dN, weights = el.shape(rule[0])[1], rule[1]
    J = _jacobian(xyz, dN)
    wdet = weights * np.abs(np.linalg.det(J))  # (e, q)
    g = dN[None] @ np.linalg.inv(J)  # dN/dx (e, q, a, 3)
    Ct = C[:, _VOIGT[:, :, None, None], _VOIGT[None, None, :, :]]  # (e, i, k, j, l)
    K = _kmat(Ct, g, g, wdet)
    if el.modes:
        # Taylor's modification: the mode strains use the centre Jacobian J0 and |det J0| in
        # place of |det J|, so that they integrate to zero over any element (patch test).
        _, dN0 = _shape_at(el.kind, "centre")
        J0 = _jacobian(xyz, dN0)[:, 0]
        det0 = np.abs(np.linalg.det(J0))[:, None]
        gp = _mode_gradients(el.family, el.k_pts, el.k_w)[None] @ np.linalg.inv(J0)[:, None]
        Kua = _kmat(Ct, g, gp, el.k_w * det0)
        Kaa = _kmat(Ct, gp, gp, el.k_w**2 * det0**2 / wdet)
        K -= Kua @ np.linalg.solve(Kaa, Kua.transpose(0, 2, 1))
    return 0.5 * (K + K.transpose(0, 2, 1))


def _stable_tetra10(el: _Element, xyz: np.ndarray, C: np.ndarray, K: np.ndarray) -> np.ndarray:
    """K with the 5-point rule's indefinite elements integrated by a positive rule instead.

    The 5-point rule's centre weight is negative. On straight-edged elements it is exact, so
    K is positive semi-definite; a strongly curved element (midside nodes a fifth of the edge
    off the chord: 23 of 300 random well-shaped ones) or a curved sliver can get a negative
    eigenvalue. Curved elements whose K has a negative eigenvalue or more than the six
    rigid-body zero modes (below 1e-10 of the largest) are integrated with the collapsed
    4^3 Gauss rule, whose weights are positive. The check costs an eigenvalue solve per curved
    element; straight-edged elements skip it.
    """
    edges = np.array(_EDGES["tet"])
    chord = 0.5 * (xyz[:, edges[:, 0]] + xyz[:, edges[:, 1]])
    length = np.linalg.norm(xyz[:, edges[:, 1]] - xyz[:, edges[:, 0]], axis=2)
    curved = np.flatnonzero(
        (np.linalg.norm(xyz[:, 4:] - chord, axis=2) > 1e-8 * length).any(axis=1)
    )
    if not len(curved):
        return K
    ev = np.linalg.eigvalsh(K[curved])
    tol = 1e-10 * ev[:, -1:]
    bad = curved[(ev[:, 0] < -tol[:, 0]) | ((np.abs(ev) < tol).sum(axis=1) > 6)]
    if len(bad):
        K = K.copy()
        K[bad] = _stiffness(el, xyz[bad], C[bad], rule=_rule("tetc", 4, 0))
    return K


def _scalar_mass(el: _Element, xyz: np.ndarray) -> np.ndarray:
    """int N_a N_b dV: (e, a, b)."""
    N, dN = _shape_at(el.kind, "m")
    wdet = el.m_w * np.abs(np.linalg.det(_jacobian(xyz, dN)))  # (e, q)
    a = el.n_nodes
    NN = (N[:, :, None] * N[:, None, :]).reshape(-1, a * a)
    return (wdet @ NN).reshape(-1, a, a)


# --------------------------------------------------------------------------------------------
# Public kernels
# --------------------------------------------------------------------------------------------


def isotropic_C(E: np.ndarray, nu: np.ndarray) -> np.ndarray:  # noqa: N802 (API name)
    """Isotropic constitutive matrix (n, 6, 6), Voigt xx, yy, zz, xy, yz, zx, engineering shear."""
    E = np.atleast_1d(np.asarray(E, dtype=float))
    nu = np.atleast_1d(np.asarray(nu, dtype=float))
    E, nu = np.broadcast_arrays(E, nu)
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    mu = E / (2 * (1 + nu))
    C = np.zeros((*E.shape, 6, 6))
    C[..., :3, :3] = lam[..., None, None]
    for i in range(3):
        C[..., i, i] += 2 * mu
        C[..., 3 + i, 3 + i] = mu
    return C


def solid_volume(kind: str, xyz: np.ndarray) -> np.ndarray:
    """Volume (n,) of the solid elements; ValueError for elements whose Jacobian changes sign."""
    el, xyz = _prepare(kind, xyz)
    _, dN = _shape_at(kind, "m")
    return np.abs(np.linalg.det(_jacobian(xyz, dN))) @ el.m_w


def solid_matrices(
    kind: str, xyz: np.ndarray, C: np.ndarray, rho: np.ndarray, *, coupled_mass: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness and mass of solid elements of one kind.

    kind: one of HEXA8, HEXA20, PENTA6, PENTA15, TETRA4, TETRA10, PYRAM5, PYRAM13.
    xyz: (n, n_nodes, 3) basic coordinates in NASTRAN node order (either orientation).
    C: (n, 6, 6) constitutive matrix in the basic frame, Voigt xx, yy, zz, xy, yz, zx with
    engineering shear strains. rho: (n,) mass density.
    Returns K, M: (n, 3 n_nodes, 3 n_nodes), DOFs [T1 T2 T3] per node, symmetric. M is lumped
    (row sum for linear kinds, HRZ for quadratic kinds) unless ``coupled_mass``.
    Raises ValueError if an element's Jacobian changes sign inside it or vanishes.
    """
    el, xyz = _prepare(kind, xyz)
    n = xyz.shape[0]
    C = np.broadcast_to(np.asarray(C, dtype=float), (n, 6, 6))
    rho = np.broadcast_to(np.asarray(rho, dtype=float), (n,))
    K = _stiffness(el, xyz, C)
    if kind == "TETRA10":
        K = _stable_tetra10(el, xyz, C, K)
    Ms = rho[:, None, None] * _scalar_mass(el, xyz)
    nd = 3 * el.n_nodes
    if coupled_mass:
        M = np.einsum("eab,ij->eaibj", Ms, np.eye(3)).reshape(n, nd, nd)
        return K, M
    if kind in _QUADRATIC:  # HRZ
        diag = np.einsum("eaa->ea", Ms)
        total = diag.sum(axis=1)
        scale = np.divide(Ms.sum(axis=(1, 2)), total, out=np.zeros_like(total),
                          where=total != 0)  # massless elements (rho = 0) stay massless
        m = diag * scale[:, None]
    else:
        m = Ms.sum(axis=2)
    M = np.zeros((n, nd, nd))
    idx = np.arange(nd)
    M[:, idx, idx] = np.repeat(m, 3, axis=1)
    return K, M
