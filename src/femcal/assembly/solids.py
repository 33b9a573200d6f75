"""Solids (CHEXA, CPENTA, CTETRA, CPYRAM, linear and quadratic) into the assembly: PSOLID
materials and :mod:`femcal.elements.solid`'s matrices."""

from __future__ import annotations

import numpy as np

from ..elements.solid import solid_matrices, solid_volume
from ..errors import ModelError
from ..model.model import ElementBlock
from ..properties.lines import property_rows
from .context import Context, chunks, name_positions
from .pattern import Assembler

_SOLID_KINDS = {
    "CHEXA": ((8, "HEXA8"), (20, "HEXA20")),
    "CPENTA": ((6, "PENTA6"), (15, "PENTA15")),
    "CTETRA": ((4, "TETRA4"), (10, "TETRA10")),
    "CPYRAM": ((5, "PYRAM5"), (13, "PYRAM13")),
}


def solids(ctx: Context, block: ElementBlock, asm: Assembler) -> float:
    m = ctx.model
    t, rows = property_rows(m, "PSOLID", block)
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
                raise ModelError(f"{block.type} ({kind}): {name_positions(str(e), ids)}",
                                 ids[:20]) from None  # fmt: skip
            return nodes, 3, K, M

        ctx.run_chunks(asm, chunks(sel), compute)
        total += float((rho[sel] * solid_volume(kind, m.xyz[block.nodes[sel, :nn]])).sum())
    if not matched.all():
        bad = block.ids[~matched][:20]
        raise ModelError(
            f"{block.type} {bad.tolist()}: some but not all midside nodes given; expected "
            f"{' or '.join(str(nn) for nn, _ in _SOLID_KINDS[block.type])} nodes",
            bad,
        )
    return total
