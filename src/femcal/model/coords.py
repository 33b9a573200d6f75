"""Coordinate systems: CORD1R/C/S and CORD2R/C/S resolved to the basic frame.

Conventions
-----------
A system is ``(kind, origin, T)``: ``kind`` is ``"R"``, ``"C"`` or ``"S"``; ``origin`` (3,)
in basic; ``T`` (3, 3) whose *columns* are the system's unit axes in basic, so a point whose
rectangular local coordinates are ``q`` sits at ``origin + T @ q``.

Local coordinates: R ``(x, y, z)``; C ``(r, theta_deg, z)``; S ``(r, theta_deg, phi_deg)``
with theta measured from the local z axis and phi in the xy plane from x (NASTRAN).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class CoordSystem:
    """One resolved coordinate system (see module docstring)."""

    cid: int
    kind: str
    origin: np.ndarray  # (3,)
    T: np.ndarray  # (3, 3) columns = axes in basic


BASIC = CoordSystem(0, "R", np.zeros(3), np.eye(3))


def to_rectangular(kind: str, p: np.ndarray) -> np.ndarray:
    """Local coordinates (n, 3) of a ``kind`` system -> rectangular local coordinates (n, 3)."""
    p = np.asarray(p, dtype=float)
    if kind == "R":
        return p.copy()
    if kind == "C":
        r, th, z = p[:, 0], np.radians(p[:, 1]), p[:, 2]
        return np.column_stack([r * np.cos(th), r * np.sin(th), z])
    if kind == "S":
        r, th, ph = p[:, 0], np.radians(p[:, 1]), np.radians(p[:, 2])
        st = np.sin(th)
        return np.column_stack([r * st * np.cos(ph), r * st * np.sin(ph), r * np.cos(th)])
    raise ValueError(f"unknown coordinate system kind {kind!r}")


def to_basic(cs: CoordSystem, p: np.ndarray) -> np.ndarray:
    """Points (n, 3) given in system ``cs`` -> basic coordinates (n, 3)."""
    return cs.origin + to_rectangular(cs.kind, p) @ cs.T.T


def axes_from_points(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray | None:
    """Axes (3, 3) (columns x, y, z) from origin A, a point B on z and C in the xz plane.

    Returns None when the points do not define a system (A = B, or C on the z axis).
    """
    z = b - a
    nz = np.linalg.norm(z)
    if nz == 0.0:
        return None
    z = z / nz
    y = np.cross(z, c - a)
    ny = np.linalg.norm(y)
    if ny <= 1e-12 * max(nz, np.linalg.norm(c - a), 1e-300):
        return None
    y = y / ny
    x = np.cross(y, z)
    return np.column_stack([x, y, z])


def displacement_frames(cs: CoordSystem, xyz: np.ndarray) -> np.ndarray:
    """Displacement frames (n, 3, 3) of system ``cs`` at basic points ``xyz`` (n, 3).

    Columns are the unit directions of components 1, 2, 3 in basic: (x, y, z) for R,
    (r, theta, z) for C and (r, theta, phi) for S, evaluated at each point. At a point on
    the axis (or the origin), the angle is taken as 0.
    """
    n = len(xyz)
    if cs.kind == "R":
        return np.broadcast_to(cs.T, (n, 3, 3)).copy()
    q = (xyz - cs.origin) @ cs.T  # local rectangular
    local = np.zeros((n, 3, 3))
    if cs.kind == "C":
        th = np.arctan2(q[:, 1], q[:, 0])
        c, s = np.cos(th), np.sin(th)
        local[:, 0, 0], local[:, 1, 0] = c, s
        local[:, 0, 1], local[:, 1, 1] = -s, c
        local[:, 2, 2] = 1.0
    else:
        rxy = np.hypot(q[:, 0], q[:, 1])
        th = np.arctan2(rxy, q[:, 2])
        ph = np.arctan2(q[:, 1], q[:, 0])
        st, ct, sp, cp = np.sin(th), np.cos(th), np.sin(ph), np.cos(ph)
        local[:, :, 0] = np.column_stack([st * cp, st * sp, ct])
        local[:, :, 1] = np.column_stack([ct * cp, ct * sp, -st])
        local[:, :, 2] = np.column_stack([-sp, cp, np.zeros(n)])
    return np.einsum("ij,njk->nik", cs.T, local)
