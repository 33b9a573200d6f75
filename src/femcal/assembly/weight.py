"""Grid point weight generator (NASTRAN PARAM GRDPNT): rigid-body mass properties of M_gg."""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..elements.line import skew
from ..errors import FemcalWarning
from ..model.model import Model


@dataclass(frozen=True)
class WeightSummary:
    """Rigid-body mass properties.

    Attributes
    ----------
    reference : (3,) reference point in basic (GRDPNT grid, or the origin).
    MO : (6, 6) rigid-body mass matrix about the reference point, basic axes.
    mass : (3,) mass in the x, y and z directions.
    cg : (3, 3) row d: centre of gravity seen from the direction-d mass (basic coordinates).
    inertia_cg : (3, 3) inertia tensor about the centre of gravity (NASTRAN's I(S)).
    principal : (3,) principal moments of inertia, ascending; axes : (3, 3) columns.
    """

    reference: np.ndarray
    MO: np.ndarray
    mass: np.ndarray
    cg: np.ndarray
    inertia_cg: np.ndarray
    principal: np.ndarray
    axes: np.ndarray


def rigid_body_vectors(model: Model, reference: np.ndarray) -> np.ndarray:
    """(n_dof, 6) g-set displacements (CD frames) of unit rigid motions about ``reference``."""
    D = np.zeros((model.n_dof, 6))
    g = np.flatnonzero(model.is_grid)
    r = model.xyz[g] - reference
    basic = np.zeros((len(g), 6, 6))  # rows: T1-3, R1-3 in basic; columns: rigid motions
    basic[:, 0:3, 0:3] = np.eye(3)
    basic[:, 0:3, 3:6] = -skew(r)
    basic[:, 3:6, 3:6] = np.eye(3)
    F = model.cd_frames[g]
    local = np.empty_like(basic)
    local[:, 0:3] = np.einsum("nji,njk->nik", F, basic[:, 0:3])
    local[:, 3:6] = np.einsum("nji,njk->nik", F, basic[:, 3:6])
    rows = model.dof_start[g][:, None] + np.arange(6)
    D[rows.ravel()] = local.reshape(-1, 6)
    return D


def weight_summary(model: Model, M: sp.spmatrix, reference_grid: int = 0) -> WeightSummary:
    """Mass, centre of gravity and inertia of the g-set mass matrix ``M`` (in the input's
    mass units: NASTRAN's generator reports before PARAM WTMASS, so pass M / WTMASS).

    ``reference_grid``: GRID id of the reference point, 0 for the basic origin. A grid the
    model lacks is warned about (FemcalWarning) and the basic origin taken, as NASTRAN
    does.
    """
    ref = np.zeros(3)
    if reference_grid > 0:
        i = int(model.node_index(reference_grid)[0])
        if i < 0 or not model.is_grid[i]:
            warnings.warn(f"PARAM GRDPNT {reference_grid}: no GRID {reference_grid} in the "
                          "model; the weight summary is taken about the basic origin, as "
                          "NASTRAN does", FemcalWarning, stacklevel=2)  # fmt: skip
        else:
            ref = model.xyz[i].copy()
    D = rigid_body_vectors(model, ref)
    MO = D.T @ (M @ D)
    MO = 0.5 * (MO + MO.T)
    mass = np.diag(MO)[:3].copy()
    cg = np.zeros((3, 3))
    with np.errstate(divide="ignore", invalid="ignore"):
        # moments of the direction-d mass about the reference give the other two coordinates
        cg[0] = [np.nan, -MO[0, 5] / mass[0], MO[0, 4] / mass[0]]
        cg[1] = [MO[1, 5] / mass[1], np.nan, -MO[1, 3] / mass[1]]
        cg[2] = [-MO[2, 4] / mass[2], MO[2, 3] / mass[2], np.nan]
    cg = np.where(np.isnan(cg), 0.0, cg) + ref
    c = np.array([cg[1, 0], cg[0, 1], cg[0, 2]]) - ref  # x from y-mass, y, z from x-mass
    m = mass.mean()
    Iref = MO[3:6, 3:6]
    inertia = Iref - m * (c @ c * np.eye(3) - np.outer(c, c))
    w, v = np.linalg.eigh(0.5 * (inertia + inertia.T))
    return WeightSummary(ref, MO, mass, cg, inertia, w, v)


def weight_table(ws: WeightSummary) -> Iterator[str]:
    """Lines in the spirit of NASTRAN's GRID POINT WEIGHT GENERATOR output."""
    yield "     O U T P U T   F R O M   G R I D   P O I N T   W E I G H T   G E N E R A T O R"
    x, y, z = ws.reference
    yield f"   REFERENCE POINT = ({x:.6g}, {y:.6g}, {z:.6g})"
    yield "   M O (rigid-body mass matrix about the reference point, basic axes)"
    for row in ws.MO:
        yield "      " + " ".join(f"{v:13.6E}" for v in row)
    yield "   DIRECTION   MASS            X-C.G.          Y-C.G.          Z-C.G."
    for d, name in enumerate("XYZ"):
        yield (f"      {name}     {ws.mass[d]:13.6E}  {ws.cg[d, 0]:13.6E}  {ws.cg[d, 1]:13.6E}"
               f"  {ws.cg[d, 2]:13.6E}")  # fmt: skip
    yield "   I(S) (inertia about the centre of gravity)"
    for row in ws.inertia_cg:
        yield "      " + " ".join(f"{v:13.6E}" for v in row)
    yield "   I(Q) (principal inertias) " + " ".join(f"{v:13.6E}" for v in ws.principal)
