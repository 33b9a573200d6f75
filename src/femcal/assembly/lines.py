"""Rods, bars, beams and bushes into the assembly: orientation, offsets and pin flags from
the element cards, sections from their properties (:mod:`femcal.properties.lines`), matrices
from :mod:`femcal.elements.line`."""

from __future__ import annotations

import numpy as np

from ..elements.line import (
    FLEX_X,
    MASS_W,
    MASS_X,
    bar_matrices,
    bush_matrices,
    line_frame,
    rod_matrices,
)
from ..errors import ModelError
from ..markers import INT_BLANK
from ..model.coords import displacement_frames
from ..model.model import ElementBlock
from ..properties.lines import bar_sections, beam_sections, bush_stiffness, rod_sections
from .context import Context
from .pattern import Assembler


def rods(ctx: Context, block: ElementBlock, asm: Assembler) -> float:
    m = ctx.model
    xyz = m.xyz[block.nodes]
    s = rod_sections(m, block)
    mat = ctx.materials.mat1(s.mids, block.type, block.ids)
    K, M = rod_matrices(xyz, mat.E, mat.G, s.area, s.torsion, mat.rho, s.nsm,
                        coupled_mass=ctx.coupled)  # fmt: skip
    asm.add_blocks(block.nodes, 6, K, M)
    L = np.linalg.norm(xyz[:, 1] - xyz[:, 0], axis=1)
    return float(((mat.rho * s.area + s.nsm) * L).sum())


def _orientation(ctx: Context, block: ElementBlock) -> tuple[np.ndarray, np.ndarray]:
    """Orientation vectors v (basic) and OFFT codes of CBAR/CBEAM, with BAROR/BEAMOR defaults."""
    m = ctx.model
    d = block.data
    x = np.column_stack([d["x1"], d["x2"], d["x3"]])
    g0 = d["g0"].copy()
    offt = np.array([s or "" for s in d.get("offt", np.full(len(block), "", object))], object)
    missing = _no_orientation(block)
    if missing.any():
        default = {"CBAR": ", and no BAROR gives one", "CBEAM": ", and no BEAMOR gives one"}
        raise ModelError(
            f"{block.type} {block.ids[missing][:20].tolist()} have neither an orientation "
            f"vector nor G0{default.get(block.type, '')}",
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


def _no_orientation(block: ElementBlock) -> np.ndarray:
    """(n,) True where an element gives neither X1-X3 nor G0."""
    d = block.data
    x = np.column_stack([d["x1"], d["x2"], d["x3"]])
    return np.isnan(x).all(axis=1) & ((d["g0"] == INT_BLANK) | (d["g0"] == 0))


def _offsets(ctx: Context, block: ElementBlock, offt: np.ndarray, v: np.ndarray):
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


def bars(ctx: Context, block: ElementBlock, asm: Assembler) -> float:
    m = ctx.model
    xyz = m.xyz[block.nodes]
    v, offt = _orientation(ctx, block)
    wa, wb = _offsets(ctx, block, offt, v)
    s = bar_sections(m, block)
    mat = ctx.materials.mat1(s.mids, block.type, block.ids)
    mpl = mat.rho * s.section[:, 0] + s.nsm
    K, M = bar_matrices(
        xyz, v, wa, wb, mat.E, mat.G, s.section, s.k1, s.k2, mpl,
        pa=_pins(block.data["pa"]), pb=_pins(block.data["pb"]), coupled_mass=ctx.coupled,
    )  # fmt: skip
    asm.add_blocks(block.nodes, 6, K, M)
    L = np.linalg.norm((xyz[:, 1] + wb) - (xyz[:, 0] + wa), axis=1)
    return float((mpl * L).sum())


def beams(ctx: Context, block: ElementBlock, asm: Assembler) -> float:
    m = ctx.model
    xyz = m.xyz[block.nodes]
    v, offt = _orientation(ctx, block)
    wa, wb = _offsets(ctx, block, offt, v)
    s = beam_sections(m, block, MASS_X, FLEX_X)
    mat = ctx.materials.mat1(s.mids, block.type, block.ids)
    mpl_q = mat.rho[:, None] * s.section[..., 0] + s.nsm  # mass per length at the stations
    mpl = (mpl_q * MASS_W).sum(axis=1)  # mean mass per length
    polar_q = mat.rho[:, None] * (s.section[..., 1] + s.section[..., 2]) + s.nsi
    K, M = bar_matrices(
        xyz, v, wa, wb, mat.E, mat.G, s.section_k, s.k1, s.k2, mpl_q,
        pa=_pins(block.data["pa"]), pb=_pins(block.data["pb"]), coupled_mass=ctx.coupled,
        torsion_inertia=polar_q,
    )  # fmt: skip
    asm.add_blocks(block.nodes, 6, K, M)
    L = np.linalg.norm((xyz[:, 1] + wb) - (xyz[:, 0] + wa), axis=1)
    return float((mpl * L).sum())


def _pins(codes: np.ndarray) -> np.ndarray:
    return np.where(codes == INT_BLANK, 0, codes)


def bushes(ctx: Context, block: ElementBlock, asm: Assembler) -> float:
    m = ctx.model
    n = len(block)
    d = block.data
    grounded = block.nodes[:, 1] < 0
    xyz = m.xyz[np.where(block.nodes < 0, block.nodes[:, :1], block.nodes)]
    k = bush_stiffness(m, block)
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
        # QRG CBUSH remark 5: without GO, X1-X3 and CID the element x axis is GA-GB, valid
        # when the PBUSH gives only K1 and K4 (the y and z axes then carry no stiffness)
        axial = _no_orientation(sub)
        if axial.any():
            across = k[other][axial][:, [1, 2, 4, 5]]
            if across.any():
                bad = sub.ids[axial][across.any(axis=1)][:20]
                raise ModelError(f"CBUSH {bad.tolist()}: neither GO, X1-X3 nor CID, with a "
                                 "PBUSH K2, K3, K5 or K6: expected an orientation or a CID "
                                 "(without them only K1 and K4 are allowed)", bad)  # fmt: skip
            axis = xyz[other][axial, 1] - xyz[other][axial, 0]
            # any vector off the axis (only the x axis carries stiffness), given as X1-X3 are:
            # in the displacement frame of GA
            trial = np.eye(3)[np.argmin(np.abs(axis), axis=1)]
            frames = m.cd_frames[sub.nodes[axial, 0]]
            trial = np.einsum("nji,nj->ni", frames, trial)
            sub.data["x1"][axial], sub.data["x2"][axial], sub.data["x3"][axial] = trial.T
        v, _ = _orientation(ctx, sub)
        R[other], _ = line_frame(xyz[other, 0], xyz[other, 1], v)
    s = np.where(np.isnan(d["s"]), 0.5, d["s"])
    K = bush_matrices(xyz, R, k, s, grounded)
    asm.add_blocks(block.nodes, 6, K, None)
    return 0.0
