"""Line-element properties -> the section inputs of the rod, bar, beam and bush kernels.

PROD, PTUBE and CONROD give a rod's area and torsion constant; PBAR and PBARL a bar's
section (A, I1, I2, I12, J), shear factors K1/K2 and non-structural mass; PBEAM and PBEAML
a beam's section along its length, interpolated linearly between the stations as NASTRAN
does (PBEAML through the section properties at its stations, as NASTRAN turns it into a
PBEAM); PBUSH a bush's six stiffnesses.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from ..model.ids import IdIndex
from ..model.model import ElementBlock, Model
from .sections import section_properties, shear_factors


def property_rows(model: Model, card: str, block: ElementBlock) -> tuple[dict, np.ndarray]:
    """(the model's ``card`` table, the row of each element's PID in it, -1 where absent)."""
    table = model.properties[card]
    return table, IdIndex(table["pid"]).rows(block.pids)


@dataclass(frozen=True)
class RodSections:
    """Rods (CROD, CONROD, CTUBE): material ids, area, torsion constant and non-structural
    mass per length, each (n,)."""

    mids: np.ndarray
    area: np.ndarray
    torsion: np.ndarray
    nsm: np.ndarray


def rod_sections(model: Model, block: ElementBlock) -> RodSections:
    """The sections of a CONROD (its own fields), CROD (PROD) or CTUBE (PTUBE; a tapered
    tube takes its mean diameter) block."""
    if block.type == "CONROD":
        d = block.data
        return RodSections(d["mid"], d["a"], d["j"], d["nsm"])
    if block.type == "CROD":
        t, rows = property_rows(model, "PROD", block)
        return RodSections(t["mid"][rows], t["a"][rows], t["j"][rows], t["nsm"][rows])
    t, rows = property_rows(model, "PTUBE", block)
    od, wall, nsm = t["od"][rows], t["t"][rows], t["nsm"][rows]
    od2 = t["od2"][rows]
    od = np.where(np.isnan(od2), od, 0.5 * (od + od2))
    # QRG PTUBE: T blank is OD/2; remark 1, a T of zero is a solid circular rod
    wall = np.where(np.isnan(wall) | (wall == 0), od / 2.0, wall)
    di = od - 2.0 * wall
    return RodSections(t["mid"][rows], np.pi * (od**2 - di**2) / 4.0,
                       np.pi * (od**4 - di**4) / 32.0, nsm)  # fmt: skip


@dataclass(frozen=True)
class BarSections:
    """Uniform bars (CBAR): ``section`` (n, 5) = A, I1, I2, I12, J; shear factors ``k1``,
    ``k2`` (n,) (NaN: no shear flexibility); material ids and non-structural mass per
    length (n,)."""

    section: np.ndarray
    k1: np.ndarray
    k2: np.ndarray
    mids: np.ndarray
    nsm: np.ndarray


def bar_sections(model: Model, block: ElementBlock) -> BarSections:
    """The sections of a CBAR block from PBAR and PBARL.

    Raises
    ------
    ModelError
        Naming the elements without a PBAR/PBARL, or a PBARL whose dimensions give no
        section.
    """
    n = len(block)
    section = np.zeros((n, 5))
    k1 = np.full(n, np.nan)
    k2 = np.full(n, np.nan)
    mids = np.zeros(n, np.int64)
    nsm = np.zeros(n)
    done = np.zeros(n, bool)
    if "PBAR" in model.properties:
        t, rows = property_rows(model, "PBAR", block)
        sel = rows >= 0
        r = rows[sel]
        section[sel] = np.column_stack([t["a"][r], t["i1"][r], t["i2"][r], t["i12"][r], t["j"][r]])
        k1[sel], k2[sel] = t["k1"][r], t["k2"][r]
        mids[sel], nsm[sel] = t["mid"][r], t["nsm"][r]
        done |= sel
    if "PBARL" in model.properties:
        recs = {p.pid: p for p in model.properties["PBARL"]}
        for i in np.flatnonzero(~done):
            p = recs.get(int(block.pids[i]))
            if p is None:
                continue
            section[i] = _section(p.type, p.dims, block, i)
            k1[i], k2[i] = shear_factors(p.type, p.dims)[0]
            mids[i], nsm[i] = p.mid, p.nsm
            done[i] = True
    _all_done(done, block, "PBAR or PBARL")
    # QRG PBAR remarks: K1 and K2 are ignored if I12 is not 0 (the bar then has no transverse
    # shear flexibility); a PBARL is the PBAR of its section, an L's I12 included
    coupled = section[:, 3] != 0
    k1[coupled], k2[coupled] = np.nan, np.nan
    return BarSections(section, k1, k2, mids, nsm)


@dataclass(frozen=True)
class BeamSections:
    """Beams (CBEAM) along their length.

    Attributes
    ----------
    section : (n, q, 5) A, I1, I2, I12, J at the mass stations (q of them).
    section_k : (n, qk, 5) the same at the flexibility stations.
    k1, k2 : (n,) shear factors.
    mids : (n,) material ids.
    nsm, nsi : (n, q) non-structural mass and its polar inertia per length at the mass
        stations.
    """

    section: np.ndarray
    section_k: np.ndarray
    k1: np.ndarray
    k2: np.ndarray
    mids: np.ndarray
    nsm: np.ndarray
    nsi: np.ndarray


def beam_sections(model: Model, block: ElementBlock, mass_x: np.ndarray,
                  flex_x: np.ndarray) -> BeamSections:  # fmt: skip
    """The sections of a CBEAM block from PBEAM and PBEAML at the stations ``mass_x`` and
    ``flex_x`` (fractions of the length from end A).

    Raises
    ------
    ModelError
        As :func:`bar_sections`.
    """
    n = len(block)
    q = len(mass_x)
    section = np.zeros((n, q, 5))
    section_k = np.zeros((n, len(flex_x), 5))
    k1 = np.ones(n)
    k2 = np.ones(n)
    mids = np.zeros(n, np.int64)
    nsm = np.zeros((n, q))
    nsi = np.zeros((n, q))
    done = np.zeros(n, bool)
    pbeam = {p.pid: p for p in model.properties.get("PBEAM", [])}
    pbeaml = {p.pid: p for p in model.properties.get("PBEAML", [])}
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
                for x in (mass_x, flex_x)
            )
            nsm[i] = np.interp(mass_x, xs, ns)
            k1[i], k2[i] = p.tail_value("k1"), p.tail_value("k2")
            nsi_a, nsi_b = p.tail_value("nsi_a"), p.tail_value("nsi_b")
            nsi[i] = nsi_a + ((nsi_a if np.isnan(nsi_b) else nsi_b) - nsi_a) * mass_x
            mids[i] = p.mid
        elif pid in pbeaml:
            p = pbeaml[pid]
            xs = np.array([s.x for s in p.stations])
            dims = np.array([s.dims for s in p.stations])
            ns = np.array([s.nsm for s in p.stations])
            if len(xs) == 1:
                xs, dims, ns = np.array([0.0, 1.0]), np.vstack([dims, dims]), np.r_[ns, ns]
            props = _section(p.type, dims, block, i)
            section[i], section_k[i] = (
                np.column_stack([np.interp(x, xs, props[:, c]) for c in range(5)])
                for x in (mass_x, flex_x)
            )
            k1[i], k2[i] = shear_factors(p.type, dims).mean(axis=0)
            nsm[i] = np.interp(mass_x, xs, ns)
            mids[i] = p.mid
        else:
            continue
        done[i] = True
    _all_done(done, block, "PBEAM or PBEAML")
    return BeamSections(section, section_k, k1, k2, mids, nsm, nsi)


def bush_stiffness(model: Model, block: ElementBlock) -> np.ndarray:
    """(n, 6) stiffnesses K1-K6 of a CBUSH block from PBUSH.

    Raises
    ------
    ModelError
        For an element without its PBUSH, or a PBUSH with a mass (not supported).
    """
    recs = {p.pid: p for p in model.properties.get("PBUSH", [])}
    k = np.zeros((len(block), 6))
    for i in range(len(block)):
        p = recs.get(int(block.pids[i]))
        if p is None:
            raise ModelError(
                f"CBUSH {block.ids[i]} has no PBUSH {block.pids[i]}", [int(block.ids[i])]
            )
        if p.mass:
            raise ModelError(f"PBUSH {p.pid}: M (bush mass) is not supported yet", [p.pid])
        k[i] = p.k
    return k


def _section(kind: str, dims, block: ElementBlock, i: int) -> np.ndarray:
    try:
        props = section_properties(kind, np.atleast_2d(dims))
    except ValueError as e:
        raise ModelError(f"{block.type} {block.ids[i]}: {e}", [int(block.ids[i])]) from None
    return props if np.ndim(dims) == 2 and len(dims) > 1 else props[0]


def _all_done(done: np.ndarray, block: ElementBlock, what: str) -> None:
    if not done.all():
        bad = block.ids[~done][:20]
        raise ModelError(f"{block.type} {bad.tolist()} have no {what} property", bad)
