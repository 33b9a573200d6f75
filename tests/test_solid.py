"""Solid element kernels (CHEXA, CPENTA, CTETRA, CPYRAM): element properties, patch tests and
cantilever beams against beam theory.

References for the expected values:
* rigid-body modes, symmetry, definiteness, constant-strain patch test: Zienkiewicz, Taylor &
  Zhu, The Finite Element Method: Its Basis and Fundamentals (the patch-test chapter); Irons &
  Razzaque 1972 for the patch test itself;
* tetrahedron integrals ``int l1^a l2^b l3^c l4^d dV = 6 V a! b! c! d! / (a+b+c+d+3)!``
  (ibid., appendix; Eisenberg & Malvern, IJNME 1973), which give the consistent masses of
  TETRA4 ``rho V (1 + delta_ab) / 20`` and of TETRA10 (corner diagonal ``6/420 rho V``,
  midside diagonal ``32/420 rho V``) and the HRZ masses of TETRA10 (``rho V / 36`` at corners,
  ``4 rho V / 27`` at midsides; Hinton, Rock & Zienkiewicz 1976);
* Timoshenko beam: tip deflection ``P L^3 / (3 E I) + P L / (k G A)`` of a cantilever with a tip
  shear load, ``k = 10 (1 + nu) / (12 + 11 nu)`` for a rectangle (Cowper, J. Appl. Mech. 1966),
  i.e. 5/6 for nu = 0.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from femcal.elements.solid import isotropic_C, solid_matrices, solid_volume

KINDS = ["HEXA8", "HEXA20", "PENTA6", "PENTA15", "TETRA4", "TETRA10", "PYRAM5", "PYRAM13"]
FAMILY = {
    "HEXA8": "hex", "HEXA20": "hex", "PENTA6": "wedge", "PENTA15": "wedge",
    "TETRA4": "tet", "TETRA10": "tet", "PYRAM5": "pyr", "PYRAM13": "pyr",
}  # fmt: skip
LINEAR = {"hex": "HEXA8", "wedge": "PENTA6", "tet": "TETRA4", "pyr": "PYRAM5"}
QUADRATIC = {"HEXA8": "HEXA20", "PENTA6": "PENTA15", "TETRA4": "TETRA10", "PYRAM5": "PYRAM13"}

# Reference corners, in NASTRAN order (MSC Nastran QRG: CHEXA, CPENTA, CTETRA, CPYRAM): first
# face counterclockwise seen from the second face / the apex, G5 above G1 (CHEXA), G4 above G1
# (CPENTA).
SQUARE = [(-1, -1), (1, -1), (1, 1), (-1, 1)]
CORNERS = {
    "hex": [(r, s, t) for t in (-1, 1) for r, s in SQUARE],
    "wedge": [(r, s, t) for t in (-1, 1) for r, s in ((0, 0), (1, 0), (0, 1))],
    "tet": [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)],
    "pyr": [(r, s, 0) for r, s in SQUARE] + [(0, 0, 1)],
}


def edges(text: str) -> list[tuple[int, int]]:
    """'1-2 2-3' (grid numbers as in the QRG) -> [(0, 1), (1, 2)]."""
    return [(int(a) - 1, int(b) - 1) for a, b in (e.split("-") for e in text.split())]


# Midside nodes in NASTRAN order, as the edges they sit on.
EDGES = {
    "hex": edges("1-2 2-3 3-4 4-1 1-5 2-6 3-7 4-8 5-6 6-7 7-8 8-5"),
    "wedge": edges("1-2 2-3 3-1 1-4 2-5 3-6 4-5 5-6 6-4"),
    "tet": edges("1-2 2-3 3-1 1-4 2-4 3-4"),
    "pyr": edges("1-2 2-3 3-4 4-1 1-5 2-5 3-5 4-5"),
}
REF_VOLUME = {"hex": 8.0, "wedge": 1.0, "tet": 1.0 / 6.0, "pyr": 4.0 / 3.0}


def n_corners(kind: str) -> int:
    return len(CORNERS[FAMILY[kind]])


def ref_nodes(kind: str) -> np.ndarray:
    """Reference-element nodes (a, 3), midside nodes at the edge midpoints."""
    c = np.array(CORNERS[FAMILY[kind]], dtype=float)
    if kind in QUADRATIC.values():
        c = np.vstack([c, [(c[i] + c[j]) / 2 for i, j in EDGES[FAMILY[kind]]]])
    return c


def mirror_perm(kind: str) -> np.ndarray:
    """Node permutation that swaps the first two natural coordinates: the same element numbered
    with the opposite orientation (e.g. CHEXA 1 4 3 2 5 8 7 6)."""
    nodes = ref_nodes(kind)
    mirrored = nodes[:, [1, 0, 2]]
    d = np.linalg.norm(mirrored[:, None, :] - nodes[None, :, :], axis=2)
    perm = d.argmin(axis=1)
    assert np.allclose(d.min(axis=1), 0) and len(set(perm.tolist())) == len(perm)
    return perm


def rotation(rng: np.random.Generator) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def affine(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A random well-conditioned orientation-preserving affine map x -> A x + b."""
    A = (
        rotation(rng)
        @ np.diag(rng.uniform(0.7, 1.4, 3))
        @ (np.eye(3) + 0.15 * np.triu(rng.uniform(-1, 1, (3, 3)), 1))
    )
    return A, rng.uniform(-5, 5, 3)


def distorted(kind: str, rng: np.random.Generator, amount: float = 0.08) -> np.ndarray:
    """One mildly distorted element (1, a, 3): corners moved by up to ``amount``, midside nodes
    by a third of it (curved edges)."""
    x = ref_nodes(kind)
    scale = np.where(np.arange(len(x)) < n_corners(kind), amount, amount / 3)[:, None]
    x = x + scale * rng.uniform(-1, 1, x.shape)
    A, b = affine(rng)
    return (x @ A.T + b)[None]


def rigid_modes(xyz: np.ndarray) -> np.ndarray:
    """(3a, 6): three translations and three rotations about the centroid."""
    x = xyz - xyz.mean(axis=0)
    a = len(x)
    R = np.zeros((a, 3, 6))
    for i in range(3):
        R[:, i, i] = 1.0
        e = np.zeros(3)
        e[i] = 1.0
        R[:, :, 3 + i] = np.cross(e, x)
    return R.reshape(3 * a, 6)


def random_spd_c(rng: np.random.Generator) -> np.ndarray:
    """An anisotropic constitutive matrix: isotropic plus a random SPD part."""
    X = rng.normal(size=(6, 6))
    return isotropic_C(np.array([200.0]), np.array([0.3]))[0] + 20.0 * X @ X.T / 6


# --------------------------------------------------------------------------------------------
# Small meshes and an assembler
# --------------------------------------------------------------------------------------------

HEX_OFFSETS = [(i, j, k) for k in (0, 1) for i, j in ((0, 0), (1, 0), (1, 1), (0, 1))]


class Mesh:
    """Nodes (N, 3) and the elements of one kind (E, a)."""

    def __init__(self, kind: str, xyz: np.ndarray, conn: np.ndarray) -> None:
        self.kind, self.xyz, self.conn = kind, xyz, conn


def box_grid(n: tuple[int, int, int], size: tuple[float, float, float]):
    """Grid nodes of a box and the 8 corner ids of every cell, shaped (cells, 2, 2, 2)."""
    axes = [np.linspace(0.0, s, k + 1) for k, s in zip(n, size, strict=True)]
    xyz = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    ids = np.arange(len(xyz)).reshape(n[0] + 1, n[1] + 1, n[2] + 1)
    cell = np.empty((n[0], n[1], n[2], 2, 2, 2), dtype=int)
    for di, dj, dk in itertools.product(range(2), repeat=3):
        cell[..., di, dj, dk] = ids[di : di + n[0], dj : dj + n[1], dk : dk + n[2]]
    return xyz, cell.reshape(-1, 2, 2, 2)


def orient(kind: str, xyz: np.ndarray, conn: np.ndarray) -> np.ndarray:
    """Renumber linear elements whose first face is clockwise seen from the opposite node(s)."""
    x = xyz[conn]
    fam = FAMILY[kind]
    if fam in ("tet", "wedge"):
        vol = np.einsum(
            "ei,ei->e", np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), x[:, 3] - x[:, 0]
        )
    elif fam == "pyr":
        n = np.cross(x[:, 2] - x[:, 0], x[:, 3] - x[:, 1])
        vol = np.einsum("ei,ei->e", n, x[:, 4] - x[:, :4].mean(axis=1))
    else:
        return conn
    return np.where((vol < 0)[:, None], conn[:, mirror_perm(kind)], conn)


def split(kind: str, xyz: np.ndarray, cells: np.ndarray, axis: int = 0) -> Mesh:
    """Linear elements of ``kind`` filling the hexahedral cells (conforming across cells).

    PENTA6: 2 wedges per cell, triangles in the plane normal to ``axis``, extruded along it.
    TETRA4: Kuhn's 6 tetrahedra around the cell diagonal. PYRAM5: 6 pyramids, one per cell
    face, with the apex at a new node at the cell centre.
    """
    c = cells
    if kind == "HEXA8":
        conn = np.stack([c[:, i, j, k] for i, j, k in HEX_OFFSETS], 1)
    elif kind == "PENTA6":
        a1, a2 = (axis + 1) % 3, (axis + 2) % 3

        def at(u: int, v: int, w: int) -> np.ndarray:
            off = [0, 0, 0]
            off[a1], off[a2], off[axis] = u, v, w
            return c[:, off[0], off[1], off[2]]

        tris = [((0, 0), (1, 0), (1, 1)), ((0, 0), (1, 1), (0, 1))]
        conn = np.concatenate(
            [np.stack([at(u, v, w) for w in (0, 1) for u, v in t], 1) for t in tris]
        )
    elif kind == "TETRA4":
        tets = []
        for p in itertools.permutations(range(3)):
            path = [np.zeros(3, dtype=int)]
            for ax in p:
                path.append(path[-1] + np.eye(3, dtype=int)[ax])
            tets.append(np.stack([c[:, i, j, k] for i, j, k in path], 1))
        conn = np.concatenate(tets)
    elif kind == "PYRAM5":
        centre = np.arange(len(c)) + len(xyz)
        xyz = np.vstack([xyz, xyz[c.reshape(len(c), -1)].mean(axis=1)])
        pyrs = []
        for ax in range(3):
            a1, a2 = (ax + 1) % 3, (ax + 2) % 3
            for w in (0, 1):
                base = []
                for u, v in ((0, 0), (1, 0), (1, 1), (0, 1)):
                    off = [0, 0, 0]
                    off[a1], off[a2], off[ax] = u, v, w
                    base.append(c[:, off[0], off[1], off[2]])
                pyrs.append(np.stack([*base, centre], 1))
        conn = np.concatenate(pyrs)
    else:
        raise ValueError(kind)
    return Mesh(kind, xyz, orient(kind, xyz, conn))


def quadratic(mesh: Mesh) -> Mesh:
    """Add a node at the midpoint of every edge (shared between elements)."""
    kind = QUADRATIC[mesh.kind]
    ends = EDGES[FAMILY[kind]]
    pairs = np.stack([np.sort(mesh.conn[:, [i, j]], axis=1) for i, j in ends], 1)  # (E, m, 2)
    uniq, inv = np.unique(pairs.reshape(-1, 2), axis=0, return_inverse=True)
    mid = len(mesh.xyz) + inv.reshape(len(mesh.conn), len(ends))
    xyz = np.vstack([mesh.xyz, mesh.xyz[uniq].mean(axis=1)])
    return Mesh(kind, xyz, np.hstack([mesh.conn, mid]))


def assemble(mesh: Mesh, C: np.ndarray, rho: float = 1.0):
    """Global sparse K and M (lumped) of a mesh; DOF 3 n + i."""
    n = len(mesh.conn)
    Ke, Me = solid_matrices(
        mesh.kind, mesh.xyz[mesh.conn], np.broadcast_to(C, (n, 6, 6)), np.full(n, rho)
    )
    d = (3 * mesh.conn[:, :, None] + np.arange(3)).reshape(n, -1)
    rows = np.broadcast_to(d[:, :, None], Ke.shape).ravel()
    cols = np.broadcast_to(d[:, None, :], Ke.shape).ravel()
    nd = 3 * len(mesh.xyz)
    K = sp.coo_matrix((Ke.ravel(), (rows, cols)), shape=(nd, nd)).tocsr()
    M = sp.coo_matrix((Me.ravel(), (rows, cols)), shape=(nd, nd)).tocsr()
    return K, M


def solve(K: sp.spmatrix, f: np.ndarray) -> np.ndarray:
    """Sparse LU with a symmetric fill-reducing ordering."""
    return spla.splu(K.tocsc(), permc_spec="MMD_AT_PLUS_A").solve(f)


# --------------------------------------------------------------------------------------------
# Single elements
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("kind", KINDS)
def test_symmetric_psd_and_rigid_body_modes(kind: str) -> None:
    rng = np.random.default_rng(KINDS.index(kind))
    xyz = distorted(kind, rng)
    C = random_spd_c(rng)[None]
    K, M = solid_matrices(kind, xyz, C, np.array([2.5]))
    _, Mc = solid_matrices(kind, xyz, C, np.array([2.5]), coupled_mass=True)
    K, M, Mc = K[0], M[0], Mc[0]
    nd = 3 * len(ref_nodes(kind))
    assert K.shape == M.shape == Mc.shape == (nd, nd)
    assert np.allclose(K, K.T, rtol=0, atol=1e-13 * np.abs(K).max())
    assert np.allclose(M, M.T, rtol=0, atol=1e-15 * np.abs(M).max())
    assert np.allclose(Mc, Mc.T, rtol=0, atol=1e-15)
    lam = np.linalg.eigvalsh(K)
    # Exactly six zero eigenvalues, the rest clearly positive.
    assert np.all(np.abs(lam[:6]) < 1e-10 * lam[-1]), lam[:8] / lam[-1]
    assert lam[6] > 1e-5 * lam[-1], lam[:8] / lam[-1]
    # The null space is the rigid-body motions.
    R = rigid_modes(xyz[0])
    assert np.linalg.norm(K @ R) < 1e-10 * np.linalg.norm(K) * np.linalg.norm(R)
    # Masses: lumped diagonal and positive, consistent positive definite.
    assert np.count_nonzero(M - np.diag(np.diag(M))) == 0 and np.all(np.diag(M) > 0)
    assert np.linalg.eigvalsh(Mc)[0] > 0


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("coupled", [False, True])
def test_total_mass_is_rho_v(kind: str, coupled: bool) -> None:
    """A batch of affine images of the reference element: V = |det A| V_ref exactly."""
    rng = np.random.default_rng(10 + KINDS.index(kind))
    maps = [affine(rng) for _ in range(3)]
    xyz = np.stack([ref_nodes(kind) @ A.T + b for A, b in maps])
    xyz[1] = xyz[1][mirror_perm(kind)]  # the other orientation
    V = np.array([abs(np.linalg.det(A)) for A, _ in maps]) * REF_VOLUME[FAMILY[kind]]
    rho = np.array([1.0, 7.85e-9, 2.7])
    C = isotropic_C(np.full(3, 70e3), np.full(3, 0.33))
    _, M = solid_matrices(kind, xyz, C, rho, coupled_mass=coupled)
    np.testing.assert_allclose(solid_volume(kind, xyz), V, rtol=1e-12)
    for i in range(3):
        np.testing.assert_allclose(M[:, i::3, i::3].sum(axis=(1, 2)), rho * V, rtol=1e-12)
    assert np.all(M[:, 0::3, 1::3] == 0)  # no coupling between directions


def frustum(kind: str, a: float, b: float, h: float) -> np.ndarray:
    """Frustum of a pyramid, straight edges: square (hex) or triangular (wedge) section scaled
    from a at the bottom to b at the top over the height h."""
    fam = FAMILY[kind]
    c = np.array(CORNERS[fam], dtype=float)
    if fam == "hex":
        x = np.column_stack([c[:, :2] * np.where(c[:, 2:] < 0, a, b), (c[:, 2] + 1) * h / 2])
    elif fam == "wedge":
        cen = np.array([1 / 3, 1 / 3])
        s = np.where(c[:, 2:] < 0, a, b)
        x = np.column_stack([cen + (c[:, :2] - cen) * s, (c[:, 2] + 1) * h / 2])
    else:
        raise ValueError(kind)
    if kind in QUADRATIC.values():
        x = np.vstack([x, [(x[i] + x[j]) / 2 for i, j in EDGES[fam]]])
    return x


@pytest.mark.parametrize("kind", KINDS)
def test_volume_of_non_affine_elements(kind: str) -> None:
    """Straight-edged elements that are not affine images of the reference element."""
    fam = FAMILY[kind]
    if fam in ("hex", "wedge"):
        # Frustum V = h/3 (A1 + A2 + sqrt(A1 A2)): square sides 2a, 2b; triangle areas a^2/2...
        a, b, h = 1.5, 0.6, 2.0
        x = frustum(kind, a, b, h)
        area = (lambda s: 4 * s**2) if fam == "hex" else (lambda s: s**2 / 2)
        A1, A2 = area(a), area(b)
        V = h / 3 * (A1 + A2 + math.sqrt(A1 * A2))
    elif fam == "pyr":
        # Pyramid on a planar trapezoid base, skewed apex: V = base area * height / 3.
        x = np.array([[0, 0, 0], [4, 0, 0], [3, 2, 0], [1, 2, 0], [5, 3, 1.5]], dtype=float)
        V = (4 + 2) / 2 * 2 * 1.5 / 3
        if kind == "PYRAM13":
            x = np.vstack([x, [(x[i] + x[j]) / 2 for i, j in EDGES[fam]]])
    else:
        x = np.array([[0, 0, 0], [3, 0.5, 0], [1, 2, 0.2], [0.5, 0.7, 2.5]])
        V = abs(np.linalg.det(x[1:] - x[0])) / 6
        if kind == "TETRA10":
            x = np.vstack([x, [(x[i] + x[j]) / 2 for i, j in EDGES[fam]]])
    A, b = affine(np.random.default_rng(3))
    xyz = (x @ A.T + b)[None]
    V *= np.linalg.det(A)
    np.testing.assert_allclose(solid_volume(kind, xyz), [V], rtol=1e-12)
    for coupled in (False, True):
        _, M = solid_matrices(
            kind, xyz, isotropic_C(1.0, 0.2), np.array([3.0]), coupled_mass=coupled
        )
        np.testing.assert_allclose(M[0, 2::3, 2::3].sum(), 3.0 * V, rtol=1e-12)


@pytest.mark.parametrize("kind", KINDS)
def test_reversed_node_order_gives_the_same_matrices(kind: str) -> None:
    rng = np.random.default_rng(20 + KINDS.index(kind))
    xyz = np.concatenate([distorted(kind, rng) for _ in range(2)])
    perm = mirror_perm(kind)
    rev = xyz[:, perm]  # same elements, first face now clockwise seen from the second
    C = np.stack([random_spd_c(rng) for _ in range(2)])
    rho = np.array([1.0, 2.0])
    p = (3 * perm[:, None] + np.arange(3)).ravel()
    for coupled in (False, True):
        K, M = solid_matrices(kind, xyz, C, rho, coupled_mass=coupled)
        Kr, Mr = solid_matrices(kind, rev, C, rho, coupled_mass=coupled)
        np.testing.assert_allclose(Kr, K[:, p][:, :, p], rtol=0, atol=1e-11 * np.abs(K).max())
        np.testing.assert_allclose(Mr, M[:, p][:, :, p], rtol=0, atol=1e-14 * np.abs(M).max())
    np.testing.assert_allclose(solid_volume(kind, rev), solid_volume(kind, xyz), rtol=1e-13)


def bad_element(kind: str) -> np.ndarray:
    """An element whose Jacobian changes sign inside it (or vanishes, TETRA4)."""
    x = ref_nodes(kind).copy()
    if kind == "TETRA4":  # constant Jacobian: it cannot change sign; a flat one must fail
        x[3] = [0.3, 0.3, 0.0]
    elif kind in LINEAR.values():  # linear: corner 1 pushed through the centre
        c = x.mean(axis=0)
        x[0] = c + 0.8 * (c - x[0])
    else:  # quadratic: midside node of edge 1-2 closer to G1 than the quarter point
        nc = n_corners(kind)
        x[nc] = x[0] + 0.15 * (x[1] - x[0])
    return x


@pytest.mark.parametrize("kind", KINDS)
def test_sign_changing_jacobian_raises(kind: str) -> None:
    good = ref_nodes(kind)
    xyz = np.stack([good, good[mirror_perm(kind)], bad_element(kind), good + 1.0])
    C = isotropic_C(np.full(4, 1.0), np.full(4, 0.3))
    with pytest.raises(ValueError, match=r"positions \[2\]"):
        solid_matrices(kind, xyz, C, np.ones(4))
    with pytest.raises(ValueError, match=r"positions \[2\]"):
        solid_volume(kind, xyz)
    solid_matrices(kind, xyz[[0, 1, 3]], C[:3], np.ones(3))  # the others are fine


VOIGT = np.array([[0, 3, 5], [3, 1, 4], [5, 4, 2]])  # xx yy zz xy yz zx


def rotate_voigt(C: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Rotate a Voigt constitutive matrix (engineering shear) through its 4th-order tensor."""
    T = C[VOIGT[:, :, None, None], VOIGT[None, None, :, :]]
    T = np.einsum("ai,bk,cj,dl,ikjl->abcd", R, R, R, R, T)
    out = np.empty((6, 6))
    for i, k, j, l in itertools.product(range(3), repeat=4):
        out[VOIGT[i, k], VOIGT[j, l]] = T[i, k, j, l]
    return out


@pytest.mark.parametrize("kind", KINDS)
def test_objectivity_with_anisotropic_material(kind: str) -> None:
    """Rotating the element and its material together rotates K: K' = R K R^T (checks the
    Voigt order xx, yy, zz, xy, yz, zx and the engineering shear strains of C)."""
    rng = np.random.default_rng(40 + KINDS.index(kind))
    xyz = distorted(kind, rng)
    C = random_spd_c(rng)
    R = rotation(rng)
    K, _ = solid_matrices(kind, xyz, C[None], np.ones(1))
    Kr, _ = solid_matrices(kind, xyz @ R.T, rotate_voigt(C, R)[None], np.ones(1))
    Rb = np.kron(np.eye(len(ref_nodes(kind))), R)
    np.testing.assert_allclose(Kr[0], Rb @ K[0] @ Rb.T, rtol=0, atol=1e-11 * np.abs(K).max())


def test_empty_batch() -> None:
    K, M = solid_matrices("HEXA20", np.zeros((0, 20, 3)), np.zeros((0, 6, 6)), np.zeros(0))
    assert K.shape == M.shape == (0, 60, 60)
    assert solid_volume("TETRA4", np.zeros((0, 4, 3))).shape == (0,)


def test_bad_arguments() -> None:
    with pytest.raises(ValueError, match="unknown"):
        solid_volume("HEXA27", np.zeros((1, 27, 3)))
    with pytest.raises(ValueError, match="shape"):
        solid_volume("HEXA8", np.zeros((1, 20, 3)))


def test_isotropic_c_inverse_is_the_compliance() -> None:
    E, nu = np.array([210e3, 70e3]), np.array([0.3, 0.0])
    C = isotropic_C(E, nu)
    for e, n, c in zip(E, nu, C, strict=True):
        S = np.zeros((6, 6))
        S[:3, :3] = -n / e
        S[np.arange(3), np.arange(3)] = 1 / e
        S[np.arange(3, 6), np.arange(3, 6)] = 2 * (1 + n) / e  # 1/G, engineering shear
        np.testing.assert_allclose(np.linalg.inv(c), S, rtol=1e-12, atol=1e-20)


# --------------------------------------------------------------------------------------------
# Mass matrices against closed forms
# --------------------------------------------------------------------------------------------


def test_tetra_consistent_and_lumped_masses() -> None:
    rng = np.random.default_rng(5)
    A, b = affine(rng)
    x4 = ref_nodes("TETRA4") @ A.T + b
    x10 = ref_nodes("TETRA10") @ A.T + b
    V = abs(np.linalg.det(A)) / 6
    rho = 2.0
    C = isotropic_C(1.0, 0.25)
    # TETRA4: rho V (1 + delta_ab) / 20 per direction; lumped rho V / 4.
    _, Mc = solid_matrices("TETRA4", x4[None], C, np.array([rho]), coupled_mass=True)
    np.testing.assert_allclose(Mc[0, 0::3, 0::3], rho * V * (np.ones(4) + np.eye(4)) / 20)
    _, Ml = solid_matrices("TETRA4", x4[None], C, np.array([rho]))
    np.testing.assert_allclose(np.diag(Ml[0]), rho * V / 4)
    # TETRA10: corner row sum -rho V / 20, midside row sum rho V / 5, diagonal 6/420 and 32/420.
    _, Mc = solid_matrices("TETRA10", x10[None], C, np.array([rho]), coupled_mass=True)
    m = Mc[0, 0::3, 0::3] / (rho * V)
    np.testing.assert_allclose(m.sum(axis=1), [-1 / 20] * 4 + [1 / 5] * 6, atol=1e-13)
    np.testing.assert_allclose(np.diag(m), [6 / 420] * 4 + [32 / 420] * 6, atol=1e-13)
    # corner-corner 1/420, midside-midside 16/420 (sharing a corner) or 8/420 (opposite).
    assert math.isclose(m[0, 1], 1 / 420) and math.isclose(m[4, 6], 16 / 420)
    assert math.isclose(m[4, 9], 8 / 420)  # edges 1-2 and 3-4
    # HRZ: rho V / 36 at corners, 4 rho V / 27 at midsides.
    _, Ml = solid_matrices("TETRA10", x10[None], C, np.array([rho]))
    np.testing.assert_allclose(
        np.diag(Ml[0])[0::3] / (rho * V), [1 / 36] * 4 + [4 / 27] * 6, rtol=1e-12
    )


def test_hexa8_box_consistent_mass() -> None:
    """Trilinear box: the tensor product of the 1-D consistent masses rho L / 6 [[2, 1], [1, 2]],
    M_ab = rho V / 216 * prod over directions (2 if a, b on the same side else 1)."""
    xyz = (ref_nodes("HEXA8") + 1) / 2 * [2.0, 1.0, 0.5]
    _, Mc = solid_matrices(
        "HEXA8", xyz[None], isotropic_C(1.0, 0.3), np.array([3.0]), coupled_mass=True
    )
    c = np.array(CORNERS["hex"])
    expect = 3.0 * 1.0 / 216 * np.prod(np.where(c[:, None, :] == c[None, :, :], 2, 1), axis=2)
    np.testing.assert_allclose(Mc[0, 1::3, 1::3], expect, rtol=1e-13)
    _, Ml = solid_matrices("HEXA8", xyz[None], isotropic_C(1.0, 0.3), np.array([3.0]))
    np.testing.assert_allclose(np.diag(Ml[0]), 3.0 / 8, rtol=1e-13)


# --------------------------------------------------------------------------------------------
# Constant-strain patch test
# --------------------------------------------------------------------------------------------


def patch_mesh(kind: str, rng: np.random.Generator, curved: bool) -> tuple[Mesh, np.ndarray]:
    """3x3x3 distorted cells (interior grid nodes moved by up to 0.25 h) split into ``kind``;
    returns the mesh and the boundary-node mask (nodes on the faces of the box)."""
    xyz, cells = box_grid((3, 3, 3), (3.0, 3.0, 3.0))
    inner = np.all((xyz > 0.5) & (xyz < 2.5), axis=1)
    xyz[inner] += rng.uniform(-0.25, 0.25, (inner.sum(), 3))
    mesh = split(LINEAR[FAMILY[kind]], xyz, cells, axis=2)
    if kind in QUADRATIC.values():
        mesh = quadratic(mesh)
    boundary = np.any(np.isclose(mesh.xyz, 0.0) | np.isclose(mesh.xyz, 3.0), axis=1)
    if curved:  # move interior midside nodes too: curved edges
        mid = np.zeros(len(mesh.xyz), dtype=bool)
        mid[mesh.conn[:, n_corners(kind) :]] = True
        move = mid & ~boundary
        mesh.xyz[move] += rng.uniform(-0.06, 0.06, (move.sum(), 3))
    return mesh, boundary


PATCH_CASES = [(k, False) for k in KINDS] + [("HEXA20", True), ("PENTA15", True)]


@pytest.mark.parametrize(("kind", "curved"), PATCH_CASES)
def test_constant_strain_patch(kind: str, curved: bool) -> None:
    rng = np.random.default_rng(30 + KINDS.index(kind))
    mesh, boundary = patch_mesh(kind, rng, curved)
    A, b = affine(rng)
    mesh.xyz = mesh.xyz @ A.T + b  # affine map of the whole patch: the field stays linear
    C = random_spd_c(rng)
    K, _ = assemble(mesh, C)
    G = 1e-3 * rng.normal(size=(3, 3))  # u = u0 + G x: constant strain
    u = (rng.normal(size=3) + mesh.xyz @ G.T).ravel()
    fixed = np.repeat(boundary, 3)
    free = ~fixed
    assert free.sum() > 0
    Kff = K[free][:, free]
    u_free = solve(Kff, -K[free][:, fixed] @ u[fixed])
    err = np.linalg.norm(u_free - u[free]) / np.linalg.norm(u[free])
    assert err < 1e-8, err
    # Strain energy of the pure strain part (no rigid motion, whose K u would only add round-off):
    # u^T K u = eps^T C eps V with V the volume of the patch.
    S = (G + G.T) / 2
    us = ((mesh.xyz - mesh.xyz.mean(axis=0)) @ S).ravel()
    eps = np.array([S[0, 0], S[1, 1], S[2, 2], 2 * S[0, 1], 2 * S[1, 2], 2 * S[2, 0]])
    V = 27.0 * np.linalg.det(A)
    np.testing.assert_allclose(us @ (K @ us), eps @ C @ eps * V, rtol=1e-10)


# --------------------------------------------------------------------------------------------
# Cantilever beams against Timoshenko beam theory
# --------------------------------------------------------------------------------------------

L, H, E, NU, P = 10.0, 1.0, 1000.0, 0.0, 1.0
FACE_WEIGHTS = {  # consistent nodal loads of a uniform traction on an affine face / area
    3: ([1 / 3] * 3, []),
    4: ([1 / 4] * 4, []),
    6: ([0.0] * 3, [1 / 3] * 3),
    8: ([-1 / 12] * 4, [1 / 3] * 4),
}
TIP_FACE_SIZES = {
    "HEXA8": {4},
    "HEXA20": {8},
    "PENTA6": {3},
    "PENTA15": {6},
    "TETRA10": {6},
    "PYRAM13": {8},
}


def timoshenko_tip() -> float:
    I = H**4 / 12
    G = E / (2 * (1 + NU))
    k = 10 * (1 + NU) / (12 + 11 * NU)  # Cowper, rectangle: 5/6 for nu = 0
    return P * L**3 / (3 * E * I) + P * L / (k * G * H * H)


def tip_loads(mesh: Mesh) -> np.ndarray:
    """Consistent nodal forces (N,) of a uniform shear traction P / H^2 on the face x = L."""
    f = np.zeros(len(mesh.xyz))
    on = np.isclose(mesh.xyz[mesh.conn, 0], L)  # (E, a)
    nc = n_corners(mesh.kind)
    for e in np.flatnonzero(np.isin(on.sum(axis=1), list(TIP_FACE_SIZES[mesh.kind]))):
        local = np.flatnonzero(on[e])
        corners = mesh.xyz[mesh.conn[e, local[local < nc]]][:, 1:]
        ang = np.arctan2(*(corners - corners.mean(axis=0)).T[::-1])
        p = corners[np.argsort(ang)]
        area = 0.5 * abs(
            np.dot(p[:, 0], np.roll(p[:, 1], -1)) - np.dot(p[:, 1], np.roll(p[:, 0], -1))
        )
        wc, wm = FACE_WEIGHTS[len(local)]
        w = np.array(wc + wm)
        f[mesh.conn[e, local]] += w * area * P / H**2
    assert math.isclose(f.sum(), P)
    return f


def cantilever_tip(mesh: Mesh) -> float:
    """Tip deflection (along y) of the centroid node for a tip load P along y; root clamped."""
    K, _ = assemble(mesh, isotropic_C(E, NU)[0])
    F = np.zeros(3 * len(mesh.xyz))
    F[1::3] = tip_loads(mesh)
    free = np.repeat(~np.isclose(mesh.xyz[:, 0], 0.0), 3)
    u = np.zeros_like(F)
    u[free] = solve(K[free][:, free], F[free])
    tip = np.flatnonzero(np.all(np.isclose(mesh.xyz, [L, H / 2, H / 2]), axis=1))
    assert len(tip) == 1
    return float(u[3 * tip[0] + 1])


def beam_mesh(kind: str, n: tuple[int, int, int]) -> Mesh:
    xyz, cells = box_grid(n, (L, H, H))
    mesh = split(kind if kind in LINEAR.values() else LINEAR[FAMILY[kind]], xyz, cells, axis=0)
    return quadratic(mesh) if kind in QUADRATIC.values() else mesh


@pytest.mark.parametrize(
    ("kind", "tol"),
    [
        ("HEXA8", 0.01),  # 20 x 4 x 4 incompatible-mode bricks
        ("PENTA6", 0.01),  # the same cells split into 2 wedges along the beam axis
        ("TETRA10", 0.02),  # the same cells split into 6 TETRA10
        ("HEXA20", 0.01),
        ("PENTA15", 0.01),
        ("PYRAM13", 0.01),  # 6 pyramids per cell around a centre node
    ],
)
def test_cantilever_tip_deflection(kind: str, tol: float) -> None:
    """Cantilever 10 x 1 x 1, nu = 0, all root nodes clamped, tip shear load (consistent
    uniform traction): tip deflection P L^3/(3EI) + P L/(k G A), k = 5/6 (Timoshenko/Cowper)."""
    delta = cantilever_tip(beam_mesh(kind, (20, 4, 4)))
    ref = timoshenko_tip()
    assert abs(delta / ref - 1) < tol, (delta, ref, delta / ref - 1)


def test_strongly_curved_tetra10_stay_positive_semi_definite():
    # TETRA10's 5-point stiffness rule (NASTRAN's) has a negative centre weight: on strongly
    # curved elements it can give an indefinite K. Those are integrated with a positive rule,
    # so every element keeps exactly its six rigid-body zero modes and no negative eigenvalue.
    from femcal.elements import solid

    rng = np.random.default_rng(7)
    corner = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    edges = solid._EDGES["tet"]
    xyz = []
    while len(xyz) < 150:
        c = corner + 0.05 * rng.standard_normal((4, 3))
        x = np.vstack([c, [(c[i] + c[j]) / 2 for i, j in edges]])
        for k, (i, j) in enumerate(edges):  # curve each edge: midside node off the chord
            e = (c[j] - c[i]) / np.linalg.norm(c[j] - c[i])
            r = rng.standard_normal(3)
            r -= (r @ e) * e
            x[4 + k] += 0.2 * np.linalg.norm(c[j] - c[i]) * rng.uniform() * r / np.linalg.norm(r)
        try:  # keep the ones whose Jacobian keeps its sign
            solid_volume("TETRA10", x[None])
        except ValueError:
            continue
        xyz.append(x)
    xyz = np.array(xyz)
    C = isotropic_C(np.array([1.0]), np.array([0.3]))[0]
    K, _ = solid_matrices("TETRA10", xyz, C, np.ones(len(xyz)))
    ev = np.linalg.eigvalsh(K)
    tol = 1e-10 * ev[:, -1:]
    assert (ev[:, 0] > -tol[:, 0]).all()
    assert ((np.abs(ev) < tol).sum(axis=1) == 6).all()
    # the 5-point rule alone is indefinite on some of them, and equal to K on the others
    el, xp = solid._prepare("TETRA10", xyz)
    K5 = solid._stiffness(el, xp, np.broadcast_to(C, (len(xyz), 6, 6)))
    ev5 = np.linalg.eigvalsh(K5)
    indefinite = ev5[:, 0] < -1e-10 * ev5[:, -1]
    assert 0 < indefinite.sum() < len(xyz)
    assert np.allclose(K[~indefinite], K5[~indefinite], rtol=0, atol=1e-12 * np.abs(K).max())
