"""Cross-section properties of the PBARL / PBEAML section library (MSCBML0).

Dimensions follow the Quick Reference Guide's figures, with the element y axis along the
section's height for BAR and BOX (plane 1 bending, I1, uses the height). Returns A, I1, I2,
I12, J. Types not yet implemented raise ValueError naming them.
"""

from __future__ import annotations

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
    """(n, 2) shear factors K1, K2 of library sections (NaN: no shear flexibility)."""
    d = np.atleast_2d(np.asarray(dims, dtype=float))
    if kind in SHEAR_FACTORS:
        return np.tile(SHEAR_FACTORS[kind], (len(d), 1))
    if kind == "BOX":
        props = section_properties(kind, d)
        b, h, t1, t2 = d[:, 0], d[:, 1], d[:, 2], d[:, 3]
        # plane 1 (shear along y, the height): the side walls; plane 2: top and bottom
        return np.column_stack([2 * t2 * (h - 2 * t1), 2 * t1 * (b - 2 * t2)]) / props[:, :1]
    return np.full((len(d), 2), np.nan)


def section_properties(kind: str, dims: np.ndarray) -> np.ndarray:
    """Section properties of one library type.

    Parameters
    ----------
    kind : section type (``"ROD"``, ``"TUBE"``, ``"TUBE2"``, ``"BAR"``, ``"BOX"``).
    dims : (n, n_dims) dimensions (DIM1, DIM2, ...), deck units.

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
    else:
        raise ValueError(
            f"PBARL/PBEAML section type {kind} is not supported yet "
            "(supported: ROD, TUBE, TUBE2, BAR, BOX)"
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
