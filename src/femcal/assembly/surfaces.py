"""Shells (CQUAD4, CTRIA3, CQUADR, CTRIAR, CQUAD8, CTRIA6) and shear panels (CSHEAR) into the
assembly: element frames and material angles, sections from :mod:`femcal.properties.shells`,
matrices from :mod:`femcal.elements.shell`, :mod:`femcal.elements.shell_quadratic` and
:mod:`femcal.elements.shear`."""

from __future__ import annotations

import numpy as np

from ..elements.shear import shear_panel_matrices
from ..elements.shell import quad4_matrices, shell_frame, tria3_matrices
from ..elements.shell_quadratic import MIDSIDE_EDGES, quad8_matrices, tria6_matrices
from ..errors import ModelError
from ..markers import INT_BLANK
from ..model.coords import displacement_frames
from ..model.model import ElementBlock
from ..properties.lines import property_rows
from ..properties.shells import shell_sections
from .context import Context, chunks, name_positions
from .pattern import Assembler


def shells(ctx: Context, block: ElementBlock, asm: Assembler) -> float:
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
        raise ModelError(f"{block.type}: {name_positions(str(e), block.ids)}",
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
            if quadratic:
                variant = {"midside": block.nodes[sel, corners:] >= 0}
            elif block.type in ("CQUADR", "CTRIAR"):
                variant = {"drilling": True}
            else:  # CQUAD4, CTRIA3: the grid normals tie the drilling rotation where curved
                variant = {"normals": ctx.grid_normals()[block.nodes[sel]]}
            if k == 4 and ctx.kept is not None:  # the same elements again: their shape kept
                variant["keep"] = ctx.kept.setdefault((block.type, sel.tobytes()), {})
            K, M = kernel(
                xyz[sel], sec.A[sel], sec.D[sel], None if rigid else sec.S[sel], B,
                rho_area=sec.rho_area[sel], nsm=sec.nsm[sel], zoffs=zoffs[sel],
                k6rot=ctx.k6rot, coupled_mass=ctx.coupled, **variant,
            )  # fmt: skip
        except ValueError as e:
            ids = block.ids[sel]
            raise ModelError(f"{block.type}: {name_positions(str(e), ids)}", ids[:20]) from None
        return block.nodes[sel], 6, K, M

    parts = []
    for rigid in (False, True):  # one kernel call takes one kind of transverse shear
        group = np.flatnonzero(sec.shear_rigid == rigid)
        parts += chunks(group)
    ctx.run_chunks(asm, parts, compute)
    area = _polygon_area(xyz[:, :corners])
    return float(((sec.rho_area + sec.nsm) * area).sum())


def _polygon_area(xyz: np.ndarray) -> np.ndarray:
    """(n,) area of flat or slightly warped polygons (n, k, 3)."""
    c = np.cross(xyz[:, 1:-1] - xyz[:, :1], xyz[:, 2:] - xyz[:, :1])
    return 0.5 * np.linalg.norm(c.sum(axis=1), axis=1)


def _material_angle(
    ctx: Context, block: ElementBlock, xyz: np.ndarray, R: np.ndarray, centre: np.ndarray
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


def shear_panels(ctx: Context, block: ElementBlock, asm: Assembler) -> float:
    m = ctx.model
    t, rows = property_rows(m, "PSHEAR", block)
    f1, f2 = t["f1"][rows], t["f2"][rows]
    if ((f1 > 0) | (f2 > 0)).any():
        bad = block.ids[(f1 > 0) | (f2 > 0)][:20]
        raise ModelError(
            f"CSHEAR {bad.tolist()}: PSHEAR F1/F2 (extensional edge stiffness) is not supported",
            bad,
        )
    mat = ctx.materials.mat1(t["mid"][rows], "CSHEAR", block.ids)
    thick, nsm = t["t"][rows], t["nsm"][rows]
    xyz = m.xyz[block.nodes]
    try:
        K, M = shear_panel_matrices(xyz, mat.G, thick, mat.rho * thick + nsm)
    except ValueError as e:
        raise ModelError(f"CSHEAR: {name_positions(str(e), block.ids)}", block.ids[:20]) from None
    asm.add_blocks(block.nodes, 6, K, M)
    return float(((mat.rho * thick + nsm) * _polygon_area(xyz)).sum())
