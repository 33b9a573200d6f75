"""Cross-section properties of the PBARL / PBEAML section library (MSCBML0).

Dimensions follow the Quick Reference Guide's figures, with the element y axis along the
section's height (up in the figures) and z across it, for every type. Returns A, I1, I2, I12,
J: I1 = integral of y^2 dA (plane-1 bending), I2 = integral of z^2 dA, I12 = integral of
y z dA, all about the centroid; J the Saint-Venant torsion constant. Types not yet
implemented raise ValueError naming them.

ROD, TUBE, TUBE2, BAR and BOX have closed forms below. The other types (``_SHAPES``) are
unions of non-overlapping rectangles placed as the QRG figure places the dimensions (z to the
right, y up), and A, I1, I2, I12 come exactly from the rectangles (``_rectangle_moments``).
Where the figure could be drawn either way round, the placement follows pyNastran's and
sectionproperties' renderings of the same figures:

- L: the corner at the origin, the DIM3-thick leg along +z, the DIM4-thick leg along +y,
  so I12 < 0 (the MSC Reference Manual's I12 formula for L, as quoted in pyNastran, also
  measures both legs' offsets as positive and gives I12 < 0).
- Z: the top flange points to -z and the bottom flange to +z, so I12 < 0.
- T1: the DIM2 x DIM4 arm points to -z from the DIM1 x DIM3 upright.
- CHAN, CHAN1: web at the left, flanges to +z; CHAN2 opens upwards (+y); HAT's crown is at
  the top and its feet at the bottom.
- BOX1: DIM3 top, DIM4 bottom, DIM5 the right (+z) wall, DIM6 the left wall; I12 is not zero
  when the walls differ on both axes.

J of the open sections is the thin-walled sum of b t^3 / 3 over the walls with each wall's
length b taken on the mid-line (to the mid-line of the wall it meets; free ends at the edge).
This is the formula the MSC Nastran Reference Manual's beam library gives for I, L, CHAN and
T (as quoted in pyNastran's bars.py: e.g. I: (b tb^3 + a ta^3 + (h - (ta + tb)/2) tw^3)/3,
T: (d tf^3 + (h - tf/2) tw^3)/3); the same rule is used for the other open types, where
NASTRAN's own choice is not known (MYSTRAN, e.g., takes the clear lengths for CROSS and H,
and (DIM1 - DIM4) DIM3^3 + DIM2 DIM4^3 for T2; all agree as the walls get thin).
BOX1 uses Bredt-Batho on the wall mid-lines, like BOX.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

#: Transverse shear factors K1, K2 NASTRAN gives library sections (K A G). ROD and BAR are
#: matched to NASTRAN runs (refdecks pyn_satk_bar, pyn_cbush_sol111: ROD; ekm_cbar_suport:
#: BAR); TUBE (thin-walled value 1/2) and BOX (wall-area fractions, see shear_factors) are
#: textbook values not yet confirmed by a NASTRAN run.
SHEAR_FACTORS = {
    "ROD": (0.9, 0.9),
    "BAR": (5.0 / 6.0, 5.0 / 6.0),
    "TUBE": (0.5, 0.5),
    "TUBE2": (0.5, 0.5),
}


def shear_factors(kind: str, dims: np.ndarray) -> np.ndarray:
    """(n, 2) shear factors K1, K2 of library sections (NaN: no shear flexibility).

    ROD and BAR are NASTRAN's values (matched by runs). All the others are textbook values
    not confirmed by a NASTRAN run: TUBE, TUBE2 1/2; BOX and every type in ``_SHAPES`` the
    wall-area fractions, K1 = (area of the walls along y) / A for shear along y (plane 1) and
    K2 = (area of the walls along z) / A for shear along z (plane 2), each wall counted
    without the junction it shares with a wall of the other direction (BOX: side walls
    2 t2 (h - 2 t1); I: web DIM4 (DIM1 - DIM5 - DIM6)). For L and CHAN these are the K1, K2
    of the MSC Reference Manual's beam library (as quoted in pyNastran's bars.py).
    """
    d = np.atleast_2d(np.asarray(dims, dtype=float))
    if kind in SHEAR_FACTORS:
        return np.tile(SHEAR_FACTORS[kind], (len(d), 1))
    if kind == "BOX":
        props = section_properties(kind, d)
        b, h, t1, t2 = d[:, 0], d[:, 1], d[:, 2], d[:, 3]
        # plane 1 (shear along y, the height): the side walls; plane 2: top and bottom
        return np.column_stack([2 * t2 * (h - 2 * t1), 2 * t1 * (b - 2 * t2)]) / props[:, :1]
    if kind in _SHAPES:
        shape = _shape(kind, d)
        area = _rectangle_moments(shape.rects)[0]
        return np.column_stack([shape.shear1, shape.shear2]) / area[:, None]
    return np.full((len(d), 2), np.nan)


def section_properties(kind: str, dims: np.ndarray) -> np.ndarray:
    """Section properties of one library type.

    Parameters
    ----------
    kind : section type: ``ROD``, ``TUBE``, ``TUBE2``, ``BAR``, ``BOX`` or one of
        ``_SHAPES`` (``I``, ``I1``, ``CHAN``, ``CHAN1``, ``CHAN2``, ``T``, ``T1``, ``T2``,
        ``L``, ``H``, ``Z``, ``CROSS``, ``HAT``, ``BOX1``).
    dims : (n, n_dims) dimensions (DIM1, DIM2, ...), the model's length unit.

    Returns
    -------
    (n, 5) columns A, I1, I2, I12, J.
    """
    d = np.atleast_2d(np.asarray(dims, dtype=float))
    n = len(d)
    out = np.zeros((n, 5))
    if kind == "ROD":
        r = d[:, 0]
        out[:, 0] = np.pi * r**2
        out[:, 1] = out[:, 2] = np.pi * r**4 / 4.0
        out[:, 4] = np.pi * r**4 / 2.0
    elif kind in ("TUBE", "TUBE2"):
        ro = d[:, 0]
        ri = d[:, 1] if kind == "TUBE" else d[:, 0] - d[:, 1]
        _require(kind, ri < ro, "inner radius below outer radius")
        out[:, 0] = np.pi * (ro**2 - ri**2)
        out[:, 1] = out[:, 2] = np.pi * (ro**4 - ri**4) / 4.0
        out[:, 4] = np.pi * (ro**4 - ri**4) / 2.0
    elif kind == "BAR":
        b, h = d[:, 0], d[:, 1]
        out[:, 0] = b * h
        out[:, 1] = b * h**3 / 12.0
        out[:, 2] = h * b**3 / 12.0
        out[:, 4] = _rectangle_torsion(b, h)
    elif kind == "BOX":
        b, h, t1, t2 = d[:, 0], d[:, 1], d[:, 2], d[:, 3]
        hi, bi = h - 2.0 * t1, b - 2.0 * t2
        _require(kind, (hi > 0) & (bi > 0), "walls thinner than half the width and height")
        out[:, 0] = b * h - bi * hi
        out[:, 1] = (b * h**3 - bi * hi**3) / 12.0
        out[:, 2] = (h * b**3 - hi * bi**3) / 12.0
        # Bredt-Batho for the thin-walled closed section, on the wall mid-lines.
        bm, hm = b - t2, h - t1
        out[:, 4] = 2.0 * (bm * hm) ** 2 / (bm / t1 + hm / t2)
    elif kind in _SHAPES:
        shape = _shape(kind, d)
        out[:, :4] = np.column_stack(_rectangle_moments(shape.rects))
        if kind not in _ASYMMETRIC:
            out[:, 3] = 0.0  # an axis of symmetry: exactly zero, not rounding noise
        out[:, 4] = shape.torsion
    else:
        raise ValueError(
            f"PBARL/PBEAML section type {kind} is not supported yet "
            f"(supported: ROD, TUBE, TUBE2, BAR, BOX, {', '.join(_SHAPES)})"
        )
    return out


def _rectangle_torsion(b: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Saint-Venant torsion constant of a b x h rectangle (Roark's series approximation)."""
    a = np.maximum(b, h)
    c = np.minimum(b, h)
    return a * c**3 * (1.0 / 3.0 - 0.21 * (c / a) * (1.0 - c**4 / (12.0 * a**4)))


def _require(kind: str, ok: np.ndarray, what: str) -> None:
    bad = np.flatnonzero(~ok)
    if len(bad):
        raise ValueError(f"{kind} section needs {what} (entries {bad[:20].tolist()})")


# ------------------------------------------------------------- sections made of rectangles

#: A rectangle z0 <= z <= z1, y0 <= y <= y1 of the section, each bound an (n,) array.
Rect = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]


class _Shape(NamedTuple):
    """One library type for n sets of dimensions."""

    rects: list[Rect]  # non-overlapping rectangles making up the section
    torsion: np.ndarray  # (n,) J
    shear1: np.ndarray  # (n,) area of the walls along y (shear along y, plane 1)
    shear2: np.ndarray  # (n,) area of the walls along z (shear along z, plane 2)


def _rectangle_moments(
    rects: list[Rect],
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A, I1 (y^2), I2 (z^2), I12 (y z) about the centroid of a union of rectangles."""
    z0, z1, y0, y1 = (np.stack([r[k] for r in rects], axis=1) for k in range(4))
    b, h = z1 - z0, y1 - y0
    a = b * h
    area = a.sum(axis=1)
    zc, yc = 0.5 * (z0 + z1), 0.5 * (y0 + y1)
    dz = zc - (a * zc).sum(axis=1, keepdims=True) / area[:, None]
    dy = yc - (a * yc).sum(axis=1, keepdims=True) / area[:, None]
    i1 = (b * h**3 / 12.0 + a * dy**2).sum(axis=1)
    i2 = (h * b**3 / 12.0 + a * dz**2).sum(axis=1)
    i12 = (a * dy * dz).sum(axis=1)
    return area, i1, i2, i12


def _open_torsion(*walls: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """Thin-walled open-section J: sum of b t^3 / 3 over (mid-line length b, thickness t)."""
    return sum(b * t**3 for b, t in walls) / 3.0


#: Number of dimensions of each rectangle-built type.
_SHAPES = {
    "I": 6, "I1": 4, "CHAN": 4, "CHAN1": 4, "CHAN2": 4, "T": 4, "T1": 4, "T2": 4, "L": 4,
    "H": 4, "Z": 4, "CROSS": 4, "HAT": 4, "BOX1": 6,
}  # fmt: skip

#: Types without an axis of symmetry along y or z (I12 generally not zero).
_ASYMMETRIC = {"L", "Z", "BOX1"}


def _shape(kind: str, d: np.ndarray) -> _Shape:
    """Rectangles, J and shear areas of a ``_SHAPES`` type for dims d (n, >= n_dims)."""
    need = _SHAPES[kind]
    if d.ndim != 2 or d.shape[1] < need:
        raise ValueError(f"{kind} section needs {need} dimensions DIM1..DIM{need}")
    D = [d[:, k] for k in range(need)]
    _require(kind, np.all(d[:, :need] > 0, axis=1), "all dimensions positive")
    zero = np.zeros(len(d))
    if kind == "I":
        h, wb, wt, tw, tb, tt = D  # height, bottom/top flange widths, web, bottom/top flange t
        _require(kind, tb + tt < h, "flange thicknesses DIM5 + DIM6 below the height DIM1")
        _require(kind, (tw < wb) & (tw < wt), "web DIM4 thinner than the flanges DIM2, DIM3")
        rects = [
            (-wb / 2, wb / 2, zero, tb),
            (-tw / 2, tw / 2, tb, h - tt),
            (-wt / 2, wt / 2, h - tt, h),
        ]
        J = _open_torsion((wb, tb), (wt, tt), (h - (tb + tt) / 2, tw))
        s1, s2 = tw * (h - tb - tt), (wb - tw) * tb + (wt - tw) * tt
    elif kind in ("I1", "CHAN1", "Z"):
        # flange outstand(s), web thickness, web clear height, overall height
        b, tw, hw, h = D
        _require(kind, hw < h, "web clear height DIM3 below the height DIM4")
        tf = (h - hw) / 2
        if kind == "I1":  # DIM1 is the sum of both outstands, half on each side
            w = b + tw
            rects = [
                (-w / 2, w / 2, -h / 2, -hw / 2),
                (-tw / 2, tw / 2, -hw / 2, hw / 2),
                (-w / 2, w / 2, hw / 2, h / 2),
            ]
            flange = w
        elif kind == "CHAN1":  # web at the left, flanges to +z
            rects = [
                (zero, tw, -h / 2, h / 2),
                (tw, tw + b, -h / 2, -hw / 2),
                (tw, tw + b, hw / 2, h / 2),
            ]
            flange = b + tw / 2
        else:  # Z: top flange to -z, bottom flange to +z
            rects = [
                (-tw / 2, tw / 2, -h / 2, h / 2),
                (-tw / 2 - b, -tw / 2, hw / 2, h / 2),
                (tw / 2, tw / 2 + b, -h / 2, -hw / 2),
            ]
            flange = b + tw / 2
        J = _open_torsion((flange, tf), (flange, tf), (h - tf, tw))
        s1, s2 = tw * hw, b * (h - hw)
    elif kind == "CHAN":
        b, h, tw, tf = D  # overall width, height, web thickness, flange thickness
        _require(kind, 2 * tf < h, "flanges 2 DIM4 thinner than the height DIM2")
        _require(kind, tw < b, "web DIM3 thinner than the width DIM1")
        rects = [(zero, tw, zero, h), (tw, b, zero, tf), (tw, b, h - tf, h)]
        J = _open_torsion((b - tw / 2, tf), (b - tw / 2, tf), (h - tf, tw))
        s1, s2 = tw * (h - 2 * tf), 2 * tf * (b - tw)
    elif kind == "CHAN2":
        tl, tb, h, b = D  # leg thickness, base thickness, height, width; opens upwards
        _require(kind, 2 * tl < b, "legs 2 DIM1 thinner than the width DIM4")
        _require(kind, tb < h, "base DIM2 thinner than the height DIM3")
        rects = [
            (-b / 2, b / 2, zero, tb),
            (-b / 2, -b / 2 + tl, tb, h),
            (b / 2 - tl, b / 2, tb, h),
        ]
        J = _open_torsion((h - tb / 2, tl), (h - tb / 2, tl), (b - tl, tb))
        s1, s2 = 2 * tl * (h - tb), tb * (b - 2 * tl)
    elif kind in ("T", "T2"):
        b, h, tf, tw = D  # flange width, height, flange thickness, web thickness
        _require(kind, tf < h, "flange DIM3 thinner than the height DIM2")
        _require(kind, tw < b, "web DIM4 thinner than the flange width DIM1")
        if kind == "T":  # flange at the top
            rects = [(-tw / 2, tw / 2, zero, h - tf), (-b / 2, b / 2, h - tf, h)]
        else:  # T2: flange at the bottom
            rects = [(-b / 2, b / 2, zero, tf), (-tw / 2, tw / 2, tf, h)]
        J = _open_torsion((b, tf), (h - tf / 2, tw))
        s1, s2 = tw * (h - tf), (b - tw) * tf
    elif kind == "T1":
        h, b, tu, ta = D  # upright height, arm length, upright thickness, arm thickness
        _require(kind, ta < h, "arm DIM4 thinner than the height DIM1")
        rects = [(zero, tu, -h / 2, h / 2), (-b, zero, -ta / 2, ta / 2)]
        J = _open_torsion((h, tu), (b + tu / 2, ta))
        s1, s2 = tu * (h - ta), b * ta
    elif kind == "L":
        b, h, th, tv = D  # width, height, horizontal leg thickness, vertical leg thickness
        _require(kind, th < h, "horizontal leg DIM3 thinner than the height DIM2")
        _require(kind, tv < b, "vertical leg DIM4 thinner than the width DIM1")
        rects = [(zero, b, zero, th), (zero, tv, th, h)]
        J = _open_torsion((b - tv / 2, th), (h - th / 2, tv))
        s1, s2 = tv * (h - th), (b - tv) * th
    elif kind == "H":
        bw, t2f, h, tw = D  # web clear length, both flange thicknesses, height, web thickness
        _require(kind, tw < h, "web DIM4 thinner than the height DIM3")
        tf = t2f / 2
        rects = [
            (-bw / 2 - tf, -bw / 2, -h / 2, h / 2),
            (bw / 2, bw / 2 + tf, -h / 2, h / 2),
            (-bw / 2, bw / 2, -tw / 2, tw / 2),
        ]
        J = _open_torsion((h, tf), (h, tf), (bw + tf, tw))
        s1, s2 = t2f * (h - tw), bw * tw
    elif kind == "CROSS":
        b, tv, h, th = D  # both arm lengths, upright thickness, height, arm thickness
        _require(kind, th < h, "arms DIM4 thinner than the height DIM3")
        rects = [
            (-tv / 2, tv / 2, -h / 2, h / 2),
            (-tv / 2 - b / 2, -tv / 2, -th / 2, th / 2),
            (tv / 2, tv / 2 + b / 2, -th / 2, th / 2),
        ]
        J = _open_torsion((h, tv), (b + tv, th))
        s1, s2 = tv * (h - th), b * th
    elif kind == "HAT":
        h, t, w, f = D  # height, wall thickness, crown width (outside), foot length
        _require(kind, 2 * t < h, "walls 2 DIM2 thinner than the height DIM1")
        _require(kind, 2 * t < w, "walls 2 DIM2 thinner than the crown width DIM3")
        rects = [
            (-w / 2, w / 2, h - t, h),  # crown
            (-w / 2, -w / 2 + t, zero, h - t),  # legs
            (w / 2 - t, w / 2, zero, h - t),
            (-w / 2 - f, -w / 2, zero, t),  # feet
            (w / 2, w / 2 + f, zero, t),
        ]
        J = _open_torsion((w - t, t), (h - t, t), (h - t, t), (f + t / 2, t), (f + t / 2, t))
        s1, s2 = 2 * t * (h - 2 * t), t * (w - 2 * t + 2 * f)
    elif kind == "BOX1":
        b, h, tt, tb, tr, tl = D  # width, height, top, bottom, right (+z), left walls
        _require(kind, tt + tb < h, "top and bottom walls DIM3 + DIM4 below the height DIM2")
        _require(kind, tr + tl < b, "side walls DIM5 + DIM6 below the width DIM1")
        rects = [
            (zero, tl, zero, h),
            (b - tr, b, zero, h),
            (tl, b - tr, zero, tb),
            (tl, b - tr, h - tt, h),
        ]
        # Bredt-Batho for the thin-walled closed section, on the wall mid-lines.
        bm, hm = b - (tl + tr) / 2, h - (tt + tb) / 2
        J = 4.0 * (bm * hm) ** 2 / (hm * (1 / tl + 1 / tr) + bm * (1 / tt + 1 / tb))
        s1, s2 = (tl + tr) * (h - tt - tb), (tt + tb) * (b - tl - tr)
    else:  # pragma: no cover - _SHAPES and the branches above list the same types
        raise AssertionError(kind)
    return _Shape(rects, np.asarray(J, dtype=float), s1, s2)
