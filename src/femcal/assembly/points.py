"""Scalar springs and masses (CELAS1-4, CMASS1-4) and concentrated masses (CONM1, CONM2)
into the assembly."""

from __future__ import annotations

import numpy as np

from ..elements.mass import conm1_matrix, conm2_matrix
from ..errors import ModelError
from ..model.coords import displacement_frames
from ..model.model import ElementBlock
from ..properties.lines import property_rows
from .context import Context
from .pattern import Assembler


def scalars(ctx: Context, block: ElementBlock, asm: Assembler) -> float:
    m = ctx.model
    etype = block.type
    if etype in ("CELAS2", "CELAS4"):
        value = block.data["k"]
    elif etype in ("CMASS2", "CMASS4"):
        value = block.data["m"]
    else:
        card, col = ("PELAS", "k") if etype.startswith("CELAS") else ("PMASS", "m")
        t, rows = property_rows(m, card, block)
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


def _frames_of(ctx: Context, cids: np.ndarray, at: np.ndarray, block: ElementBlock) -> np.ndarray:
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


def conm2(ctx: Context, block: ElementBlock, asm: Assembler) -> float:
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


def conm1(ctx: Context, block: ElementBlock, asm: Assembler) -> float:
    m = ctx.model
    d = block.data
    g = block.nodes[:, 0]
    T = _frames_of(ctx, d["cid"], m.xyz[g], block)
    lower = np.column_stack([d[f"m{i}{j}"] for i in range(1, 7) for j in range(1, i + 1)])
    asm.add_blocks(block.nodes, 6, None, conm1_matrix(lower, T))
    return float(d["m11"].sum())
