"""Model -> stiffness and mass matrices of the g-set (K_gg, M_gg).

This module knows what NASTRAN's properties and materials mean (PSHELL, PBAR, MAT1 ...) and
turns them into the explicit inputs of the element kernels in :mod:`femcal.elements`; the
kernels know no cards. One kernel call per element type; one sparse scatter per matrix.

PARAMs honoured: COUPMASS (> 0: coupled mass where the element has one), WTMASS (scales the
whole mass matrix), K6ROT (shell drilling stiffness).
"""

from __future__ import annotations

import os
from collections import deque
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from ..elements.line import bar_matrices, bush_matrices, line_frame, rod_matrices
from ..elements.mass import conm1_matrix, conm2_matrix
from ..errors import ModelError
from ..markers import INT_BLANK
from ..model.coords import displacement_frames
from ..model.model import ElementBlock, Model
from ..properties.materials import MaterialTables, mat1_moduli
from ..properties.sections import section_properties, shear_factors
from .pattern import Assembler, Pattern

#: Elements per kernel call. It bounds the kernels' temporaries to about 10 MB each, small
#: enough for the C library to reuse freed memory rather than map fresh pages per call (which
#: costs more than the arithmetic), large enough to amortise NumPy's per-call overhead.
KERNEL_CHUNK = 2048


@dataclass(frozen=True)
class Matrices:
    """Assembled g-set matrices.

    Attributes
    ----------
    K, M : (n_dof, n_dof) CSR stiffness and mass in the nodes' displacement frames.
    element_mass : structural mass by element type (before WTMASS), for weight summaries.
    """

    K: sp.csr_matrix
    M: sp.csr_matrix
    element_mass: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class Options:
    """Assembly options; None means "as the model's PARAMs say" (``Model.params``)."""

    coupled_mass: bool | None = None
    wtmass: float | None = None
    k6rot: float | None = None
    #: Threads computing element matrices (NumPy releases the GIL in its array work);
    #: None: the cores this process may use, at most 4. The sums are the same for any count.
    threads: int | None = None


def _usable_cores() -> int:
    """Cores this process may run on (its affinity where the OS tells it)."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def assemble(model: Model, options: Options | None = None) -> Matrices:
    """Stiffness and mass matrices of the whole model (g-set, before constraints).

    Raises
    ------
    ModelError
        For element or property data the kernels cannot use (zero length, a missing section
        type, ...), naming the element ids.
    """
    opt = options or Options()
    par = model.params
    coupled = opt.coupled_mass if opt.coupled_mass is not None else par.coupled_mass
    wtmass = opt.wtmass if opt.wtmass is not None else par.wtmass
    k6rot = opt.k6rot if opt.k6rot is not None else par.k6rot
    ndof = np.where(model.is_grid, 6, 1)
    pairs = [_pairs(b) for b in model.elements.values()]
    threads = opt.threads if opt.threads is not None else min(4, _usable_cores())
    # the pattern's column indices are only needed at the end: built while the kernels run
    pattern = Pattern.build(model.dof_start, ndof, pairs, background=threads > 1)
    asm = Assembler(pattern, model.cd_frames, n_matrices=2)  # K and M
    ctx = _Context(model, coupled, k6rot, max(1, threads))
    masses: dict[str, float] = {}
    for etype, block in model.elements.items():
        handler = _HANDLERS.get(etype)
        if handler is None:
            raise ModelError(f"{etype} stiffness and mass are not implemented yet", block.ids[:20])
        masses[etype] = handler(ctx, block, asm)
    M = _compact(asm.matrix(1))  # a lumped mass is (block) diagonal: keep only what it holds
    if wtmass != 1.0:
        M = M * wtmass
    return Matrices(asm.matrix(0), M, masses)


def _compact(A: sp.csr_matrix) -> sp.csr_matrix:
    """A copy of A without its stored zeros, built from the nonzeros only (A shares its
    index arrays with another matrix, so it is not compacted in place)."""
    keep = np.flatnonzero(A.data)  # far faster than a running count over every entry
    nonzeros_before = np.searchsorted(keep, A.indptr)  # per row boundary
    out = sp.csr_matrix(A.shape)
    out.data, out.indices = A.data[keep], A.indices[keep]
    out.indptr = nonzeros_before.astype(A.indptr.dtype)
    return out


def _pairs(block: ElementBlock) -> np.ndarray:
    k = block.nodes.shape[1]
    if k == 1:
        return np.zeros((0, 2), np.int64)
    a, b = np.triu_indices(k, 1)
    return np.stack([block.nodes[:, a], block.nodes[:, b]], axis=-1).reshape(-1, 2)


# ----------------------------------------------------------------------------- lookups


class _Lookup:
    """Rows of a property or material table by id."""

    def __init__(self, ids: np.ndarray):
        self.order = np.argsort(ids, kind="stable")
        self.sorted = ids[self.order]

    def rows(self, query: np.ndarray) -> np.ndarray:
        pos = np.searchsorted(self.sorted, query)
        pos = np.minimum(pos, len(self.sorted) - 1)
        found = self.sorted[pos] == query
        return np.where(found, self.order[pos], -1)


class _Context:
    def __init__(self, model: Model, coupled: bool, k6rot: float, threads: int = 1):
        self.model = model
        self.coupled = coupled
        self.k6rot = k6rot
        self.threads = threads
        self.materials = MaterialTables(model.materials)

    def run_chunks(
        self,
        asm: Assembler,
        parts: Sequence[np.ndarray],
        compute: Callable[[np.ndarray], tuple[np.ndarray, int, np.ndarray, np.ndarray]],
    ) -> None:
        """Element matrices of each part (element indices) by ``compute(part) -> (nodes, dof
        per node, K, M)``, added to ``asm``.

        The kernels and the assembler's preparation run on ``threads`` worker threads, at most
        one part ahead of each; the scatter runs here, in part order, so the sums are the same
        whatever the thread count, and the first failing part (in order) raises.
        """

        def task(part: np.ndarray) -> list:
            nodes, d, K, M = compute(part)
            return asm.prepare(nodes, d, K, M)

        if self.threads <= 1 or len(parts) <= 1:
            for part in parts:
                asm.scatter(task(part))
            return
        todo = iter(parts)
        with ThreadPoolExecutor(self.threads, thread_name_prefix="femcal-kernel") as pool:
            pending: deque[Future] = deque()
            try:
                for part in todo:
                    pending.append(pool.submit(task, part))
                    if len(pending) > self.threads:
                        break
                while pending:
                    prepared = pending.popleft().result()
                    nxt = next(todo, None)
                    if nxt is not None:
                        pending.append(pool.submit(task, nxt))
                    asm.scatter(prepared)
            finally:
                for f in pending:
                    f.cancel()

    def mat1(self, mids: np.ndarray, who: str, eids: np.ndarray) -> dict[str, np.ndarray]:
        """E, G, NU, RHO of MAT1 materials, with NASTRAN's rules for blank E, G or NU."""
        table = self.model.materials.get("MAT1")
        if table is None:
            raise ModelError(f"{who} elements need MAT1 materials; the deck has none", eids[:20])
        rows = _Lookup(table["mid"]).rows(mids)
        if (rows < 0).any():
            bad = np.flatnonzero(rows < 0)
            raise ModelError(
                f"{who} elements {eids[bad][:20].tolist()} refer to materials "
                f"{np.unique(mids[bad])[:20].tolist()} that are not MAT1",
                eids[bad][:20],
            )
        E, G, nu = table["e"][rows], table["g"][rows], table["nu"][rows]
        E, G, nu = mat1_moduli(E, G, nu)
        return {"E": E, "G": G, "nu": nu, "rho": table["rho"][rows]}


def _property(model: Model, card: str, block: ElementBlock, rows_of: str = "pid"):
    table = model.properties[card]
    rows = _Lookup(table[rows_of]).rows(block.pids)
    return table, rows


# ----------------------------------------------------------------------------- rods


def _rods(ctx: _Context, block: ElementBlock, asm: Assembler) -> float:
    m = ctx.model
    xyz = m.xyz[block.nodes]
    if block.type == "CONROD":
        d = block.data
        mids, A, J, nsm = d["mid"], d["a"], d["j"], d["nsm"]
    elif block.type == "CROD":
        t, rows = _property(m, "PROD", block)
        mids, A, J, nsm = t["mid"][rows], t["a"][rows], t["j"][rows], t["nsm"][rows]
    else:  # CTUBE
        t, rows = _property(m, "PTUBE", block)
        od, wall, nsm = t["od"][rows], t["t"][rows], t["nsm"][rows]
        od2 = t["od2"][rows]
        od = np.where(np.isnan(od2), od, 0.5 * (od + od2))  # tapered tubes: mean diameter
        wall = np.where(np.isnan(wall), od / 2.0, wall)
        di = od - 2.0 * wall
        A = np.pi * (od**2 - di**2) / 4.0
        J = np.pi * (od**4 - di**4) / 32.0
        mids = t["mid"][rows]
    mat = ctx.mat1(mids, block.type, block.ids)
    K, M = rod_matrices(xyz, mat["E"], mat["G"], A, J, mat["rho"], nsm, coupled_mass=ctx.coupled)
    asm.add_blocks(block.nodes, 6, K, M)
    L = np.linalg.norm(xyz[:, 1] - xyz[:, 0], axis=1)
    return float(((mat["rho"] * A + nsm) * L).sum())


# ----------------------------------------------------------------------------- bars, beams


def _orientation(ctx: _Context, block: ElementBlock) -> tuple[np.ndarray, np.ndarray]:
    """Orientation vectors v (basic) and OFFT codes of CBAR/CBEAM, with BAROR/BEAMOR defaults."""
    m = ctx.model
    d = block.data
    x = np.column_stack([d["x1"], d["x2"], d["x3"]])
    g0 = d["g0"].copy()
    offt = np.array([s or "" for s in d.get("offt", np.full(len(block), "", object))], object)
    missing = np.isnan(x).all(axis=1) & ((g0 == INT_BLANK) | (g0 == 0))
    if missing.any():
        raise ModelError(
            f"{block.type} {block.ids[missing][:20].tolist()} have neither an orientation "
            "vector nor G0, and no BAROR/BEAMOR gives one",
            block.ids[missing][:20],
        )
    offt = np.where(offt == "", "GGG", offt)
    ga = block.nodes[:, 0]
    v = np.where(np.isnan(x), 0.0, x)
    use_g0 = (g0 != INT_BLANK) & (g0 != 0)
    if use_g0.any():
        gi = m.node_index(g0[use_g0])
        v[use_g0] = m.xyz[gi] - m.xyz[ga[use_g0]]
    vec = ~use_g0
    in_cd = vec & np.array([o[0] == "G" for o in offt])
    if in_cd.any():  # components in the displacement frame of GA
        v[in_cd] = np.einsum("nij,nj->ni", m.cd_frames[ga[in_cd]], v[in_cd])
    return v, offt


def _offsets(ctx: _Context, block: ElementBlock, offt: np.ndarray, v: np.ndarray):
    m = ctx.model
    d = block.data
    wa = np.column_stack([d["w1a"], d["w2a"], d["w3a"]])
    wb = np.column_stack([d["w1b"], d["w2b"], d["w3b"]])
    if not (wa.any() or wb.any()):
        return wa, wb
    R = None
    for end, w, col in ((0, wa, 1), (1, wb, 2)):
        codes = np.array([o[col] for o in offt])
        g = codes == "G"
        if g.any():
            w[g] = np.einsum("nij,nj->ni", m.cd_frames[block.nodes[g, end]], w[g])
        o = codes == "O"
        if o.any():
            if R is None:
                xyz = m.xyz[block.nodes]
                R, _ = line_frame(xyz[:, 0], xyz[:, 1], v)
            w[o] = np.einsum("nji,nj->ni", R[o], w[o])
    return wa, wb


def _bars(ctx: _Context, block: ElementBlock, asm: Assembler) -> float:
    m = ctx.model
    n = len(block)
    xyz = m.xyz[block.nodes]
    v, offt = _orientation(ctx, block)
    wa, wb = _offsets(ctx, block, offt, v)
    section = np.zeros((n, 5))
    k1 = np.full(n, np.nan)
    k2 = np.full(n, np.nan)
    mids = np.zeros(n, np.int64)
    nsm = np.zeros(n)
    done = np.zeros(n, bool)
    if "PBAR" in m.properties:
        t, rows = _property(m, "PBAR", block)
        sel = rows >= 0
        r = rows[sel]
        section[sel] = np.column_stack([t["a"][r], t["i1"][r], t["i2"][r], t["i12"][r], t["j"][r]])
        k1[sel], k2[sel] = t["k1"][r], t["k2"][r]
        mids[sel], nsm[sel] = t["mid"][r], t["nsm"][r]
        done |= sel
    if "PBARL" in m.properties:
        recs = {p.pid: p for p in m.properties["PBARL"]}
        for i in np.flatnonzero(~done):
            p = recs.get(int(block.pids[i]))
            if p is None:
                continue
            section[i] = _section(p.type, p.dims, block, i)
            k1[i], k2[i] = shear_factors(p.type, p.dims)[0]
            mids[i], nsm[i] = p.mid, p.nsm
            done[i] = True
    _all_done(done, block, "PBAR or PBARL")
    mat = ctx.mat1(mids, block.type, block.ids)
    mpl = mat["rho"] * section[:, 0] + nsm
    K, M = bar_matrices(
        xyz, v, wa, wb, mat["E"], mat["G"], section, k1, k2, mpl,
        pa=_pins(block.data["pa"]), pb=_pins(block.data["pb"]), coupled_mass=ctx.coupled,
    )  # fmt: skip
    asm.add_blocks(block.nodes, 6, K, M)
    L = np.linalg.norm((xyz[:, 1] + wb) - (xyz[:, 0] + wa), axis=1)
    return float((mpl * L).sum())


def _beams(ctx: _Context, block: ElementBlock, asm: Assembler) -> float:
    from ..elements.line import _GAUSS_W, _GAUSS_X, FLEX_X

    m = ctx.model
    n = len(block)
    xyz = m.xyz[block.nodes]
    v, offt = _orientation(ctx, block)
    wa, wb = _offsets(ctx, block, offt, v)
    q = len(_GAUSS_X)
    section = np.zeros((n, q, 5))  # at the mass stations _GAUSS_X
    section_k = np.zeros((n, len(FLEX_X), 5))  # at the flexibility stations FLEX_X
    k1 = np.ones(n)
    k2 = np.ones(n)
    mids = np.zeros(n, np.int64)
    nsm = np.zeros((n, q))
    nsi = np.zeros((n, q))  # NSI at the stations
    done = np.zeros(n, bool)
    pbeam = {p.pid: p for p in m.properties.get("PBEAM", [])}
    pbeaml = {p.pid: p for p in m.properties.get("PBEAML", [])}
    for i in range(n):
        pid = int(block.pids[i])
        if pid in pbeam:
            p = pbeam[pid]
            xs = np.array([s.x for s in p.stations])
            props = np.array([[s.a, s.i1, s.i2, s.i12, s.j] for s in p.stations])
            ns = np.array([s.nsm for s in p.stations])
            if len(xs) == 1:
                xs, props, ns = np.array([0.0, 1.0]), np.vstack([props, props]), np.r_[ns, ns]
            section[i], section_k[i] = (
                np.column_stack([np.interp(x, xs, props[:, c]) for c in range(5)])
                for x in (_GAUSS_X, FLEX_X)
            )
            nsm[i] = np.interp(_GAUSS_X, xs, ns)
            k1[i], k2[i] = p.tail_value("k1"), p.tail_value("k2")
            nsi_a, nsi_b = p.tail_value("nsi_a"), p.tail_value("nsi_b")
            nsi[i] = nsi_a + ((nsi_a if np.isnan(nsi_b) else nsi_b) - nsi_a) * _GAUSS_X
            mids[i] = p.mid
        elif pid in pbeaml:
            p = pbeaml[pid]
            xs = np.array([s.x for s in p.stations])
            dims = np.array([s.dims for s in p.stations])
            ns = np.array([s.nsm for s in p.stations])
            if len(xs) == 1:
                xs, dims, ns = np.array([0.0, 1.0]), np.vstack([dims, dims]), np.r_[ns, ns]
            # NASTRAN turns PBEAML into a PBEAM: section properties at the stations,
            # interpolated linearly between them
            props = _section(p.type, dims, block, i)
            section[i], section_k[i] = (
                np.column_stack([np.interp(x, xs, props[:, c]) for c in range(5)])
                for x in (_GAUSS_X, FLEX_X)
            )
            k1[i], k2[i] = shear_factors(p.type, dims).mean(axis=0)
            nsm[i] = np.interp(_GAUSS_X, xs, ns)
            mids[i] = p.mid
        else:
            continue
        done[i] = True
    _all_done(done, block, "PBEAM or PBEAML")
    mat = ctx.mat1(mids, block.type, block.ids)
    mpl_q = mat["rho"][:, None] * section[..., 0] + nsm  # mass per length at the stations
    mpl = (mpl_q * _GAUSS_W).sum(axis=1)  # mean mass per length
    polar_q = mat["rho"][:, None] * (section[..., 1] + section[..., 2]) + nsi
    K, M = bar_matrices(
        xyz, v, wa, wb, mat["E"], mat["G"], section_k, k1, k2, mpl_q,
        pa=_pins(block.data["pa"]), pb=_pins(block.data["pb"]), coupled_mass=ctx.coupled,
        torsion_inertia=polar_q,
    )  # fmt: skip
    asm.add_blocks(block.nodes, 6, K, M)
    L = np.linalg.norm((xyz[:, 1] + wb) - (xyz[:, 0] + wa), axis=1)
    return float((mpl * L).sum())


def _section(kind: str, dims, block: ElementBlock, i: int) -> np.ndarray:
    try:
        props = section_properties(kind, np.atleast_2d(dims))
    except ValueError as e:
        raise ModelError(f"{block.type} {block.ids[i]}: {e}", [int(block.ids[i])]) from None
    return props if np.ndim(dims) == 2 and len(dims) > 1 else props[0]


def _pins(codes: np.ndarray) -> np.ndarray:
    return np.where(codes == INT_BLANK, 0, codes)


def _all_done(done: np.ndarray, block: ElementBlock, what: str) -> None:
    if not done.all():
        bad = block.ids[~done][:20]
        raise ModelError(f"{block.type} {bad.tolist()} have no {what} property", bad)


# ----------------------------------------------------------------------------- bushes


def _bushes(ctx: _Context, block: ElementBlock, asm: Assembler) -> float:
    m = ctx.model
    n = len(block)
    d = block.data
    grounded = block.nodes[:, 1] < 0
    xyz = m.xyz[np.where(block.nodes < 0, block.nodes[:, :1], block.nodes)]
    recs = {p.pid: p for p in m.properties.get("PBUSH", [])}
    k = np.zeros((n, 6))
    for i in range(n):
        p = recs.get(int(block.pids[i]))
        if p is None:
            raise ModelError(
                f"CBUSH {block.ids[i]} has no PBUSH {block.pids[i]}", [int(block.ids[i])]
            )
        if p.mass:
            raise ModelError(f"PBUSH {p.pid}: M (bush mass) is not supported yet", [p.pid])
        k[i] = p.k
    R = np.zeros((n, 3, 3))
    cid = d["cid"]
    has_cid = cid != INT_BLANK
    for c in np.unique(cid[has_cid]):
        sel = np.flatnonzero(cid == c)
        cs = m.coords.get(int(c))
        if cs is None:
            raise ModelError(
                f"CBUSH {block.ids[sel][:20].tolist()}: CID {c} is not defined", block.ids[sel][:20]
            )
        R[sel] = np.swapaxes(displacement_frames(cs, xyz[sel, 0]), 1, 2)
    other = np.flatnonzero(~has_cid)
    if len(other):
        sub = ElementBlock(block.type, block.ids[other], block.pids[other], block.nodes[other],
                           None, {kk: vv[other] for kk, vv in d.items()}, block.file[other],
                           block.line[other])  # fmt: skip
        coincident = np.linalg.norm(xyz[other, 1] - xyz[other, 0], axis=1) <= 0.0
        if (coincident | grounded[other]).any():
            bad = block.ids[other][coincident | grounded[other]][:20]
            raise ModelError(f"CBUSH {bad.tolist()}: coincident or grounded bushes need a CID", bad)
        v, _ = _orientation(ctx, sub)
        R[other], _ = line_frame(xyz[other, 0], xyz[other, 1], v)
    s = np.where(np.isnan(d["s"]), 0.5, d["s"])
    K = bush_matrices(xyz, R, k, s, grounded)
    asm.add_blocks(block.nodes, 6, K, None)
    return 0.0


# ----------------------------------------------------------------------------- scalar, masses


def _scalar(ctx: _Context, block: ElementBlock, asm: Assembler) -> float:
    m = ctx.model
    etype = block.type
    if etype in ("CELAS2", "CELAS4"):
        value = block.data["k"]
    elif etype in ("CMASS2", "CMASS4"):
        value = block.data["m"]
    else:
        card, col = ("PELAS", "k") if etype.startswith("CELAS") else ("PMASS", "m")
        t, rows = _property(m, card, block)
        value = t[col][rows]
    nodes, comps = block.nodes, block.components
    present = nodes >= 0
    safe = np.where(present, nodes, 0)
    dof = m.dof_start[safe] + np.where(m.is_grid[safe], comps - 1, 0)
    rows_, cols_, vals = [], [], []
    for i in (0, 1):
        for j in (0, 1):
            sel = present[:, i] & present[:, j]
            rows_.append(dof[sel, i])
            cols_.append(dof[sel, j])
            vals.append(value[sel] * (1.0 if i == j else -1.0))
    asm.add_entries(
        np.concatenate(rows_), np.concatenate(cols_), np.concatenate(vals),
        which=0 if etype.startswith("CELAS") else 1,
    )  # fmt: skip
    return float(value.sum()) if etype.startswith("CMASS") else 0.0


def _frames_of(ctx: _Context, cids: np.ndarray, at: np.ndarray, block: ElementBlock) -> np.ndarray:
    T = np.broadcast_to(np.eye(3), (len(cids), 3, 3)).copy()
    for c in np.unique(cids):
        if c in (0, -1):
            continue
        cs = ctx.model.coords.get(int(c))
        sel = np.flatnonzero(cids == c)
        if cs is None:
            raise ModelError(
                f"{block.type} {block.ids[sel][:20].tolist()}: CID {c} is not defined",
                block.ids[sel][:20],
            )
        T[sel] = displacement_frames(cs, at[sel])
    return T


def _conm2(ctx: _Context, block: ElementBlock, asm: Assembler) -> float:
    m = ctx.model
    d = block.data
    g = block.nodes[:, 0]
    cid = d["cid"]
    x = np.column_stack([d["x1"], d["x2"], d["x3"]])
    T = _frames_of(ctx, cid, m.xyz[g], block)
    offset = np.where((cid == -1)[:, None], x - m.xyz[g], np.einsum("nij,nj->ni", T, x))
    inertia = np.column_stack([d[k] for k in ("i11", "i21", "i22", "i31", "i32", "i33")])
    M = conm2_matrix(d["m"], offset, inertia, T)
    asm.add_blocks(block.nodes, 6, None, M)
    return float(d["m"].sum())


def _conm1(ctx: _Context, block: ElementBlock, asm: Assembler) -> float:
    m = ctx.model
    d = block.data
    g = block.nodes[:, 0]
    T = _frames_of(ctx, d["cid"], m.xyz[g], block)
    lower = np.column_stack([d[f"m{i}{j}"] for i in range(1, 7) for j in range(1, i + 1)])
    asm.add_blocks(block.nodes, 6, None, conm1_matrix(lower, T))
    return float(d["m11"].sum())


# ----------------------------------------------------------------------------- shells, solids


def _shells(ctx: _Context, block: ElementBlock, asm: Assembler) -> float:
    from ..elements.shell import quad4_matrices, shell_frame, tria3_matrices
    from ..elements.shell_quadratic import MIDSIDE_EDGES, quad8_matrices, tria6_matrices
    from ..properties.shells import shell_sections

    m = ctx.model
    k = block.nodes.shape[1]
    corners = 4 if block.type.startswith("CQUAD") else 3
    quadratic = k in MIDSIDE_EDGES
    # an omitted midside node (-1) gets a placeholder position: the quadratic kernels place it
    # on its edge themselves, and frame, material angle and area use the corners only
    xyz = m.xyz[np.where(block.nodes < 0, 0, block.nodes)]
    try:
        R, centre = shell_frame(xyz[:, :corners])
    except ValueError as e:
        raise ModelError(f"{block.type}: {_name_positions(str(e), block.ids)}",
                         block.ids[:20]) from None  # fmt: skip
    theta = _material_angle(ctx, block, xyz, R, centre)
    d = block.data
    et = np.column_stack([d[f"t{i}"] for i in range(1, corners + 1)])
    sec = shell_sections(
        m.properties, ctx.materials, block.pids, block.ids, theta, et, d["tflag"], block.type
    )
    zoffs = np.where(np.isnan(d["zoffs"]), 0.0, d["zoffs"])
    kernel = {4: quad4_matrices, 3: tria3_matrices, 8: quad8_matrices, 6: tria6_matrices}[k]

    def compute(sel: np.ndarray) -> tuple[np.ndarray, int, np.ndarray, np.ndarray]:
        rigid = bool(sec.shear_rigid[sel[0]])
        B = sec.B[sel] if sec.B[sel].any() else None
        try:
            # quadratic shells: which midside nodes are given (the kernel ties an omitted one
            # to its corners); linear ones: CQUADR / CTRIAR have the Allman (drilling) membrane
            variant = ({"midside": block.nodes[sel, corners:] >= 0} if quadratic
                       else {"drilling": block.type in ("CQUADR", "CTRIAR")})  # fmt: skip
            K, M = kernel(
                xyz[sel], sec.A[sel], sec.D[sel], None if rigid else sec.S[sel], B,
                rho_area=sec.rho_area[sel], nsm=sec.nsm[sel], zoffs=zoffs[sel],
                k6rot=ctx.k6rot, coupled_mass=ctx.coupled, **variant,
            )  # fmt: skip
        except ValueError as e:
            ids = block.ids[sel]
            raise ModelError(f"{block.type}: {_name_positions(str(e), ids)}", ids[:20]) from None
        return block.nodes[sel], 6, K, M

    parts = []
    for rigid in (False, True):  # one kernel call takes one kind of transverse shear
        group = np.flatnonzero(sec.shear_rigid == rigid)
        parts += [group[s : s + KERNEL_CHUNK] for s in range(0, len(group), KERNEL_CHUNK)]
    ctx.run_chunks(asm, parts, compute)
    area = _polygon_area(xyz[:, :corners])
    return float(((sec.rho_area + sec.nsm) * area).sum())


def _name_positions(message: str, ids: np.ndarray) -> str:
    """Replace the element positions ``[i, j]`` of a kernel's message (``element index(es)
    [i, j]``, ``positions [i, j]`` or a bare list) by the element ids they stand for."""
    import re

    m = re.search(r"(?:element )?(?:index\(es\) |positions )?\[([\d, ]+)\]", message)
    if not m:
        return message
    pos = [int(x) for x in m.group(1).split(",") if x.strip()]
    named = [int(ids[p]) for p in pos if 0 <= p < len(ids)]
    return message[: m.start()] + f"element ids {named}" + message[m.end() :]


def _polygon_area(xyz: np.ndarray) -> np.ndarray:
    """(n,) area of flat or slightly warped polygons (n, k, 3)."""
    c = np.cross(xyz[:, 1:-1] - xyz[:, :1], xyz[:, 2:] - xyz[:, :1])
    return 0.5 * np.linalg.norm(c.sum(axis=1), axis=1)


def _material_angle(
    ctx: _Context, block: ElementBlock, xyz: np.ndarray, R: np.ndarray, centre: np.ndarray
) -> np.ndarray:
    """Material x axis angle from the element x axis (degrees): THETA from the projected
    G1-G2 side, or the projection of MCID's x axis."""
    d = block.data
    e12 = xyz[:, 1] - xyz[:, 0]
    phi = np.degrees(
        np.arctan2(np.einsum("ni,ni->n", e12, R[:, 1]), np.einsum("ni,ni->n", e12, R[:, 0]))
    )
    theta = np.where(np.isnan(d["theta"]), 0.0, d["theta"]) + phi
    mcid = d["mcid"]
    for c in np.unique(mcid[(mcid != INT_BLANK) & (mcid >= 0)]):
        sel = np.flatnonzero(mcid == c)
        cs = ctx.model.coords.get(int(c))
        if cs is None:
            raise ModelError(
                f"{block.type} {block.ids[sel][:20].tolist()}: MCID {c} is not defined",
                block.ids[sel][:20],
            )
        X = displacement_frames(cs, centre[sel])[:, :, 0]
        theta[sel] = np.degrees(
            np.arctan2(np.einsum("ni,ni->n", X, R[sel, 1]), np.einsum("ni,ni->n", X, R[sel, 0]))
        )
    return theta


def _shear_panels(ctx: _Context, block: ElementBlock, asm: Assembler) -> float:
    from ..elements.shear import shear_panel_matrices

    m = ctx.model
    t, rows = _property(m, "PSHEAR", block)
    f1, f2 = t["f1"][rows], t["f2"][rows]
    if ((f1 > 0) | (f2 > 0)).any():
        bad = block.ids[(f1 > 0) | (f2 > 0)][:20]
        raise ModelError(
            f"CSHEAR {bad.tolist()}: PSHEAR F1/F2 (extensional edge stiffness) is not supported",
            bad,
        )
    mat = ctx.mat1(t["mid"][rows], "CSHEAR", block.ids)
    thick, nsm = t["t"][rows], t["nsm"][rows]
    xyz = m.xyz[block.nodes]
    try:
        K, M = shear_panel_matrices(xyz, mat["G"], thick, mat["rho"] * thick + nsm)
    except ValueError as e:
        raise ModelError(f"CSHEAR: {_name_positions(str(e), block.ids)}", block.ids[:20]) from None
    asm.add_blocks(block.nodes, 6, K, M)
    return float(((mat["rho"] * thick + nsm) * _polygon_area(xyz)).sum())


_SOLID_KINDS = {
    "CHEXA": ((8, "HEXA8"), (20, "HEXA20")),
    "CPENTA": ((6, "PENTA6"), (15, "PENTA15")),
    "CTETRA": ((4, "TETRA4"), (10, "TETRA10")),
    "CPYRAM": ((5, "PYRAM5"), (13, "PYRAM13")),
}


def _solids(ctx: _Context, block: ElementBlock, asm: Assembler) -> float:
    from ..elements.solid import solid_matrices, solid_volume

    m = ctx.model
    t, rows = _property(m, "PSOLID", block)
    mids, cordm = t["mid"][rows], t["cordm"][rows]
    C, rho, iso = ctx.materials.solid(mids, f"{block.type} PSOLID")
    if (~iso & (cordm != 0)).any():
        bad = block.ids[~iso & (cordm != 0)][:20]
        raise ModelError(f"{block.type} {bad.tolist()}: anisotropic material with PSOLID CORDM "
                         "other than basic is not supported yet", bad)  # fmt: skip
    present = (block.nodes >= 0).sum(axis=1)
    total = 0.0
    matched = np.zeros(len(block), bool)
    for nn, kind in _SOLID_KINDS[block.type]:
        sel = np.flatnonzero((present == nn) & (block.nodes[:, :nn] >= 0).all(axis=1))
        if not len(sel):
            continue
        matched[sel] = True

        def compute(part: np.ndarray, nn=nn, kind=kind):
            nodes = block.nodes[part, :nn]
            try:
                K, M = solid_matrices(kind, m.xyz[nodes], C[part], rho[part],
                                      coupled_mass=ctx.coupled)  # fmt: skip
            except ValueError as e:
                ids = block.ids[part]
                raise ModelError(f"{block.type} ({kind}): {_name_positions(str(e), ids)}",
                                 ids[:20]) from None  # fmt: skip
            return nodes, 3, K, M

        parts = [sel[s : s + KERNEL_CHUNK] for s in range(0, len(sel), KERNEL_CHUNK)]
        ctx.run_chunks(asm, parts, compute)
        total += float((rho[sel] * solid_volume(kind, m.xyz[block.nodes[sel, :nn]])).sum())
    if not matched.all():
        bad = block.ids[~matched][:20]
        raise ModelError(
            f"{block.type} {bad.tolist()}: some but not all midside nodes given; expected "
            f"{' or '.join(str(nn) for nn, _ in _SOLID_KINDS[block.type])} nodes",
            bad,
        )
    return total


_Handler = Callable[[_Context, ElementBlock, Assembler], float]
_HANDLERS: dict[str, _Handler] = {
    "CROD": _rods,
    "CONROD": _rods,
    "CTUBE": _rods,
    "CBAR": _bars,
    "CBEAM": _beams,
    "CBUSH": _bushes,
    "CELAS1": _scalar,
    "CELAS2": _scalar,
    "CELAS3": _scalar,
    "CELAS4": _scalar,
    "CMASS1": _scalar,
    "CMASS2": _scalar,
    "CMASS3": _scalar,
    "CMASS4": _scalar,
    "CONM2": _conm2,
    "CONM1": _conm1,
    "CQUAD4": _shells,
    "CTRIA3": _shells,
    "CQUADR": _shells,
    "CTRIAR": _shells,
    "CQUAD8": _shells,
    "CTRIA6": _shells,
    "CSHEAR": _shear_panels,
    "CHEXA": _solids,
    "CPENTA": _solids,
    "CTETRA": _solids,
    "CPYRAM": _solids,
}
