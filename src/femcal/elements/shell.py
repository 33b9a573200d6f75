"""Shell element kernels: NASTRAN CQUAD4 and CTRIA3 (and, with ``drilling=True``, CQUADR and
CTRIAR), all elements of a type at once.

Element frame (:func:`shell_frame`)
-----------------------------------
* CQUAD4: ``z`` is the unit normal along ``(G3 - G1) x (G4 - G2)``; the diagonals
  ``d1 = G3 - G1`` and ``d2 = G4 - G2`` are both perpendicular to it, so they already lie in
  the mean plane. ``x = unit(d1/|d1| - d2/|d2|)``: the bisector of the angle between ``d1``
  and ``-d2``, which for a rectangle is the ``G1 -> G2`` direction (the bisector of NASTRAN's
  ``2 alpha`` diagonal angle that lies closest to ``G1 -> G2``); ``y = z x x``. The origin is
  the mean of the four nodes.
* CTRIA3: ``x`` from G1 to G2, ``z`` along ``(G2 - G1) x (G3 - G1)``, ``y = z x x``; origin at
  the centroid.

Kinematics and sign conventions (element frame)
-----------------------------------------------
Node DOFs are ``[u v w Rx Ry Rz]`` (T1..R3 in the element frame). The Reissner-Mindlin
director rotations are ``beta_x = Ry`` and ``beta_y = -Rx``, so the in-plane displacement of
a fibre at height ``z`` above the reference plane is ``u + z Ry``, ``v - z Rx`` and

* membrane strain ``eps = [u,x, v,y, u,y + v,x]`` (engineering shear),
* curvature ``kappa = [Ry,x, -Rx,y, Ry,y - Rx,x]``, so the in-plane strain at height ``z`` is
  ``eps + z kappa`` and ``M = integral(sigma z dz)``: a positive ``M_x`` stretches the ``+z``
  (Z2) fibre,
* transverse shear ``gamma = [w,x + Ry, w,y - Rx]`` (order ``xz, yz``),
* resultants ``N = A eps + B kappa``, ``M = B^T eps + D kappa``, ``Q = S gamma``, i.e.
  ``B = integral(Q(z) z dz)`` about the reference plane.

A plate in pure bending (``w`` quadratic, ``Rx = w,y``, ``Ry = -w,x``) has zero transverse
shear and constant curvature ``kappa = -[w,xx, w,yy, 2 w,xy]``.

CQUAD4 formulation
------------------
* Bending and transverse shear: MITC4 (Bathe & Dvorkin 1985). The covariant transverse shear
  strains ``e_xi`` and ``e_eta`` are sampled at the edge midpoints ``(0, +-1)`` and
  ``(+-1, 0)`` and interpolated linearly across the element, then mapped to Cartesian
  ``gamma = J^-1 e`` at each Gauss point; 2x2 Gauss integration. This removes shear locking
  and passes the constant-curvature patch test on distorted meshes.
* Residual bending flexibility (MacNeal, "A simple quadrilateral shell element", Computers &
  Structures 8, 1978, as in NASTRAN's QUAD4): bilinear rotations give no curvature varying
  along its own direction, so under a moment varying linearly across the element (a
  transverse shear force ``Q``) the bending energy ``Q^2 var(x) / (2 D)`` per unit area is
  missing. It is added as transverse shear flexibility: ``S_eff = (S^-1 + sum_k var_k / D_k
  t_k t_k^T)^-1`` over the principal directions ``t_k`` of the element's area covariance
  (``a^2/12``, ``b^2/12`` for an ``a x b`` rectangle), ``D_k`` the cylindrical-bending
  stiffness along ``t_k`` of the laminate about its neutral surface (``D - B^T A^-1 B``).
  A strip of elements under a tip shear load then gives the beam's tip deflection exactly,
  even one element long. It matters on coarse meshes of thin walls (element size several
  times the thickness): NASTRAN's modes of the reference deck pyn_nx_sine_solid (thin skins
  on solid faces) need it. Not applied with MID3 blank (the shear-rigid penalty below
  stands). The CTRIA3 gets the same (below).
* Membrane, CQUAD4 (``drilling=False``, the default): bilinear displacements with Taylor's
  incompatible modes ``(1 - xi^2)``, ``(1 - eta^2)`` on ``u`` and ``v`` (QM6: their gradients
  taken with the centre Jacobian and ``det J0 / det J``, so that their strains integrate to
  zero over any element and the patch test is passed), condensed statically; 2x2 Gauss.
  ``Rz`` enters only the drilling penalty below, as in NASTRAN's CQUAD4, whose drilling
  stiffness is K6ROT's penalty. A rectangle is exact in in-plane pure bending; like every
  4-node quadrilateral it is stiff in in-plane bending when trapezoidal (MacNeal-Harder
  straight beam: 0.99 rectangular, 0.05 trapezoidal, 0.63 parallelogram).
* Membrane, CQUADR (``drilling=True``): Allman-type quadrilateral with drilling rotations
  (Ibrahimbegovic, Taylor & Wilson 1990): bilinear displacements plus, on each edge ``ij``, a
  serendipity midside
  function carrying the normal displacement ``l (Rz_j - Rz_i) / 8`` along the outward normal;
  2x2 Gauss. The quadratic edge terms are what relieves the bilinear element's in-plane shear
  locking (a 10x1 in-plane cantilever of square elements is within 0.5 % of beam theory), but
  elongated or distorted elements remain stiff in in-plane bending (MacNeal-Harder straight
  beam, aspect ratio 5: 0.90 rectangular, 0.78 trapezoidal / parallelogram).
  No incompatible modes are added: their ``1 - xi^2``, ``1 - eta^2`` fields can cancel the
  strain of the Allman alternating-rotation mode and leave a near-spurious membrane mode.
* Warped quadrilaterals: the element is flat, lying in the mean plane of the frame above. The
  nodes' distances ``+-h`` from that plane are bridged by rigid links along the element normal
  (the same device as ZOFFS below), which keeps the six rigid-body modes exact for a warped
  element. No other warping correction is made.

CTRIA3 formulation
------------------
* Membrane, CTRIA3 (``drilling=False``): the constant-strain triangle; ``Rz`` only in the
  drilling penalty. CTRIAR (``drilling=True``): Allman (1984) triangle: linear displacements
  plus the quadratic edge terms ``4 L_i L_j l (Rz_j - Rz_i) / 8`` along each edge's outward
  normal (the same device as the quadrilateral), integrated by the 3-point rule; with equal
  drilling rotations it is the constant-strain triangle.
* Bending: linear rotations, constant curvature. Transverse shear: MITC3 (Lee & Bathe 2004):
  ``e_r = e_r(1) + c s``, ``e_s = e_s(2) - c r`` with ``c = e_s(2) - e_r(1) - e_s(3) + e_r(3)``
  and tying points (1) ``(1/2, 0)``, (2) ``(0, 1/2)``, (3) ``(1/2, 1/2)``: the tangential shear
  is constant along each edge. MITC3 is isotropic (independent of node numbering), has no
  spurious zero-energy modes and passes the constant-curvature patch test; integrated by the
  3-point rule (exact here).
* Residual bending flexibility, as the CQUAD4's above, with the triangle's area covariance
  ``sum_i (p_i - c)(p_i - c)^T / 12``: constant curvature misses the same energy under a
  transverse shear force. This is also what keeps MITC3 from locking on coarse meshes of thin
  plates (it has the form of the stabilisation of Lyly, Stenberg & Vihinen, Comput. Mech. 13,
  1993, ``S t^2 / (t^2 + c h^2)``). Unlike the CQUAD4's, it is applied to the shear-rigid
  penalty too (MID3 blank, below), which locks MITC3 as well (both checked by
  ``tests/test_sol103_analytic.py``: ``test_thin_plates_do_not_lock``,
  ``test_shear_rigid_triangles_do_not_lock``).

Drilling rotation (K6ROT, SNORM)
--------------------------------
A Hughes-Brezzi penalty ties ``Rz`` to the in-plane rotation ``omega = (v,x - u,y) / 2`` of
the membrane field: ``U_drill = 1/2 alpha integral((Rz - omega)^2 dA)``, integrated with the
element's full rule (2x2 Gauss, or the 3-point triangle rule).

* CQUADR / CTRIAR (Allman membranes, ``Rz`` the physical in-plane rotation; NASTRAN's R
  elements ignore K6ROT): ``omega`` includes the Allman terms and
  ``alpha = (DRILL_GAMMA + k6rot * 1e-6) * A[2, 2]``, ``DRILL_GAMMA = 1``: the ``gamma = G``
  recommended by Ibrahimbegovic, Taylor & Wilson (the Allman terms alone would leave an
  equal-``Rz`` mode). A free element has exactly six zero-energy modes.
* CQUAD4 / CTRIA3: the membranes do not use ``Rz`` (NASTRAN's do not: its CQUAD4 and CTRIA3
  membranes are the bilinear / constant-strain ones, and femcal's strain energies with
  NASTRAN's printed mode shapes of pyn_mode_solid_shell_bar agree with its printed ones only
  so). ``Rz`` carries NASTRAN's K6ROT penalty (QRG, PARAM K6ROT: ``1e-6 K6ROT G t`` on the
  element's area, G of MID1, none for a membrane with MID1 alone), with the modulus
  ``alpha = 9 (quadrilateral) or 12 (triangle) x 1e-6 K6ROT A[2, 2]``, so that one corner's
  ``Rz`` alone costs ``1e-6 K6ROT G t A`` on a CQUAD4 and ``... 2A`` on a CTRIA3: the
  values MYSTRAN's authors matched to MSC's element matrices (``CALC_K6ROT.f90``). With the
  default K6ROT = 100 this is weak (``1e-4 G t A``): a bar that twists a flat shell about its
  normal meets little resistance there, as in NASTRAN (``tests/test_drilling.py``); the
  reference deck pyn_goland, a CQUAD4 wing whose offset CONM2s load it, checks it against
  MSC (``tests/test_conformance.py``). Without K6ROT the drilling rotations are free
  (AUTOSPC fixes them, as NASTRAN's).

  Where the shell is curved, flat facets with a weak drilling stiffness hinge: the rotation
  about one element's normal is a bending rotation of its slightly tilted neighbour, free up
  to the penalty, so neighbours' bending rotations part (the MacNeal-Harder twisted beam is
  +35 % too flexible on any mesh). NASTRAN avoids this with unique grid-point normals (PARAM
  SNORM, default 20 degrees: a grid's normal is the mean of its shells' normals when each
  lies within SNORM of it; none at a fold), about which it takes the drilling rotation; how
  they enter its element matrices is not published. femcal instead ties ``Rz`` at such grids
  (:func:`grid_normals`; ``normals`` of the kernels): ``alpha += min(PENALTY_GAMMA A[2, 2],
  TIE_SCALE sin^2(eps) D / area)``, ``eps`` the largest angle between the element's normal
  and a grid normal at its corners, ``D`` the mean bending stiffness. The hinge's stiffness
  goes as ``alpha / eps^2`` against bending ``D / area``, so this is the same tie for every
  mesh of a surface and vanishes on flat shells and at folds, where the K6ROT penalty alone
  is NASTRAN's. ``PENALTY_GAMMA = 0.1``, ``TIE_SCALE = 600``: the twisted beam within 1 % on
  2x12, 4x24 and 8x48 meshes. Where a curved shell's drilling rotation is loaded (a bar about
  its normal), femcal is therefore stiffer there than NASTRAN.

``omega`` includes the incompatible modes' rotation (without it the penalty locks the
membrane in in-plane bending); condensing them relaxes a corner's K6ROT stiffness a little
(4e-5 of it at K6ROT 100).

Shear-rigid plates (``S=None``)
-------------------------------
NASTRAN omits transverse shear flexibility when MID3 is blank. ``S=None`` emulates this with a
stiff penalty ``S = 1e4 * trace(D) / area * I``, a shear-to-bending stiffness ratio of about
``1e4`` on the scale of one element: far stiffer than the plate's bending, and well
conditioned because MITC4 does not lock. The CTRIA3 adds its residual bending flexibility to
the penalty (MITC3 would lock), which makes the plate a Kirchhoff plate in the limit of small
elements.

Offsets (ZOFFS)
---------------
The reference plane lies at ``zoffs`` along the element ``z`` axis from the grid plane. Each
element node is connected to its grid by a rigid link of length ``d = zoffs - h_a`` along ``z``
(``h_a`` the node's warping distance, 0 for a flat element): ``u_ref = u + d Ry``,
``v_ref = v - d Rx``, ``w``, ``R`` unchanged. ``K`` and ``M`` are both transformed. For a flat
element this is exactly the laminate ``B -> B + d A``, ``D -> D + d (B + B^T) + d^2 A`` about
the grid plane, except for the drilling penalty, whose ``omega`` is that of the reference
plane.

Mass
----
Translational only, no rotary inertia in the reference plane; ``m = rho_area + nsm`` per unit
area. Lumped (default): node ``a`` gets ``m integral(N_a dA)`` (the row sum of the consistent
mass; ``area/4`` for a parallelogram, ``area/3`` for a triangle) on T1, T2 and T3. Coupled:
``m integral(N_a N_b dA)`` on each translation with the node shape functions of the
membrane (bilinear / linear; the Allman drilling terms carry no mass). The rigid
offsets carry the mass to the grids (which then shows rotational terms at the grid), and the
total translational mass stays ``m * area`` (projected area for warped quads).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["grid_normals", "quad4_matrices", "shell_frame", "tria3_matrices"]

#: Ratio of the penalty transverse shear stiffness to ``trace(D) / area`` for ``S=None``.
SHEAR_RIGID_PENALTY = 1.0e4
#: Drilling penalty: ``alpha = (DRILL_GAMMA + k6rot * DRILL_SCALE) * A[2, 2]`` (CQUADR,
#: CTRIAR: the Allman membranes); CQUAD4 / CTRIA3, whose membranes do not use ``Rz``: K6ROT's
#: penalty and, where curved, a tie of at most ``PENALTY_GAMMA * A[2, 2]`` (see "Drilling
#: rotation" above).
DRILL_GAMMA = 1.0
PENALTY_GAMMA = 0.1
DRILL_SCALE = 1.0e-6
#: CQUAD4 / CTRIA3 curvature tie: ``alpha_tie = min(PENALTY_GAMMA A[2, 2], TIE_SCALE
#: sin^2(eps) D / area)``, ``eps`` the largest angle between the element normal and a grid
#: normal at its nodes (see "Drilling rotation" above).
TIE_SCALE = 600.0

_G = 1.0 / np.sqrt(3.0)
_GAUSS_2X2 = ((-_G, -_G), (_G, -_G), (_G, _G), (-_G, _G))
_XI = np.array([-1.0, 1.0, 1.0, -1.0])
_ETA = np.array([-1.0, -1.0, 1.0, 1.0])
# 3-point triangle rule (degree 2) in area coordinates (r, s); weights sum to 1/2.
_TRI_POINTS = ((1.0 / 6.0, 1.0 / 6.0), (2.0 / 3.0, 1.0 / 6.0), (1.0 / 6.0, 2.0 / 3.0))
_TRI_WEIGHT = 1.0 / 6.0


def _unit(v: np.ndarray, what: str) -> np.ndarray:
    """Normalise the rows of ``v`` (n, 3); raise on zero-length rows."""
    nrm = np.linalg.norm(v, axis=-1)
    bad = ~(nrm > 0.0)
    if np.any(bad):
        raise ValueError(
            f"degenerate shell geometry ({what}) for element index(es) "
            f"{np.flatnonzero(bad)[:10].tolist()}"
        )
    return v / nrm[:, None]


def shell_frame(xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Element frame of CQUAD4 / CTRIA3 elements (see the module docstring).

    Parameters
    ----------
    xyz : ndarray, shape (n, 4, 3) or (n, 3, 3)
        Node coordinates in basic, NASTRAN order G1..G4 (or G1..G3), length units.

    Returns
    -------
    T : ndarray, shape (n, 3, 3)
        Rows are the element x, y, z unit axes in basic, so ``T @ v_basic`` gives the
        element-frame components of a vector.
    centre : ndarray, shape (n, 3)
        Frame origin in basic (mean of the nodes), length units.
    """
    xyz = np.asarray(xyz, dtype=float)
    if xyz.ndim != 3 or xyz.shape[2] != 3 or xyz.shape[1] not in (3, 4):
        raise ValueError(f"xyz must have shape (n, 3 or 4, 3), got {xyz.shape}")
    centre = xyz.mean(axis=1)
    if xyz.shape[1] == 4:
        d1 = xyz[:, 2] - xyz[:, 0]
        d2 = xyz[:, 3] - xyz[:, 1]
        z = _unit(np.cross(d1, d2), "normal")
        x = _unit(d1, "diagonal G1-G3") - _unit(d2, "diagonal G2-G4")
    else:
        x = xyz[:, 1] - xyz[:, 0]
        z = _unit(np.cross(x, xyz[:, 2] - xyz[:, 0]), "normal")
    x = x - np.einsum("ei,ei->e", x, z)[:, None] * z
    x = _unit(x, "x axis")
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=1), centre


def grid_normals(
    n_grids: int, connectivity: list[np.ndarray], normals: list[np.ndarray], snorm: float
) -> np.ndarray:
    """NASTRAN's unique grid-point normals (PARAM SNORM), in basic: (n_grids, 3), NaN at grids
    that get none.

    A grid's normal is the mean of the unit normals of the shells at it, kept only if every
    one of those normals lies within ``snorm`` degrees of it (``snorm <= 0``: none).

    Parameters
    ----------
    n_grids : number of grids (node indices run 0 .. n_grids - 1).
    connectivity : per element type, (n, k) corner node indices (-1: absent).
    normals : per element type, (n, 3) unit element normals in basic (``shell_frame``).
    snorm : PARAM SNORM, degrees.
    """
    out = np.full((n_grids, 3), np.nan)
    if snorm <= 0.0 or not connectivity:
        return out
    nodes = np.concatenate([c.ravel() for c in connectivity])
    each = np.concatenate([np.repeat(nrm, c.shape[1], axis=0)
                           for c, nrm in zip(connectivity, normals, strict=True)])  # fmt: skip
    keep = nodes >= 0
    nodes, each = nodes[keep], each[keep]
    total = np.zeros((n_grids, 3))
    np.add.at(total, nodes, each)
    length = np.linalg.norm(total, axis=1)
    mean = np.divide(total, length[:, None], out=np.full_like(total, np.nan),
                     where=length[:, None] > 1e-12)  # fmt: skip
    cos = np.einsum("ei,ei->e", each, mean[nodes])
    ok = np.ones(n_grids, bool)
    np.logical_and.at(ok, nodes, cos >= np.cos(np.radians(snorm)))
    used = np.zeros(n_grids, bool)
    used[nodes] = True
    good = ok & used & np.isfinite(mean).all(axis=1)
    out[good] = mean[good]
    return out


# ----------------------------------------------------------------------------------------
# Input handling
# ----------------------------------------------------------------------------------------


def _per_elem(a: ArrayLike | None, n: int, shape: tuple[int, ...], name: str) -> np.ndarray:
    """Broadcast ``a`` to (n, *shape) as a float array (a copy)."""
    arr = np.asarray(0.0 if a is None else a, dtype=float)
    try:
        return np.array(np.broadcast_to(arr, (n, *shape)), dtype=float)
    except ValueError as exc:
        raise ValueError(
            f"{name} of shape {arr.shape} does not broadcast to {(n, *shape)}"
        ) from exc


def _constitutive(A: np.ndarray, D: np.ndarray, S: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Generalised constitutive matrix (n, 8, 8) for [eps(3), kappa(3), gamma(2)]."""
    n = A.shape[0]
    C = np.zeros((n, 8, 8))
    C[:, 0:3, 0:3] = A
    C[:, 0:3, 3:6] = B
    C[:, 3:6, 0:3] = np.swapaxes(B, 1, 2)
    C[:, 3:6, 3:6] = D
    C[:, 6:8, 6:8] = S
    return C


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
    frame: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]] | None = None,
    drill_gamma: float | None = None,
) -> tuple[np.ndarray, ...]:
    """Validate and broadcast the kernel inputs; compute frame and local node coordinates.

    Returns ``T, xl, h, A, D, S (or None), B, m, zoffs, alpha`` with ``xl`` (n, nn, 2) the
    in-plane local coordinates, ``h`` (n, nn) the warping distances, ``m`` the mass per area
    and ``alpha = (drill_gamma + k6rot * DRILL_SCALE) * A[2, 2]`` the drilling penalty
    modulus (``drill_gamma`` None: :data:`DRILL_GAMMA`). ``frame`` gives (T, centre) of the
    elements (default :func:`shell_frame`).
    """
    xyz = np.asarray(xyz, dtype=float)
    if xyz.ndim != 3 or xyz.shape[1:] != (n_nodes, 3):
        raise ValueError(f"xyz must have shape (n, {n_nodes}, 3), got {xyz.shape}")
    n = xyz.shape[0]
    T, centre = (frame or shell_frame)(xyz)
    p = np.einsum("eij,eaj->eai", T, xyz - centre[:, None, :])
    A = _per_elem(A, n, (3, 3), "A")
    D = _per_elem(D, n, (3, 3), "D")
    B = _per_elem(B, n, (3, 3), "B")
    S_arr = None if S is None else _per_elem(S, n, (2, 2), "S")
    m = _per_elem(rho_area, n, (), "rho_area") + _per_elem(nsm, n, (), "nsm")
    zoffs = _per_elem(zoffs, n, (), "zoffs")
    gamma = DRILL_GAMMA if drill_gamma is None else drill_gamma
    alpha = (gamma + _per_elem(k6rot, n, (), "k6rot") * DRILL_SCALE) * A[:, 2, 2]
    return T, p[..., :2], p[..., 2], A, D, S_arr, B, m, zoffs, alpha


def _polygon_area(xl: np.ndarray) -> np.ndarray:
    """(n,) area of the polygons (n, k, 2) of in-plane corner coordinates."""
    x, y = xl[..., 0], xl[..., 1]
    return 0.5 * np.abs((x * np.roll(y, -1, axis=1) - np.roll(x, -1, axis=1) * y).sum(axis=1))


def _k6rot_modulus(alpha: np.ndarray, D: np.ndarray, corners: int) -> np.ndarray:
    """CQUAD4 / CTRIA3 drilling modulus (n,) from ``alpha = 1e-6 K6ROT A[2, 2]``: scaled so
    that one corner's ``Rz`` alone costs ``1e-6 K6ROT G t A`` (a triangle: ``2 A``), as in
    NASTRAN (see "Drilling rotation"); zero without bending stiffness (MID2 blank)."""
    scale = 12.0 if corners == 3 else 9.0  # 1 / integral(N_a^2 dA / A), triangle / parallelogram
    bending = np.abs(D).reshape(len(D), -1).max(axis=1) > 0.0
    return np.where(bending, scale * alpha, 0.0)


def _curvature_tie(
    T: np.ndarray, xl: np.ndarray, normals: ArrayLike | None, A: np.ndarray, D: np.ndarray
) -> np.ndarray:
    """Drilling modulus (n,) that ties ``Rz`` where the shell is curved (see "Drilling rotation").

    ``normals`` (n, nn, 3) are the grid normals at the element's nodes in basic (NaN: the
    grid has none); a node without one, or whose normal is the element's own, adds nothing.
    """
    if normals is None:
        return np.zeros(T.shape[0])
    normals = np.asarray(normals, dtype=float)
    if normals.shape != (T.shape[0], xl.shape[1], 3):
        raise ValueError(f"normals must have shape ({T.shape[0]}, {xl.shape[1]}, 3), "
                         f"got {normals.shape}")  # fmt: skip
    normals = np.where(np.isnan(normals), T[:, None, 2], normals)
    cos = np.einsum("eai,ei->ea", normals, T[:, 2]) / np.linalg.norm(normals, axis=2)
    sin2 = np.clip(1.0 - cos * cos, 0.0, 1.0).max(axis=1)
    area = _polygon_area(xl)
    bending = 0.5 * (D[:, 0, 0] + D[:, 1, 1])
    return np.minimum(PENALTY_GAMMA * A[:, 2, 2], TIE_SCALE * sin2 * bending / area)


def _area_covariance(xl: np.ndarray, detJ: list[np.ndarray], area: np.ndarray) -> np.ndarray:
    """Second central moment of a quadrilateral's area per unit area (n, 2, 2), in length^2:
    ``integral((x - xc)(x - xc)^T dA) / area``, by the 2x2 rule (exact for the bilinear map).
    ``a^2 / 12`` and ``b^2 / 12`` on the diagonal for an ``a x b`` rectangle."""
    pts = [np.einsum("a,eai->ei", _quad_shape(xi, eta)[0], xl) for xi, eta in _GAUSS_2X2]
    centre = sum(dJ[:, None] * x for dJ, x in zip(detJ, pts, strict=True)) / area[:, None]
    cov = sum(dJ[:, None, None] * np.einsum("ei,ej->eij", x - centre, x - centre)
              for dJ, x in zip(detJ, pts, strict=True))  # fmt: skip
    return cov / area[:, None, None]


def _with_residual_bending(
    S: np.ndarray, cov: np.ndarray, A: np.ndarray, B: np.ndarray, D: np.ndarray
) -> np.ndarray:
    """Transverse shear stiffness (n, 2, 2) with MacNeal's residual bending flexibility added.

    ``S_eff = (S^-1 + sum_k cov_k / D_k t_k t_k^T)^-1``: ``t_k`` and ``cov_k`` the principal
    directions and values of the element's area covariance ``cov``, ``D_k`` the bending
    stiffness for curvature along ``t_k`` alone (``m^T D* m`` with ``m = [tx^2, ty^2,
    2 tx ty]``) of the laminate about its neutral surface, ``D* = D - B^T A^-1 B`` (so a
    reference-plane offset does not change it; ``D`` itself where ``A`` is singular, with no
    membrane to relax). Elements without bending stiffness along a direction get no term
    there, and elements whose ``S`` is singular (no transverse shear stiffness in some
    direction) keep their ``S``.
    """
    keep = np.linalg.det(S) <= 0.0
    if keep.all():
        return S
    if keep.any():
        out = S.copy()
        out[~keep] = _with_residual_bending(S[~keep], cov[~keep], A[~keep], B[~keep], D[~keep])
        return out
    Dstar = D.copy()
    coupled = np.abs(B).reshape(len(B), -1).max(axis=1) > 0.0
    coupled &= np.linalg.det(A) > 0.0
    if coupled.any():
        Dstar[coupled] -= np.swapaxes(B[coupled], 1, 2) @ np.linalg.solve(A[coupled], B[coupled])
    lam, vec = np.linalg.eigh(cov)
    compliance = np.linalg.inv(S)
    for k in range(2):
        t = vec[:, :, k]
        m = np.stack([t[:, 0] ** 2, t[:, 1] ** 2, 2.0 * t[:, 0] * t[:, 1]], axis=1)
        Dk = np.einsum("ei,eij,ej->e", m, Dstar, m)
        c = np.divide(lam[:, k], Dk, out=np.zeros_like(Dk), where=Dk > 0.0)
        compliance += c[:, None, None] * np.einsum("ei,ej->eij", t, t)
    return np.linalg.inv(compliance)


def _shear_penalty(D: np.ndarray, area: np.ndarray) -> np.ndarray:
    """Shear-rigid penalty S (n, 2, 2) = 1e4 * trace(D) / area * I."""
    s = SHEAR_RIGID_PENALTY * np.trace(D, axis1=1, axis2=2) / area
    return s[:, None, None] * np.eye(2)


# ----------------------------------------------------------------------------------------
# Strain-displacement rows (element frame, 6 DOFs per node: u v w Rx Ry Rz)
# ----------------------------------------------------------------------------------------


def _allman_coefficients(xl: np.ndarray, edges: tuple[tuple[int, int], ...]) -> np.ndarray:
    """Allman edge coefficients (n, 2, n_edges, nn): bubble k's (u, v) amplitude per Rz_a.

    Edge ``k`` from node ``i`` to ``j`` (counter-clockwise) has midside normal displacement
    ``l (Rz_j - Rz_i) / 8`` along its outward normal, i.e. ``(du, dv) = (y_j - y_i,
    x_i - x_j) (Rz_j - Rz_i) / 8``.
    """
    n, nn, _ = xl.shape
    G = np.zeros((n, 2, len(edges), nn))
    for k, (i, j) in enumerate(edges):
        du = (xl[:, j, 1] - xl[:, i, 1]) / 8.0
        dv = (xl[:, i, 0] - xl[:, j, 0]) / 8.0
        for comp, dd in ((0, du), (1, dv)):
            G[:, comp, k, j] += dd
            G[:, comp, k, i] -= dd
    return G


def _allman_gradients(Jinv: np.ndarray, bubbles: np.ndarray, Gal: np.ndarray | None
                      ) -> np.ndarray | None:  # fmt: skip
    """d(u, v)/d(x, y) per Rz_a (n, comp, deriv, nn) of the Allman edge bubbles at a point:
    ``Jinv`` (n, 2, 2) the inverse Jacobian there, ``bubbles`` (2, n_edges) the bubbles'
    natural derivatives, ``Gal`` (n, 2, n_edges, nn) from :func:`_allman_coefficients`;
    None without Allman terms (Gal None)."""
    if Gal is None:
        return None
    return np.einsum("edk,ecka->ecda", np.einsum("eir,rk->eik", Jinv, bubbles), Gal)


def _membrane_bending_rows(dNxy: np.ndarray, dR: np.ndarray | None) -> np.ndarray:
    """Rows (n, 6, 6 nn) of [eps, kappa].

    ``dNxy`` (n, 2, nn) Cartesian derivatives of the node shape functions, ``dR`` the Allman
    terms' gradients (:func:`_allman_gradients`; None: no Allman terms).
    """
    n, _, nn = dNxy.shape
    Bm = np.zeros((n, 6, 6 * nn))
    for a in range(nn):
        dx, dy = dNxy[:, 0, a], dNxy[:, 1, a]
        c = 6 * a
        Bm[:, 0, c] = dx
        Bm[:, 1, c + 1] = dy
        Bm[:, 2, c] = dy
        Bm[:, 2, c + 1] = dx
        if dR is not None:
            Bm[:, 0, c + 5] = dR[:, 0, 0, a]
            Bm[:, 1, c + 5] = dR[:, 1, 1, a]
            Bm[:, 2, c + 5] = dR[:, 0, 1, a] + dR[:, 1, 0, a]
        # beta_x = Ry, beta_y = -Rx
        Bm[:, 3, c + 4] = dx
        Bm[:, 4, c + 3] = -dy
        Bm[:, 5, c + 4] = dy
        Bm[:, 5, c + 3] = -dx
    return Bm


def _covariant_shear_rows(N: np.ndarray, dN: np.ndarray, xl: np.ndarray) -> np.ndarray:
    """Rows (n, 2, 6 nn) of the covariant transverse shear strains at one natural point.

    ``e_r = w,r + beta . x,r`` for r in (xi, eta); ``N`` (nn,), ``dN`` (2, nn) natural
    derivatives, ``xl`` (n, nn, 2) local node coordinates.
    """
    n, nn, _ = xl.shape
    J = np.einsum("ra,eai->eri", dN, xl)  # rows: d(x, y)/d(r)
    rows = np.zeros((n, 2, 6 * nn))
    for a in range(nn):
        c = 6 * a
        rows[:, :, c + 2] = dN[:, a]
        rows[:, :, c + 4] = N[a] * J[:, :, 0]  # beta_x = Ry
        rows[:, :, c + 3] = -N[a] * J[:, :, 1]  # beta_y = -Rx
    return rows


def _drill_row(N: np.ndarray, dNxy: np.ndarray, dR: np.ndarray | None) -> np.ndarray:
    """Row (n, 6 nn) of ``Rz - (v,x - u,y) / 2`` (membrane field including Allman terms;
    ``dR`` as :func:`_membrane_bending_rows` takes it)."""
    n, _, nn = dNxy.shape
    r = np.zeros((n, 6 * nn))
    for a in range(nn):
        c = 6 * a
        r[:, c] = 0.5 * dNxy[:, 1, a]
        r[:, c + 1] = -0.5 * dNxy[:, 0, a]
        r[:, c + 5] = N[a] if dR is None else N[a] - 0.5 * (dR[:, 1, 0, a] - dR[:, 0, 1, a])
    return r


def _quad_shape(xi: float, eta: float) -> tuple[np.ndarray, np.ndarray]:
    """Bilinear shape functions (4,) and natural derivatives (2, 4) at (xi, eta)."""
    N = 0.25 * (1.0 + xi * _XI) * (1.0 + eta * _ETA)
    dN = np.stack([0.25 * _XI * (1.0 + eta * _ETA), 0.25 * _ETA * (1.0 + xi * _XI)])
    return N, dN


def _quad_bubbles(xi: float, eta: float) -> np.ndarray:
    """Natural derivatives (2, 4) of the serendipity midside functions of edges 12 23 34 41."""
    return np.array(
        [
            [-xi * (1 - eta), 0.5 * (1 - eta * eta), -xi * (1 + eta), -0.5 * (1 - eta * eta)],
            [-0.5 * (1 - xi * xi), -(1 + xi) * eta, 0.5 * (1 - xi * xi), -(1 - xi) * eta],
        ]
    )


def _tri_shape(r: float, s: float) -> tuple[np.ndarray, np.ndarray]:
    """Linear triangle shape functions (3,) and natural derivatives (2, 3) at (r, s)."""
    N = np.array([1.0 - r - s, r, s])
    dN = np.array([[-1.0, 1.0, 0.0], [-1.0, 0.0, 1.0]])
    return N, dN


def _tri_bubbles(r: float, s: float) -> np.ndarray:
    """Natural derivatives (2, 3) of the midside functions 4 L_i L_j of edges 12 23 31."""
    t = 1.0 - r - s
    return 4.0 * np.array([[t - r, s, -s], [-r, r, t - s]])


_QUAD_EDGES = ((0, 1), (1, 2), (2, 3), (3, 0))
_TRI_EDGES = ((0, 1), (1, 2), (2, 0))


# ----------------------------------------------------------------------------------------
# Element-frame matrices
# ----------------------------------------------------------------------------------------


#: A quadrilateral's in-plane DOFs (u, v, Rz of each node, in the element's 24) and its
#: out-of-plane ones (w, Rx, Ry): membrane and drilling strains take only the first (and
#: the incompatible modes), curvatures and transverse shear only the second.
_QUAD_PLANE = np.array([6 * a + i for a in range(4) for i in (0, 1, 5)])
_QUAD_OUT = np.array([6 * a + i for a in range(4) for i in (2, 3, 4)])


@dataclass(frozen=True)
class QuadGeometry:
    """What CQUAD4 elements' stiffness and mass take from their shape alone (the element
    frame's corner coordinates): kept by an assembly that forms the same elements again with
    other section properties (:class:`femcal.assembly.repeated.RepeatedAssembly`).

    detJ : per Gauss point (n,) Jacobian determinants; area (n,); cov (n, 2, 2) the area
        covariance (length^2). plane : (n, 4, 4, k) per Gauss point ``sqrt(w det J)`` times
        the membrane strain rows (3) and the drilling residual's row (``Rz - omega``, for a
        unit modulus) over the in-plane DOFs :data:`_QUAD_PLANE` and, with Taylor's
        incompatible modes, their four amplitudes (k = 16; 12 with the Allman membrane).
        bending : (n, 4, 5, 12) per Gauss point ``sqrt(w det J)`` times the curvature (3)
        and transverse shear (2) rows over the out-of-plane DOFs :data:`_QUAD_OUT`.
        Nint (n, 4), Mcons (n, 4, 4): int(N_a) and int(N_a N_b).
    """

    detJ: list[np.ndarray]  # noqa: N815 (the formulas' symbol)
    area: np.ndarray
    cov: np.ndarray
    plane: np.ndarray
    bending: np.ndarray
    Nint: np.ndarray
    Mcons: np.ndarray


def quad_geometry(xl: np.ndarray, drilling: bool = True) -> QuadGeometry:
    """The shape-only part of :func:`_quad4_local` for corner coordinates xl (n, 4, 2).

    Raises
    ------
    ValueError
        For a non-positive Jacobian (a concave or twisted quadrilateral).
    """
    n = xl.shape[0]
    jac = [np.einsum("ra,eai->eri", _quad_shape(xi, eta)[1], xl) for xi, eta in _GAUSS_2X2]
    detJ = [np.linalg.det(J) for J in jac]
    if np.any(np.stack(detJ) <= 0.0):
        bad = np.flatnonzero(np.any(np.stack(detJ) <= 0.0, axis=0))
        raise ValueError(
            f"CQUAD4 with non-positive Jacobian (concave or twisted) at element "
            f"index(es) {bad[:10].tolist()}"
        )
    area = np.sum(detJ, axis=0)

    # Covariant transverse shear strains at the MITC4 tying points (edge midpoints).
    tie = {
        pt: _covariant_shear_rows(*_quad_shape(*pt), xl)
        for pt in ((0.0, -1.0), (0.0, 1.0), (-1.0, 0.0), (1.0, 0.0))
    }

    if drilling:
        Gal = _allman_coefficients(xl, _QUAD_EDGES)
    else:  # no Allman terms
        Gal = None
        J0inv = np.linalg.inv(np.einsum("ra,eai->eri", _quad_shape(0.0, 0.0)[1], xl))
        det0 = area / 4.0  # det J at the centre of a bilinear map is the mean
    k = 12 if drilling else 16  # + u, v times (1 - xi^2), (1 - eta^2), condensed below
    # Per Gauss point q: weighted rows sqrt(w det J) B_q, stacked so that K is one batched
    # product over all points per DOF set.
    plane = np.zeros((n, 4, 4, k))
    bending = np.zeros((n, 4, 5, 12))
    Nint = np.zeros((n, 4))
    Mcons = np.zeros((n, 4, 4))
    for q, ((xi, eta), J, dJ) in enumerate(zip(_GAUSS_2X2, jac, detJ, strict=True)):
        N, dN = _quad_shape(xi, eta)
        Jinv = np.linalg.inv(J)
        dNxy = np.einsum("eir,ra->eia", Jinv, dN)
        dR = _allman_gradients(Jinv, _quad_bubbles(xi, eta), Gal)
        root = np.sqrt(dJ)[:, None, None]
        Bg = _membrane_bending_rows(dNxy, dR)
        plane[:, q, :3, :12] = root * Bg[:, :3, _QUAD_PLANE]
        bending[:, q, :3] = root * Bg[:, 3:6, _QUAD_OUT]
        e_xi = 0.5 * (1.0 - eta) * tie[0.0, -1.0][:, 0] + 0.5 * (1.0 + eta) * tie[0.0, 1.0][:, 0]
        e_eta = 0.5 * (1.0 - xi) * tie[-1.0, 0.0][:, 1] + 0.5 * (1.0 + xi) * tie[1.0, 0.0][:, 1]
        bending[:, q, 3:] = root * (Jinv @ np.stack([e_xi, e_eta], axis=1))[:, :, _QUAD_OUT]
        plane[:, q, 3, :12] = root[:, 0] * _drill_row(N, dNxy, dR)[:, _QUAD_PLANE]
        if not drilling:  # Taylor: centre Jacobian, det0 / det J, so the modes' strains
            g = np.einsum("eir,rk->eik", J0inv, np.diag([-2.0 * xi, -2.0 * eta]))  # mean 0
            g *= (det0 / np.sqrt(dJ))[:, None, None]
            plane[:, q, 0, 12:14] = g[:, 0]  # u modes: eps_xx = du/dx, gamma = du/dy
            plane[:, q, 2, 12:14] = g[:, 1]
            plane[:, q, 1, 14:16] = g[:, 1]  # v modes: eps_yy = dv/dy, gamma = dv/dx
            plane[:, q, 2, 14:16] = g[:, 0]
            # their in-plane rotation omega = (v,x - u,y) / 2 in the residual Rz - omega
            plane[:, q, 3, 12:14] = 0.5 * g[:, 1]
            plane[:, q, 3, 14:16] = -0.5 * g[:, 0]
        Nint += dJ[:, None] * N
        Mcons += dJ[:, None, None] * np.outer(N, N)
    return QuadGeometry(detJ, area, _area_covariance(xl, detJ, area), plane, bending, Nint,
                        Mcons)  # fmt: skip


def _quad4_local(
    xl: np.ndarray,
    A: np.ndarray,
    D: np.ndarray,
    S: np.ndarray | None,
    B: np.ndarray,
    alpha: np.ndarray,
    drilling: bool = True,
    geometry: QuadGeometry | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Element-frame stiffness (n, 24, 24), int(N_a) (n, 4) and int(N_a N_b) (n, 4, 4).

    ``drilling``: the Allman membrane (CQUADR); else the bilinear membrane with Taylor's
    incompatible modes (CQUAD4), ``Rz`` only in the drilling penalty. ``geometry``: the
    elements' :func:`quad_geometry` (for the same ``drilling``) if at hand.

    ``sum_q B_q^T C B_q`` is formed on the two DOF sets apart (:class:`QuadGeometry`): the
    in-plane one with the membrane stiffness and the drilling modulus, the out-of-plane one
    with the bending and transverse shear stiffness, and their coupling with ``B`` where
    there is any.
    """
    own = geometry is None
    geo = quad_geometry(xl, drilling) if own else geometry
    n = xl.shape[0]
    S = (_shear_penalty(D, geo.area) if S is None
         else _with_residual_bending(S, geo.cov, A, B, D))  # fmt: skip
    P, O = geo.plane, geo.bending
    k = P.shape[3]
    Cp = np.zeros((n, 4, 4))
    Cp[:, :3, :3] = A
    Cp[:, 3, 3] = alpha
    Kp = np.swapaxes(P.reshape(n, 16, k), 1, 2) @ (Cp[:, None] @ P).reshape(n, 16, k)
    Co = np.zeros((n, 5, 5))
    Co[:, :3, :3] = D
    Co[:, 3:, 3:] = S
    Ko = np.swapaxes(O.reshape(n, 20, 12), 1, 2) @ (Co[:, None] @ O).reshape(n, 20, 12)
    coupled = B.any()
    if not drilling and not coupled:  # the modes meet the in-plane DOFs alone: condensed there
        Kp = _condense(Kp, 4)
    size = 12 + Kp.shape[1]  # 24, or 28 with the incompatible modes still in
    plane = np.concatenate([_QUAD_PLANE, np.arange(24, size)])
    K = np.zeros((n, size, size))
    K[:, plane[:, None], plane] = Kp
    K[:, _QUAD_OUT[:, None], _QUAD_OUT] = Ko
    if coupled:  # membrane-bending coupling: N = B kappa, M = B^T eps
        Kc = (np.swapaxes(P[:, :, :3].reshape(n, 12, k), 1, 2)
              @ (B[:, None] @ O[:, :, :3]).reshape(n, 12, 12))  # fmt: skip
        K[:, plane[:, None], _QUAD_OUT] = Kc
        K[:, _QUAD_OUT[:, None], plane] = np.swapaxes(Kc, 1, 2)
    if size > 24:  # the modes, coupled to the bending through B: condensed on the whole
        K = _condense(K, 4)
    return (K, geo.Nint, geo.Mcons) if own else (K, geo.Nint.copy(), geo.Mcons.copy())


def _condense(K: np.ndarray, m: int) -> np.ndarray:
    """Static condensation of the last ``m`` DOFs of K (n, k, k) (the incompatible modes;
    an element whose modes' block is singular, such as one without membrane, keeps K's
    other DOFs as they are)."""
    k = K.shape[1] - m
    Kaa = K[:, k:, k:]
    scale = np.abs(Kaa).max(axis=(1, 2))
    ok = np.abs(np.linalg.det(Kaa)) > (1e-12 * scale) ** m
    Kaa_inv = np.zeros_like(Kaa)
    Kaa_inv[ok] = np.linalg.inv(Kaa[ok])
    return K[:, :k, :k] - K[:, :k, k:] @ Kaa_inv @ K[:, k:, :k]


def _triangle_covariance(xl: np.ndarray) -> np.ndarray:
    """Second central moment of a triangle's area per unit area (n, 2, 2), length^2:
    ``sum_i (p_i - c)(p_i - c)^T / 12`` over the corners p_i, c the centroid."""
    d = xl - xl.mean(axis=1, keepdims=True)
    return np.einsum("eai,eaj->eij", d, d) / 12.0


def _corner_covariance(xl: np.ndarray) -> np.ndarray:
    """Area covariance (n, 2, 2) of the straight-edged triangle (n, 3, 2) or bilinear
    quadrilateral (n, 4, 2) of corner coordinates xl, length^2."""
    if xl.shape[1] == 3:
        return _triangle_covariance(xl)
    detJ = [np.linalg.det(np.einsum("ra,eai->eri", _quad_shape(xi, eta)[1], xl))
            for xi, eta in _GAUSS_2X2]  # fmt: skip
    return _area_covariance(xl, detJ, np.sum(detJ, axis=0))


def _tria3_local(
    xl: np.ndarray,
    A: np.ndarray,
    D: np.ndarray,
    S: np.ndarray | None,
    B: np.ndarray,
    alpha: np.ndarray,
    drilling: bool = True,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Element-frame stiffness (n, 18, 18), int(N_a) (n, 3) and int(N_a N_b) (n, 3, 3).

    ``drilling``: the Allman membrane (CTRIAR); else the constant-strain membrane (CTRIA3),
    ``Rz`` only in the drilling penalty.
    """
    n = xl.shape[0]
    _, dN = _tri_shape(0.0, 0.0)
    J = np.einsum("ra,eai->eri", dN, xl)
    detJ = np.linalg.det(J)
    if np.any(detJ <= 0.0):
        raise ValueError(
            f"CTRIA3 with zero area at element index(es) "
            f"{np.flatnonzero(detJ <= 0.0)[:10].tolist()}"
        )
    area = 0.5 * detJ
    # Constant curvature misses the CQUAD4's energy; unlike MITC4, MITC3 locks without it,
    # so the shear-rigid penalty (MID3 blank) gets it too.
    S = _shear_penalty(D, area) if S is None else S
    S = _with_residual_bending(S, _triangle_covariance(xl), A, B, D)
    C = _constitutive(A, D, S, B)
    Jinv = np.linalg.inv(J)
    dNxy = np.einsum("eir,ra->eia", Jinv, dN)
    Gal = _allman_coefficients(xl, _TRI_EDGES) if drilling else None

    # MITC3 tying: e_r at (1/2, 0), e_s at (0, 1/2), both at (1/2, 1/2).
    t1 = _covariant_shear_rows(*_tri_shape(0.5, 0.0), xl)[:, 0]
    t2 = _covariant_shear_rows(*_tri_shape(0.0, 0.5), xl)[:, 1]
    t3 = _covariant_shear_rows(*_tri_shape(0.5, 0.5), xl)
    c = t2 - t1 - t3[:, 1] + t3[:, 0]

    K = np.zeros((n, 18, 18))
    Nint = np.zeros((n, 3))
    Mcons = np.zeros((n, 3, 3))
    for r, s in _TRI_POINTS:
        N, _ = _tri_shape(r, s)
        dR = _allman_gradients(Jinv, _tri_bubbles(r, s), Gal)
        Bg = np.zeros((n, 8, 18))
        Bg[:, 0:6] = _membrane_bending_rows(dNxy, dR)
        e = np.stack([t1 + s * c, t2 - r * c], axis=1)
        Bg[:, 6:8] = Jinv @ e
        w = _TRI_WEIGHT * detJ
        K += w[:, None, None] * (np.swapaxes(Bg, 1, 2) @ (C @ Bg))
        rd = _drill_row(N, dNxy, dR)
        K += (alpha * w)[:, None, None] * rd[:, :, None] * rd[:, None, :]
        Nint += w[:, None] * N
        Mcons += w[:, None, None] * np.outer(N, N)
    return K, Nint, Mcons


def _offset(X: np.ndarray, d: np.ndarray) -> np.ndarray:
    """``R^T X R`` (element frame) for the rigid links ``u_ref = u + d Ry``, ``v_ref = v - d Rx``.

    ``X`` (n, k, k) acts on reference-plane DOFs, ``d`` (n, nn) link lengths; returns a new
    array acting on the grid DOFs. ``R = I + E`` is applied as column, then row operations.
    """
    if not d.any():  # no offset and no warping: the links are the identity
        return X
    n, k, _ = X.shape
    nn = k // 6
    X = X.copy()
    X6 = X.reshape(n, k, nn, 6)  # columns split per node
    X6[..., 4] += d[:, None, :] * X6[..., 0]
    X6[..., 3] -= d[:, None, :] * X6[..., 1]
    X6 = X.reshape(n, nn, 6, k)  # rows split per node
    X6[:, :, 4] += d[:, :, None] * X6[:, :, 0]
    X6[:, :, 3] -= d[:, :, None] * X6[:, :, 1]
    return X


def _rotate(X: np.ndarray, T: np.ndarray) -> np.ndarray:
    """``L^T X L`` with ``L = blockdiag(T, T, ...)``: element-frame (n, k, k) -> basic."""
    n, k, _ = X.shape
    nb = k // 3
    Y = (X.reshape(n, k, nb, 3) @ T[:, None, :, :]).reshape(n, nb, 3, k)
    return (np.swapaxes(T, 1, 2)[:, None, :, :] @ Y).reshape(n, k, k)


def _to_basic(
    K: np.ndarray,
    Nint: np.ndarray,
    Mcons: np.ndarray,
    m: np.ndarray,
    T: np.ndarray,
    d: np.ndarray,
    coupled_mass: bool,
) -> tuple[np.ndarray, np.ndarray]:
    """Element-frame K and translational mass -> basic-frame K, M through the rigid offsets.

    ``d`` (n, nn) is each node's link length along the element z axis (grid -> reference).
    """
    n, nn = Nint.shape
    k = 6 * nn
    M = np.zeros((n, k, k))
    idx = 6 * np.arange(nn)
    if coupled_mass:
        Mt = m[:, None, None] * Mcons
        for i in range(3):
            M[:, (idx + i)[:, None], (idx + i)[None, :]] = Mt
    else:
        mt = m[:, None] * Nint
        for i in range(3):
            M[:, idx + i, idx + i] = mt

    Kb = _rotate(_offset(K, d), T)
    Kb = 0.5 * (Kb + np.swapaxes(Kb, 1, 2))
    if not coupled_mass and not d.any():
        return Kb, M  # lumped m I per node is the same in every frame
    Mb = _rotate(_offset(M, d), T)
    Mb = 0.5 * (Mb + np.swapaxes(Mb, 1, 2))
    return Kb, Mb


def quad4_matrices(
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
    drilling: bool = False,
    normals: ArrayLike | None = None,
    keep: dict | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness and mass of CQUAD4 elements: MITC4 bending/shear, bilinear + incompatible
    modes membrane (``drilling=True``: CQUADR, Allman (ITW) membrane).

    Formulation, sign conventions, drilling, offsets and mass: see the module docstring.
    ``keep``: a dict in which the elements' shape-only part (:class:`QuadGeometry`) is kept
    by the first call and taken by the next ones: for the same elements (the same ``xyz``
    and ``drilling``) with other section properties.
    """
    T, xl, h, A_, D_, S_, B_, m, zo, alpha = _prepare(
        xyz, 4, A, D, S, B, rho_area, nsm, zoffs, k6rot,
        drill_gamma=DRILL_GAMMA if drilling else 0.0,
    )
    if not drilling:
        alpha = _k6rot_modulus(alpha, D_, 4) + _curvature_tie(T, xl, normals, A_, D_)
    geometry = None if keep is None else keep.get(("quad", drilling))
    if keep is not None and geometry is None:
        geometry = keep[("quad", drilling)] = quad_geometry(xl, drilling)
    K, Nint, Mcons = _quad4_local(xl, A_, D_, S_, B_, alpha, drilling, geometry)
    return _to_basic(K, Nint, Mcons, m, T, zo[:, None] - h, coupled_mass)


def tria3_matrices(
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
    drilling: bool = False,
    normals: ArrayLike | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness and mass of CTRIA3 elements: MITC3 bending/shear, constant-strain membrane
    (``drilling=True``: CTRIAR, Allman membrane).

    Formulation, sign conventions, drilling, offsets and mass: see the module docstring.
    """
    T, xl, h, A_, D_, S_, B_, m, zo, alpha = _prepare(
        xyz, 3, A, D, S, B, rho_area, nsm, zoffs, k6rot,
        drill_gamma=DRILL_GAMMA if drilling else 0.0,
    )
    if not drilling:
        alpha = _k6rot_modulus(alpha, D_, 3) + _curvature_tie(T, xl, normals, A_, D_)
    K, Nint, Mcons = _tria3_local(xl, A_, D_, S_, B_, alpha, drilling)
    return _to_basic(K, Nint, Mcons, m, T, zo[:, None] - h, coupled_mass)


_PARAMS_DOC = """
    Parameters
    ----------
    xyz : ndarray, shape (n, {nn}, 3)
        Node coordinates in basic, NASTRAN order (counter-clockwise about the normal), length.
    A : array_like, shape (n, 3, 3) or (3, 3)
        Membrane stiffness, ``N = A eps`` (force/length), element frame, order xx, yy, xy
        (engineering shear). Isotropic: ``t E / (1 - nu^2) [[1, nu, 0], [nu, 1, 0],
        [0, 0, (1 - nu) / 2]]``.
    D : array_like, shape (n, 3, 3) or (3, 3)
        Bending stiffness, ``M = D kappa`` (force length / length); curvature convention in
        the module docstring. Isotropic: ``t^3 / 12`` times the matrix above.
    S : array_like, shape (n, 2, 2) or (2, 2), or None
        Transverse shear stiffness, ``Q = S gamma`` (force/length), order xz, yz; isotropic
        ``5/6 t G I``. None: shear-rigid (Kirchhoff) behaviour by the penalty
        ``1e4 trace(D) / area I``.
    B : array_like, shape (n, 3, 3) or (3, 3), optional
        Membrane-bending coupling, ``N = A eps + B kappa``, ``M = B^T eps + D kappa``
        (force); None is zero.
    rho_area : array_like, shape (n,) or scalar
        Structural mass per unit area (``rho t``), mass/length^2.
    nsm : array_like, shape (n,) or scalar
        Non-structural mass per unit area, mass/length^2.
    zoffs : array_like, shape (n,) or scalar
        Offset of the reference plane from the grid plane along the element z axis
        (NASTRAN ZOFFS), length. Rigid links, applied to K and M.
    k6rot : array_like, shape (n,) or scalar
        NASTRAN PARAM K6ROT: the drilling penalty (see the module docstring). CQUADR /
        CTRIAR: adds ``k6rot * 1e-6 * A[2, 2]`` to the modulus ``A[2, 2]``; CQUAD4 / CTRIA3:
        one corner's ``Rz`` alone costs ``1e-6 k6rot A[2, 2] area`` (triangle: ``2 area``),
        nothing without bending stiffness.
    coupled_mass : bool
        False: lumped translational mass (row sums of the consistent mass). True: consistent
        translational mass. No rotary inertia either way.
    drilling : bool
        False (CQUAD4, CTRIA3): a membrane without ``Rz``, which enters only the drilling
        penalty. True (CQUADR, CTRIAR): the Allman membrane with drilling rotations.
    normals : array_like, shape (n, {nn}, 3), optional
        CQUAD4 / CTRIA3: the grid normals at the corners in basic (:func:`grid_normals`,
        NaN where a grid has none), which tie ``Rz`` where the shell is curved; None: none.

    Returns
    -------
    K : ndarray, shape (n, {k}, {k})
        Stiffness in basic, DOFs ``[T1 T2 T3 R1 R2 R3]`` node by node (force/length,
        force, force*length blocks). Symmetric.
    M : ndarray, shape (n, {k}, {k})
        Mass in basic, same DOF order (mass, mass*length, mass*length^2 blocks). Symmetric.
    """

quad4_matrices.__doc__ = (quad4_matrices.__doc__ or "") + _PARAMS_DOC.format(nn=4, k=24)
tria3_matrices.__doc__ = (tria3_matrices.__doc__ or "") + _PARAMS_DOC.format(nn=3, k=18)
