"""Shell section resultants from PSHELL and PCOMP / PCOMPG, in each element's frame.

A shell section is what the shell kernels need: membrane A, coupling B, bending D (3 x 3
each), transverse shear S (2 x 2, or none for a shear-rigid section), and mass per area.

PSHELL (QRG): A = T Q(MID1); D = (12I/T^3) T^3/12 Q(MID2); S = (TS/T) T Gt(MID3); structural
mass rho(MID1) T (rho(MID2) T without MID1); NSM per area. Element thickness: T1..T4 of the
element (TFLAG 0: values, 1: fractions of T), else T; their mean over the nodes is used.

PCOMP (classical lamination theory): plies from Z0 (default -total/2) upwards; SYM mirrors the
plies; A, B, D summed over plies rotated to the element frame; S = 5/6 sum Gt t (an
approximation of NASTRAN's transverse shear for laminates, to be confirmed on NASTRAN runs);
plies without transverse shear moduli leave the laminate shear-rigid.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from ..markers import INT_BLANK
from ..model.ids import IdIndex
from .materials import MaterialTables, rotate_plane, rotate_shear


@dataclass(frozen=True)
class ShellSections:
    """Section data of n shell elements (element frame).

    Attributes
    ----------
    A, B, D : (n, 3, 3); S : (n, 2, 2) with ``shear_rigid`` (n,) True where the section has
    no transverse shear flexibility (PSHELL without MID3); rho_area, nsm : (n,) mass per area.
    """

    A: np.ndarray
    B: np.ndarray
    D: np.ndarray
    S: np.ndarray
    shear_rigid: np.ndarray
    rho_area: np.ndarray
    nsm: np.ndarray


def shell_sections(
    properties: dict[str, object],
    mats: MaterialTables,
    pids: np.ndarray,
    eids: np.ndarray,
    theta: np.ndarray,
    element_t: np.ndarray,
    tflag: np.ndarray,
    etype: str,
) -> ShellSections:
    """Sections of shell elements.

    Parameters
    ----------
    properties : ``Model.properties``.
    pids, eids : (n,) property and element ids.
    theta : (n,) material angle from the element x axis, degrees.
    element_t : (n, k) thicknesses T1..Tk from the element card (NaN where blank).
    tflag : (n,) TFLAG (INT_BLANK = 0).
    """
    n = len(pids)
    A = np.zeros((n, 3, 3))
    B = np.zeros((n, 3, 3))
    D = np.zeros((n, 3, 3))
    S = np.zeros((n, 2, 2))
    rigid = np.zeros(n, bool)
    rho_area = np.zeros(n)
    nsm = np.zeros(n)
    done = np.zeros(n, bool)
    pshell = properties.get("PSHELL")
    if pshell is not None:
        rows = IdIndex(pshell["pid"]).rows(pids)
        sel = np.flatnonzero(rows >= 0)
        if len(sel):
            _pshell(pshell, rows[sel], sel, mats, theta, element_t, tflag, eids, etype,
                    A, B, D, S, rigid, rho_area, nsm)  # fmt: skip
            done[sel] = True
    for card in ("PCOMP", "PCOMPG"):
        recs = {p.pid: p for p in properties.get(card, [])}
        for i in np.flatnonzero(~done):
            p = recs.get(int(pids[i]))
            if p is None:
                continue
            A[i], B[i], D[i], S[i], rho_area[i] = _laminate(p, mats, theta[i], etype, eids[i])
            # plies without transverse shear moduli (MAT8 G1Z/G2Z blank): NASTRAN leaves the
            # laminate shear-rigid, as a PSHELL without MID3
            rigid[i] = not S[i].any()
            nsm[i] = p.nsm
            done[i] = True
    if not done.all():
        bad = eids[~done][:20]
        raise ModelError(f"{etype} {bad.tolist()} have no PSHELL, PCOMP or PCOMPG", bad)
    return ShellSections(A, B, D, S, rigid, rho_area, nsm)


def _pshell(t, rows, sel, mats, theta, element_t, tflag, eids, etype,
            A, B, D, S, rigid, rho_area, nsm) -> None:  # fmt: skip
    T = t["t"][rows]
    et = element_t[sel]
    flag = np.where(tflag[sel] == INT_BLANK, 0, tflag[sel])
    nodal = np.where(np.isnan(et), T[:, None], np.where(flag[:, None] == 1, et * T[:, None], et))
    thick = nodal.mean(axis=1)
    bad = np.flatnonzero(~(thick > 0))
    if len(bad):
        raise ModelError(
            f"{etype} {eids[sel][bad][:20].tolist()}: no thickness (PSHELL T and element T1.. "
            "blank or not positive)",
            eids[sel][bad][:20],
        )
    mid1, mid2, mid3, mid4 = (t[k][rows] for k in ("mid1", "mid2", "mid3", "mid4"))
    if (mid2 == -1).any():
        raise ModelError(f"{etype}: PSHELL MID2 = -1 (plane strain) is not supported", [])
    if ((mid4 != INT_BLANK) & (mid4 > 0)).any():
        raise ModelError(f"{etype}: PSHELL MID4 (membrane-bending coupling) is not supported", [])
    th = theta[sel]
    has1 = (mid1 != INT_BLANK) & (mid1 > 0)
    has2 = (mid2 != INT_BLANK) & (mid2 > 0)
    has3 = (mid3 != INT_BLANK) & (mid3 > 0)
    if has1.any():
        m = mats.plane(mid1[has1], f"{etype} PSHELL MID1")
        A[sel[has1]] = thick[has1, None, None] * rotate_plane(m.Q, th[has1])
        rho_area[sel[has1]] = m.rho * thick[has1]
    if has2.any():
        m = mats.plane(mid2[has2], f"{etype} PSHELL MID2")
        bk = t["bk"][rows][has2]
        D[sel[has2]] = (bk * thick[has2] ** 3 / 12.0)[:, None, None] * rotate_plane(m.Q, th[has2])
        only2 = has2 & ~has1
        if only2.any():
            rho_area[sel[only2]] = m.rho[only2[has2]] * thick[only2]
    if has3.any():
        m = mats.plane(mid3[has3], f"{etype} PSHELL MID3")
        ts = t["tst"][rows][has3]
        S[sel[has3]] = (ts * thick[has3])[:, None, None] * rotate_shear(m.Gt, th[has3])
        # QRG MAT8 remark 2: G1Z and G2Z zero or blank is no transverse shear flexibility
        ids = [int(x) for x in np.unique(mid3[has3]) if mats.where(int(x))[0] == "MAT8"]
        mat8 = np.isin(mid3[has3], ids)
        has3[has3] = ~(mat8 & ~m.Gt.any(axis=(1, 2)))
    rigid[sel] = ~has3
    nsm[sel] = t["nsm"][rows]


def _laminate(p, mats: MaterialTables, theta: float, etype: str, eid: int):
    plies = list(p.plies)
    if p.lam == "SYM":
        plies = plies + plies[::-1]
    elif p.lam not in ("", "MEM", "BEND"):
        raise ModelError(f"PCOMP {p.pid}: LAM {p.lam} is not supported", [p.pid])
    t = np.array([q.t for q in plies])
    total = t.sum()
    z0 = -0.5 * total if np.isnan(p.z0) else p.z0
    z = z0 + np.concatenate([[0.0], np.cumsum(t)])
    m = mats.plane(np.array([q.mid for q in plies]), f"{etype} {eid} PCOMP {p.pid}")
    ang = np.array([q.theta for q in plies]) + theta
    Qb = rotate_plane(m.Q, ang)
    Gb = rotate_shear(m.Gt, ang)
    A = np.einsum("k,kij->ij", t, Qb)
    B = np.einsum("k,kij->ij", (z[1:] ** 2 - z[:-1] ** 2) / 2.0, Qb)
    D = np.einsum("k,kij->ij", (z[1:] ** 3 - z[:-1] ** 3) / 3.0, Qb)
    if p.lam == "MEM":
        B[:] = 0.0
        D[:] = 0.0
    elif p.lam == "BEND":
        A[:] = 0.0
        B[:] = 0.0
    S = 5.0 / 6.0 * np.einsum("k,kij->ij", t, Gb)
    return A, B, D, S, float((m.rho * t).sum())
