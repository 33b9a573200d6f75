"""Constraints by exact elimination: u_g = T u_a.

From the model's :class:`~femcal.model.constraints.Constraints`: multipoint equations and
rigid elements (RBE2, RBAR, RBE3) make dependent DOF; single-point constraints fix DOF;
AUTOSPC fixes the DOF where the stiffness is singular at a grid point. Chains of rigid
elements (a dependent DOF that another element uses as independent) are resolved.
Everything is in the nodes' displacement (CD) frames, so T applies directly to the assembled
K_gg and M_gg.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from ..elements.line import skew
from ..errors import ModelError
from ..model.constraints import Interpolation, RigidBar
from ..model.model import Model

#: NASTRAN PARAM EPZERO: a grid point's 3 x 3 stiffness block is singular in a direction
#: whose eigenvalue is below this fraction of the block's largest.
EPZERO = 1e-8


@dataclass(frozen=True)
class Reduction:
    """The map from the independent set to the g-set.

    Attributes
    ----------
    T : (n_g, n_a) CSR, u_g = T u_a.
    a_dofs : (n_a,) g-set index of each a-set DOF.
    spc : (n_s,) g-set DOF fixed by SPC/PS (before AUTOSPC).
    autospc : (n_auto,) g-set DOF fixed by AUTOSPC or because they have neither stiffness
        nor mass.
    dependent : (n_m,) g-set DOF made dependent by MPC and rigid elements.
    """

    T: sp.csr_matrix
    a_dofs: np.ndarray
    spc: np.ndarray
    autospc: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    dependent: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))

    def reduce(self, A: sp.spmatrix) -> sp.csr_matrix:
        """T^T A T (a plain selection of rows and columns when nothing is dependent)."""
        if len(self.dependent) == 0:
            return select_symmetric(A, self.a_dofs)
        T = self.T
        return (T.T @ (A @ T)).tocsr()

    def expand(self, ua: np.ndarray) -> np.ndarray:
        """g-set vectors from a-set vectors; ua (n_a,) or (n_a, k)."""
        return self.T @ ua


def select_symmetric(A: sp.spmatrix, keep: np.ndarray) -> sp.csr_matrix:
    """A[keep][:, keep] as CSR without the zeros A stores, filtering and renumbering A's
    entries in place of scipy's two fancy-indexing passes.

    A : (n, n) sparse; keep : (m,) row/column indices. For increasing ``keep`` (the a-set's
    order) the work is one gather of the column numbers (32-bit when they fit), boolean masks
    and one compression of the entries; other orders take scipy's path. Stored zeros (an
    assembly's node blocks keep a flat shell's zero membrane-bending coupling, about half of
    its K) would only be carried through every product and factorisation after it.
    """
    A = sp.csr_matrix(A)
    keep = np.asarray(keep, dtype=np.int64)
    if len(keep) > 1 and (np.diff(keep) <= 0).any():
        out = A[keep][:, keep].tocsr()
        out.eliminate_zeros()
        return out
    n, m = A.shape[0], len(keep)
    itype = np.int32 if max(n, A.nnz) < np.iinfo(np.int32).max else np.int64
    new = np.full(n, -1, itype)
    new[keep] = np.arange(m, dtype=itype)
    counts = np.diff(A.indptr)
    cols = new[A.indices]  # the new column numbers, -1 for columns that go
    take = cols >= 0
    take &= np.repeat(new >= 0, counts)  # and the rows that go
    take &= A.data != 0
    # entries taken per row (a sentinel after the last: every row's start is a valid index)
    kept = np.add.reduceat(np.append(take, False), A.indptr[:-1], dtype=itype)
    kept[counts == 0] = 0  # (reduceat gives an empty row its next entry)
    kept = kept[keep]
    indptr = np.zeros(m + 1, itype)
    np.cumsum(kept, out=indptr[1:])
    out = sp.csr_matrix((A.data[take], cols[take], indptr), shape=(m, m))
    out.has_sorted_indices = A.has_sorted_indices  # a monotone renumbering keeps the order
    return out


class _Equations:
    """Dependent-DOF equations u_d = sum c_j u_j, with who made each DOF dependent."""

    def __init__(self, label: Callable[[int], str]) -> None:
        self.label = label  # names a g-set DOF in errors
        self.rows: list[np.ndarray] = []
        self.cols: list[np.ndarray] = []
        self.vals: list[np.ndarray] = []
        self.owner: dict[int, str] = {}
        self.errors: list[str] = []

    def add(self, dep: int, cols: np.ndarray, vals: np.ndarray, who: str) -> None:
        if dep in self.owner:
            self.errors.append(
                f"{self.label(dep)} is made dependent twice, by {self.owner[dep]} and by {who}"
            )
            return
        self.owner[dep] = who
        keep = np.abs(vals) > 0
        self.rows.append(np.full(int(keep.sum()), dep))
        self.cols.append(cols[keep])
        self.vals.append(vals[keep])


def _node_dofs(model: Model, node: int) -> np.ndarray:
    """g-set DOF of a node (index): 6 at a GRID, 1 at a scalar point."""
    return model.dof_start[node] + np.arange(6 if model.is_grid[node] else 1)


def _rigid_map(model: Model, im: int, i_n: int) -> np.ndarray:
    """6 x 6 matrix G with u_m = G u_n (both in their displacement frames) for a rigid link
    from node n to node m (indices)."""
    r = model.xyz[im] - model.xyz[i_n]
    B = np.eye(6)
    B[0:3, 3:6] = -skew(r)  # u_m = u_n + theta_n x r = u_n - r x theta_n
    Fm, Fn = model.cd_frames[im], model.cd_frames[i_n]
    L = np.zeros((6, 6))
    L[0:3, 0:3] = L[3:6, 3:6] = Fm.T
    R = np.zeros((6, 6))
    R[0:3, 0:3] = R[3:6, 3:6] = Fn
    return L @ B @ R


def _rigid_equations(model: Model, eq: _Equations) -> None:
    c = model.constraints
    for link in c.rigid_links:
        cols = _node_dofs(model, link.independent)
        for gm in link.dependent:
            G = _rigid_map(model, gm, link.independent)
            dofs = _node_dofs(model, gm)
            for k in link.components:
                eq.add(int(dofs[k]), cols, G[k], f"RBE2 {link.id}")
    for bar in c.rigid_bars:
        _rbar(model, eq, bar)
    for interp in c.interpolations:
        _rbe3(model, eq, interp)


def _rbar(model: Model, eq: _Equations, bar: RigidBar) -> None:
    """RBAR: the 12 DOF of GA and GB obey the 6 rigid-bar relations; CNA/CNB independent."""
    ind, dep = list(bar.independent), list(bar.dependent)
    if len(ind) != 6 or set(ind) & set(dep):
        eq.errors.append(f"RBAR {bar.id}: CNA and CNB must give exactly 6 independent "
                         f"components (found {len(ind)}), distinct from CMA/CMB")  # fmt: skip
        return
    ga, gb = bar.nodes
    # Rigid relations in the displacement frames: E @ [u_a; u_b] = 0, E = [G_ba, -I] (6 x 12)
    E = np.hstack([_rigid_map(model, gb, ga), -np.eye(6)])
    Ei, Ed = E[:, ind], E[:, dep]
    if np.linalg.matrix_rank(E[:, [k for k in range(12) if k not in ind]]) < 6:
        eq.errors.append(f"RBAR {bar.id}: the independent components do not fix the bar's motion")
        return
    X, *_ = np.linalg.lstsq(Ed, -Ei, rcond=None)  # u_dep = X u_ind
    dofs = np.concatenate([_node_dofs(model, ga), _node_dofs(model, gb)])
    for row, k in enumerate(dep):
        eq.add(int(dofs[k]), dofs[ind], X[row], f"RBAR {bar.id}")


def _rbe3(model: Model, eq: _Equations, r: Interpolation) -> None:
    """RBE3: the reference grid moves as the weighted least-squares rigid fit of the
    independent grids' motion (translations and rotations weighted by WT; rotations use a
    length scale as NASTRAN does)."""
    if r.other_dependent:
        eq.errors.append(f"RBE3 {r.id}: UM (other dependent DOF) is not supported yet")
        return
    xr = model.xyz[r.reference]
    pts, wts, comps = [], [], []
    for g in r.groups:
        for node in g.nodes:
            pts.append(node)
            wts.append(g.weight)
            comps.append(g.components)
    xs = model.xyz[pts]
    # characteristic length: mean distance of the independent grids from their centroid
    Lc = float(np.mean(np.linalg.norm(xs - xs.mean(axis=0), axis=1))) or 1.0
    rows_G, rows_W, cols = [], [], []
    for node, w, cs, x in zip(pts, wts, comps, xs, strict=True):
        Fi = model.cd_frames[node]
        # motion of point i (basic) from the reference's rigid motion (basic): [I, -skew(r)]
        B = np.zeros((6, 6))
        B[0:3, 0:3] = np.eye(3)
        B[0:3, 3:6] = -skew(x - xr)
        B[3:6, 3:6] = np.eye(3)
        F6 = np.zeros((6, 6))
        F6[0:3, 0:3] = F6[3:6, 3:6] = Fi.T
        Bi = F6 @ B  # independent components (their CD frame) from reference motion (basic)
        dofs = _node_dofs(model, node)
        for c in cs:
            rows_G.append(Bi[c])
            rows_W.append(w * (1.0 if c < 3 else Lc**2))
            cols.append(int(dofs[c]))
    G = np.array(rows_G)
    W = np.array(rows_W)
    N = G.T @ (W[:, None] * G)
    if np.linalg.matrix_rank(N) < 6:
        eq.errors.append(f"RBE3 {r.id}: the independent grids and components do not define "
                         "all six rigid motions of the reference grid")  # fmt: skip
        return
    X = np.linalg.solve(N, G.T * W)  # reference motion (basic) = X @ u_independent
    Fr = model.cd_frames[r.reference]
    F6 = np.zeros((6, 6))
    F6[0:3, 0:3] = F6[3:6, 3:6] = Fr.T
    Xr = F6 @ X
    ref_dofs = _node_dofs(model, r.reference)
    cols_a = np.array(cols)
    for c in r.reference_components:
        eq.add(int(ref_dofs[c]), cols_a, Xr[c], f"RBE3 {r.id}")


def _mpc_equations(model: Model, eq: _Equations) -> None:
    for e in model.constraints.equations:
        grid = model.is_grid[e.nodes]
        comps = e.components
        # QRG MPC: Cj one of 1-6 at a grid point; blank, 0 or 1 at a scalar point
        bad = (grid & (comps < 1)) | (~grid & (comps > 1))
        if bad.any():
            eq.errors.append(f"MPC set {e.set_id}: GRID/SPOINT "
                             f"{model.node_ids[e.nodes[bad]].tolist()} need a component 1-6 "
                             "at a GRID, and 0, 1 or blank at an SPOINT")  # fmt: skip
            continue
        dofs = model.dofs(e.nodes, comps)
        a = e.coefficients
        if a[0] == 0.0:
            eq.errors.append(f"MPC set {e.set_id}: the first coefficient (dependent DOF) is zero")
            continue
        eq.add(int(dofs[0]), dofs[1:], -a[1:] / a[0], f"MPC set {e.set_id}")


def build_reduction(model: Model) -> Reduction:
    """The model's constraints -> :class:`Reduction` (AUTOSPC not yet applied).

    Raises
    ------
    ModelError
        A DOF made dependent twice or both dependent and constrained (naming both sources),
        a cycle of rigid elements, or an ill-posed rigid element.
    """
    if model.constraints.problems:
        raise ModelError("; ".join(model.constraints.problems))
    eq = _Equations(model.dof_label)
    _rigid_equations(model, eq)
    _mpc_equations(model, eq)
    n = model.n_dof
    spc = model.constraints.fixed
    for d in spc.tolist():
        if d in eq.owner:
            eq.errors.append(
                f"{model.dof_label(d)} is both constrained (SPC/PS) and dependent ({eq.owner[d]})"
            )
    if eq.errors:
        raise ModelError("constraints:\n  " + "\n  ".join(eq.errors[:50]))
    dep = np.array(sorted(eq.owner), dtype=np.int64)
    is_dep = np.zeros(n, bool)
    is_dep[dep] = True
    is_spc = np.zeros(n, bool)
    is_spc[spc] = True
    a_dofs = np.flatnonzero(~is_dep & ~is_spc)
    col_of = np.full(n, -1)
    col_of[a_dofs] = np.arange(len(a_dofs))
    if len(dep):
        G = sp.csr_matrix(
            (np.concatenate(eq.vals), (np.concatenate(eq.rows), np.concatenate(eq.cols))),
            shape=(n, n),
        )
        X = _resolve_chains(G, is_dep, eq)
    else:
        X = sp.csr_matrix((n, n))
    # T: identity on the a-set, the resolved equations on dependent DOF (SPC'd columns drop out)
    ident = sp.csr_matrix(
        (np.ones(len(a_dofs)), (a_dofs, np.arange(len(a_dofs)))), shape=(n, len(a_dofs))
    )
    Xc = X.tocoo()
    keep = col_of[Xc.col] >= 0
    Td = sp.csr_matrix(
        (Xc.data[keep], (Xc.row[keep], col_of[Xc.col[keep]])), shape=(n, len(a_dofs))
    )
    return Reduction((ident + Td).tocsr(), a_dofs, spc, dependent=dep)


def _resolve_chains(G: sp.csr_matrix, is_dep: np.ndarray, eq: _Equations):
    """Rows of G for dependent DOF in terms of independent DOF only (chains substituted)."""
    n = G.shape[0]
    D = sp.diags(is_dep.astype(float))
    I_ = sp.diags((~is_dep).astype(float))
    Gi = (G @ I_).tocsr()
    Gd = (G @ D).tocsr()
    X = Gi.copy()
    P = Gd.copy()
    for _ in range(n + 1):
        if P.nnz == 0:
            return X.tocsr()
        X = (X + P @ Gi).tocsr()
        P = (P @ Gd).tocsr()
        P.eliminate_zeros()
    rows = np.unique(P.tocoo().row)[:10]
    who = sorted({eq.owner.get(int(r), "?") for r in rows})
    raise ModelError(f"rigid elements or MPCs depend on each other in a cycle: {', '.join(who)}")


def autospc(
    model: Model, red: Reduction, K_aa: sp.csr_matrix, M_aa: sp.csr_matrix, *, enabled: bool
) -> Reduction:
    """Fix singular DOF of the a-set (NASTRAN AUTOSPC) and DOF with neither stiffness nor mass.

    With ``enabled``, each grid's 3 x 3 translational and rotational blocks of K_aa are
    checked: a direction whose eigenvalue is below EPZERO times the block's largest is
    singular, and the a-set component most aligned with it is fixed. DOF whose rows of K_aa and
    M_aa are entirely zero are always removed (they carry nothing).
    """
    na = len(red.a_dofs)
    fix = _zero_rows(K_aa) & _zero_rows(M_aa)
    if enabled and na:
        fix |= _singular_blocks(model, red, K_aa)
    if not fix.any():
        return red
    keep = np.flatnonzero(~fix)
    T = red.T[:, keep].tocsr()
    return Reduction(T, red.a_dofs[keep], red.spc, red.a_dofs[fix], red.dependent)


def _zero_rows(A: sp.spmatrix) -> np.ndarray:
    """(n,) whether each row of A holds no nonzero value (the sum of its magnitudes is 0).
    Where A is canonical (no duplicates, which could cancel) and stores no zeros (the a-set's
    selection drops them), that is a row that stores nothing, found without a pass over the
    values."""
    A = sp.csr_matrix(A)
    if A.has_canonical_format and np.count_nonzero(A.data[: A.nnz]) == A.nnz:
        return np.diff(A.indptr) == 0
    return abs(A).sum(axis=1).A1 == 0


def _singular_blocks(model: Model, red: Reduction, K_aa: sp.csr_matrix) -> np.ndarray:
    na = len(red.a_dofs)
    fix = np.zeros(na, bool)
    node, comp = model.dof_owner(red.a_dofs)
    grid = model.is_grid[node]
    comp = comp - 1  # 0-based within the grid (only grids are checked)
    for group in (0, 1):
        sel = np.flatnonzero(grid & (comp // 3 == group))
        if not len(sel):
            continue
        # blocks: (node, 3) -> a-set index or -1
        nodes, inv = np.unique(node[sel], return_inverse=True)
        idx = np.full((len(nodes), 3), -1)
        idx[inv, comp[sel] % 3] = sel
        present = idx >= 0
        blocks = np.zeros((len(nodes), 3, 3))
        both = present[:, :, None] & present[:, None, :]  # (node, i, j): both components in a
        b, i, j = np.nonzero(both)
        # one look-up of every block entry (scipy's element indexing, called once)
        blocks[b, i, j] = np.asarray(K_aa[idx[b, i], idx[b, j]]).ravel()
        scale = np.abs(blocks).max(axis=(1, 2))
        # missing components: make them stiff so they never look singular
        for i in range(3):
            blocks[~present[:, i], i, i] = np.where(scale > 0, scale, 1.0)[~present[:, i]]
        w, v = np.linalg.eigh(blocks)
        top = np.maximum(w[:, -1:], 1e-300)
        singular = w < EPZERO * top
        zero_block = scale == 0
        for b in np.flatnonzero(singular.any(axis=1) | zero_block):
            if zero_block[b]:
                fix[idx[b][present[b]]] = True
                continue
            taken: set[int] = set()
            for k in np.flatnonzero(singular[b]):
                vec = np.abs(v[b, :, k]) * present[b]
                for c in np.argsort(-vec):
                    if present[b, c] and c not in taken:
                        taken.add(int(c))
                        fix[idx[b, c]] = True
                        break
    return fix
