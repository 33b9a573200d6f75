"""Constraints by exact elimination: u_g = T u_a.

Sources, in NASTRAN's terms: multipoint constraints (MPC/MPCADD selected in case control)
and rigid elements (RBE2, RBAR, RBE3) make dependent DOF; single-point constraints (SPC,
SPC1, SPCADD selected in case control, GRID and GRDSET PS) fix DOF; AUTOSPC fixes the DOF
where the stiffness is singular at a grid point. Chains of rigid elements (a dependent DOF
that another element uses as independent) are resolved. Everything is in the nodes'
displacement (CD) frames, so T applies directly to the assembled K_gg and M_gg.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from ..deck.deck import Deck
from ..deck.fields import INT_BLANK
from ..elements.line import skew
from ..errors import ModelError
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
    """A[keep][:, keep] as CSR, filtering and renumbering A's entries in place of scipy's two
    fancy-indexing passes.

    A : (n, n) sparse; keep : (m,) row/column indices. For increasing ``keep`` (the a-set's
    order) the work is one gather of the column numbers (32-bit when they fit), boolean masks
    and one compression of the entries; other orders take scipy's path.
    """
    A = sp.csr_matrix(A)
    keep = np.asarray(keep, dtype=np.int64)
    if len(keep) > 1 and (np.diff(keep) <= 0).any():
        return A[keep][:, keep].tocsr()
    n, m = A.shape[0], len(keep)
    itype = np.int32 if max(n, A.nnz) < np.iinfo(np.int32).max else np.int64
    new = np.full(n, -1, itype)
    new[keep] = np.arange(m, dtype=itype)
    counts = np.diff(A.indptr)
    cols = new[A.indices]  # the new column numbers, -1 for columns that go
    take = cols >= 0
    take &= np.repeat(new >= 0, counts)  # and the rows that go
    dropped = np.searchsorted(A.indptr, np.flatnonzero(~take), side="right") - 1
    kept = (counts - np.bincount(dropped, minlength=n))[keep]
    indptr = np.zeros(m + 1, itype)
    np.cumsum(kept, out=indptr[1:])
    out = sp.csr_matrix((A.data[take], cols[take], indptr), shape=(m, m))
    out.has_sorted_indices = A.has_sorted_indices  # a monotone renumbering keeps the order
    return out


class _Equations:
    """Dependent-DOF equations u_d = sum c_j u_j, with who made each DOF dependent."""

    def __init__(self) -> None:
        self.rows: list[np.ndarray] = []
        self.cols: list[np.ndarray] = []
        self.vals: list[np.ndarray] = []
        self.owner: dict[int, str] = {}
        self.errors: list[str] = []

    def add(self, dep: int, cols: np.ndarray, vals: np.ndarray, who: str) -> None:
        if dep in self.owner:
            self.errors.append(
                f"DOF {dep} is made dependent twice, by {self.owner[dep]} and by {who}"
            )
            return
        self.owner[dep] = who
        keep = np.abs(vals) > 0
        self.rows.append(np.full(int(keep.sum()), dep))
        self.cols.append(cols[keep])
        self.vals.append(vals[keep])


def _dof_label(model: Model, dof: int) -> str:
    node = int(np.searchsorted(model.dof_start, dof, side="right") - 1)
    comp = dof - int(model.dof_start[node]) + (1 if model.is_grid[node] else 0)
    return f"{'GRID' if model.is_grid[node] else 'SPOINT'} {model.node_ids[node]} C{comp}"


def _node_dofs(model: Model, gid: int) -> np.ndarray:
    i = int(model.node_index(gid)[0])
    return model.dof_start[i] + np.arange(6 if model.is_grid[i] else 1)


def _rigid_map(model: Model, gm: int, gn: int) -> np.ndarray:
    """6 x 6 matrix G with u_m = G u_n (both in their displacement frames) for a rigid link."""
    im, i_n = int(model.node_index(gm)[0]), int(model.node_index(gn)[0])
    r = model.xyz[im] - model.xyz[i_n]
    B = np.eye(6)
    B[0:3, 3:6] = -skew(r)  # u_m = u_n + theta_n x r = u_n - r x theta_n
    Fm, Fn = model.cd_frames[im], model.cd_frames[i_n]
    L = np.zeros((6, 6))
    L[0:3, 0:3] = L[3:6, 3:6] = Fm.T
    R = np.zeros((6, 6))
    R[0:3, 0:3] = R[3:6, 3:6] = Fn
    return L @ B @ R


def _comps(code: int) -> list[int]:
    return [] if code in (INT_BLANK, 0) else [int(c) - 1 for c in str(code)]


def _rigid_equations(deck: Deck, model: Model, eq: _Equations) -> None:
    for r in deck.records_of("RBE2"):
        cols = _node_dofs(model, r.gn)
        for gm in r.gm:
            G = _rigid_map(model, gm, r.gn)
            dofs = _node_dofs(model, gm)
            for c in _comps(r.cm):
                eq.add(int(dofs[c]), cols, G[c], f"RBE2 {r.eid}")
    t = deck.tables.get("RBAR")
    if t is not None:
        c = t.columns
        for i in range(len(t)):
            _rbar(model, eq, {k: int(v[i]) if k != "alpha" else v[i] for k, v in c.items()})
    for r in deck.records_of("RBE3"):
        _rbe3(model, eq, r)


def _rbar(model: Model, eq: _Equations, c: dict) -> None:
    """RBAR: the 12 DOF of GA and GB obey the 6 rigid-bar relations; CNA/CNB independent."""
    eid, ga, gb = c["eid"], c["ga"], c["gb"]
    ind = [k for k in _comps(c["cna"])] + [6 + k for k in _comps(c["cnb"])]
    dep = [k for k in _comps(c["cma"])] + [6 + k for k in _comps(c["cmb"])]
    if not dep:  # blank CMA and CMB: every DOF not independent is dependent
        dep = [k for k in range(12) if k not in ind]
    if len(ind) != 6 or set(ind) & set(dep):
        eq.errors.append(f"RBAR {eid}: CNA and CNB must give exactly 6 independent components "
                         f"(found {len(ind)}), distinct from CMA/CMB")  # fmt: skip
        return
    # Rigid relations in the displacement frames: E @ [u_a; u_b] = 0, E = [G_ba, -I] (6 x 12)
    E = np.hstack([_rigid_map(model, gb, ga), -np.eye(6)])
    Ei, Ed = E[:, ind], E[:, dep]
    if np.linalg.matrix_rank(E[:, [k for k in range(12) if k not in ind]]) < 6:
        eq.errors.append(f"RBAR {eid}: the independent components do not fix the bar's motion")
        return
    X, *_ = np.linalg.lstsq(Ed, -Ei, rcond=None)  # u_dep = X u_ind
    dofs = np.concatenate([_node_dofs(model, ga), _node_dofs(model, gb)])
    for row, k in enumerate(dep):
        eq.add(int(dofs[k]), dofs[ind], X[row], f"RBAR {eid}")


def _rbe3(model: Model, eq: _Equations, r) -> None:
    """RBE3: the reference grid moves as the weighted least-squares rigid fit of the
    independent grids' motion (translations and rotations weighted by WT; rotations use a
    length scale as NASTRAN does)."""
    if r.um:
        eq.errors.append(f"RBE3 {r.eid}: UM (other dependent DOF) is not supported yet")
        return
    iref = int(model.node_index(r.refgrid)[0])
    xr = model.xyz[iref]
    pts, wts, comps = [], [], []
    for g in r.groups:
        for gid in g.grids:
            pts.append(gid)
            wts.append(g.weight)
            comps.append(_comps(g.components))
    xs = model.xyz[model.node_index(pts)]
    # characteristic length: mean distance of the independent grids from their centroid
    Lc = float(np.mean(np.linalg.norm(xs - xs.mean(axis=0), axis=1))) or 1.0
    rows_G, rows_W, cols = [], [], []
    for gid, w, cs, x in zip(pts, wts, comps, xs, strict=True):
        i = int(model.node_index(gid)[0])
        Fi = model.cd_frames[i]
        # motion of point i (basic) from the reference's rigid motion (basic): [I, -skew(r)]
        B = np.zeros((6, 6))
        B[0:3, 0:3] = np.eye(3)
        B[0:3, 3:6] = -skew(x - xr)
        B[3:6, 3:6] = np.eye(3)
        F6 = np.zeros((6, 6))
        F6[0:3, 0:3] = F6[3:6, 3:6] = Fi.T
        Bi = F6 @ B  # independent components (their CD frame) from reference motion (basic)
        dofs = _node_dofs(model, gid)
        for c in cs:
            rows_G.append(Bi[c])
            rows_W.append(w * (1.0 if c < 3 else Lc**2))
            cols.append(int(dofs[c]))
    G = np.array(rows_G)
    W = np.array(rows_W)
    N = G.T @ (W[:, None] * G)
    if np.linalg.matrix_rank(N) < 6:
        eq.errors.append(f"RBE3 {r.eid}: the independent grids and components do not define "
                         "all six rigid motions of the reference grid")  # fmt: skip
        return
    X = np.linalg.solve(N, G.T * W)  # reference motion (basic) = X @ u_independent
    Fr = model.cd_frames[iref]
    F6 = np.zeros((6, 6))
    F6[0:3, 0:3] = F6[3:6, 3:6] = Fr.T
    Xr = F6 @ X
    ref_dofs = _node_dofs(model, r.refgrid)
    cols_a = np.array(cols)
    for c in _comps(r.refc):
        eq.add(int(ref_dofs[c]), cols_a, Xr[c], f"RBE3 {r.eid}")


def _selected_sets(deck: Deck, key: str, add_card: str) -> set[int]:
    value = deck.case.value(key)
    if value is None:
        return set()
    try:
        sid = int(value.split()[0])
    except ValueError as e:
        raise ModelError(f"case control {key} = {value}: expected a set id") from e
    sets = {sid}
    grow = True
    while grow:
        grow = False
        for r in deck.records_of(add_card):
            if r.sid in sets and not set(r.sets) <= sets:
                sets |= set(r.sets)
                grow = True
    return sets


def _mpc_equations(deck: Deck, model: Model, eq: _Equations) -> None:
    sets = _selected_sets(deck, "MPC", "MPCADD")
    for r in deck.records_of("MPC"):
        if r.sid not in sets:
            continue
        gids = np.array([t[0] for t in r.terms])
        comps = np.array([t[1] for t in r.terms])
        grid = model.is_grid[model.node_index(gids)]
        bad = (grid & (comps < 1)) | (~grid & (comps > 0))
        if bad.any():
            eq.errors.append(f"MPC set {r.sid}: GRID {gids[bad].tolist()} need a component 1-6 "
                             "(SPOINTs take 0 or blank)")  # fmt: skip
            continue
        dofs = model.dof_index(gids, comps)
        a = np.array([t[2] for t in r.terms])
        if a[0] == 0.0:
            eq.errors.append(f"MPC set {r.sid}: the first coefficient (dependent DOF) is zero")
            continue
        eq.add(int(dofs[0]), dofs[1:], -a[1:] / a[0], f"MPC set {r.sid}")


def spc_dofs(deck: Deck, model: Model) -> np.ndarray:
    """g-set DOF fixed by GRID/GRDSET PS and the SPC set selected in case control."""
    fixed: set[int] = set()
    for i in np.flatnonzero(model.ps):
        fixed.update(int(model.dof_start[i]) + c for c in _comps(int(model.ps[i])))
    sets = _selected_sets(deck, "SPC", "SPCADD")

    def fix(g: int, code: int) -> None:
        i = int(model.node_index(g)[0])
        if not model.is_grid[i]:
            fixed.add(int(model.dof_start[i]))
        else:
            fixed.update(int(model.dof_start[i]) + c for c in _comps(code))

    for r in deck.records_of("SPC1"):
        if r.sid in sets:
            for g in r.ids:
                fix(g, r.components)
    t = deck.tables.get("SPC")
    if t is not None:
        c = t.columns
        for s, g, comp in zip(c["sid"], c["g"], c["c"], strict=True):
            if s in sets:
                fix(int(g), int(comp))
    return np.array(sorted(fixed), dtype=np.int64)


def build_reduction(deck: Deck, model: Model) -> Reduction:
    """Dependent equations and SPCs of a deck -> :class:`Reduction` (AUTOSPC not yet applied).

    Raises
    ------
    ModelError
        A DOF made dependent twice or both dependent and constrained (naming both sources),
        a cycle of rigid elements, or an ill-posed rigid element.
    """
    eq = _Equations()
    _rigid_equations(deck, model, eq)
    _mpc_equations(deck, model, eq)
    n = model.n_dof
    spc = spc_dofs(deck, model)
    for d in spc.tolist():
        if d in eq.owner:
            eq.errors.append(
                f"{_dof_label(model, d)} is both constrained (SPC/PS) and dependent ({eq.owner[d]})"
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
        X = _resolve_chains(G, is_dep, model, eq)
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


def _resolve_chains(G: sp.csr_matrix, is_dep: np.ndarray, model: Model, eq: _Equations):
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
    Kd = abs(K_aa).sum(axis=1).A1
    Md = abs(M_aa).sum(axis=1).A1
    fix = (Kd == 0) & (Md == 0)
    if enabled and na:
        fix |= _singular_blocks(model, red, K_aa)
    if not fix.any():
        return red
    keep = np.flatnonzero(~fix)
    T = red.T[:, keep].tocsr()
    return Reduction(T, red.a_dofs[keep], red.spc, red.a_dofs[fix], red.dependent)


def _singular_blocks(model: Model, red: Reduction, K_aa: sp.csr_matrix) -> np.ndarray:
    na = len(red.a_dofs)
    fix = np.zeros(na, bool)
    node = np.searchsorted(model.dof_start, red.a_dofs, side="right") - 1
    comp = red.a_dofs - model.dof_start[node]
    grid = model.is_grid[node]
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
