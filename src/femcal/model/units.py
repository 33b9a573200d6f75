"""The model's units, as far as its cards tell them (NASTRAN decks carry none)."""

from __future__ import annotations

import numpy as np

from .model import Model


def length_unit(model: Model) -> str | None:
    """``mm`` (mm, tonne, s, N, MPa) or ``m`` (SI) as the model's MAT1 cards say, None when
    they do not tell: the speed of sound sqrt(E / RHO) of each material with a density must
    be a structural material's (1-12 km/s) in that length unit, and E a modulus in N per
    its square (0.1 GPa to 1 TPa); PARAM WTMASS other than 1 changes the mass unit."""
    mats = model.materials.get("MAT1")
    if not isinstance(mats, dict) or model.params.wtmass != 1.0:
        return None
    e, rho = np.asarray(mats["e"], float), np.asarray(mats["rho"], float)
    ok = np.isfinite(e) & np.isfinite(rho) & (e > 0) & (rho > 0)
    if not ok.any():
        return None
    speed, modulus = np.sqrt(e[ok] / rho[ok]), e[ok]
    for unit, metres in (("mm", 1e-3), ("m", 1.0)):
        c = speed * metres
        pa = modulus / metres**2
        if ((c >= 1e3) & (c <= 1.2e4) & (pa >= 1e8) & (pa <= 1e12)).all():
            return unit
    return None


def element_unit(length: str | None, kind: str) -> str:
    """The unit of an element's size in the model's unit system (``length`` from
    :func:`length_unit`): ``kind`` ``"translation"`` (a spring's force per length),
    ``"rotation"`` (moment per radian) or ``"mass"``; "" when the length unit is unknown."""
    force_length = {"mm": ("N", "mm", "t"), "m": ("N", "m", "kg")}.get(length or "")
    if force_length is None:
        return ""
    force, metre, mass = force_length
    return {"translation": f"{force}/{metre}", "rotation": f"{force} {metre}/rad",
            "mass": mass}[kind]
