"""Structured shell and solid meshing for the bundled models.

Plates are meshed on station lines: a patch is the tensor grid of stations along two in-plane
directions. Nodes are shared through a registry keyed by position (0.01 mm), so patches that
meet on a common line of stations are joined without merging steps, and parts that must stay
apart (a rail and the liner nested in it) simply never share a position.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np


def stations(a: float, b: float, size: float, required: tuple[float, ...] = ()) -> np.ndarray:
    """Ascending stations from a to b, about ``size`` apart, through every required one.

    Each interval between consecutive fixed points (a, b and the required stations inside)
    is divided evenly into the fewest parts no longer than ``size``. Positions are rounded to
    0.01 (mm), which keeps every coordinate exact in an 8-character NASTRAN field.
    """
    lo, hi = min(a, b), max(a, b)
    fixed = sorted({round(lo, 2), round(hi, 2), *(round(r, 2) for r in required if lo < r < hi)})
    out = [fixed[0]]
    for p, q in itertools.pairwise(fixed):
        n = max(1, int(np.ceil((q - p) / size - 1e-9)))
        out += [round(p + (q - p) * k / n, 2) for k in range(1, n + 1)]
    s = np.array(out)
    return s if a <= b else s[::-1]


@dataclass
class Mesh:
    """Nodes, shells, solids and connectors of a model under construction (ids from 1)."""

    xyz: list[tuple[float, float, float]] = field(default_factory=list)
    quads: list[tuple[int, int, int, int, int]] = field(default_factory=list)  # pid, 4 grids
    trias: list[tuple[int, int, int, int]] = field(default_factory=list)  # pid, 3 grids
    hexas: list[tuple[int, ...]] = field(default_factory=list)  # pid, 8 grids
    _ids: dict[tuple[int, int, int], int] = field(default_factory=dict)

    def node(self, x: float, y: float, z: float) -> int:
        """Id of the node at (x, y, z), created if absent."""
        key = (round(x * 100), round(y * 100), round(z * 100))
        nid = self._ids.get(key)
        if nid is None:
            self.xyz.append((key[0] / 100, key[1] / 100, key[2] / 100))
            nid = len(self.xyz)
            self._ids[key] = nid
        return nid

    def find(self, x: float, y: float, z: float) -> int:
        """Id of the existing node at (x, y, z); KeyError if there is none."""
        return self._ids[(round(x * 100), round(y * 100), round(z * 100))]

    def patch(self, pid: int, origin, u, v, us: np.ndarray, vs: np.ndarray) -> np.ndarray:
        """Quadrilaterals on the grid ``origin + us[i] u + vs[j] v`` (u, v unit vectors);
        element normals along u x v. Returns the node ids (len(us), len(vs))."""
        o, u, v = (np.asarray(a, float) for a in (origin, u, v))
        ids = np.array([[self.node(*(o + a * u + b * v)) for b in vs] for a in us])
        for i in range(len(us) - 1):
            for j in range(len(vs) - 1):
                self.quads.append((pid, ids[i, j], ids[i + 1, j], ids[i + 1, j + 1], ids[i, j + 1]))
        return ids

    def triangle_patch(self, pid: int, origin, u, v, n: int, a: float, b: float) -> None:
        """A right-triangle plate with legs ``a`` along u and ``b`` along v, meshed in n rows:
        quadrilaterals, and a CTRIA3 at the end of each row along the hypotenuse."""
        o, u, v = (np.asarray(p, float) for p in (origin, u, v))

        def nd(i: int, j: int) -> int:  # i along u (0..n), j along v (0..n - i)
            return self.node(*(o + (a * i / n) * u + (b * j / n) * v))

        for i in range(n):
            for j in range(n - i - 1):
                self.quads.append((pid, nd(i, j), nd(i + 1, j), nd(i + 1, j + 1), nd(i, j + 1)))
            j = n - i - 1
            self.trias.append((pid, nd(i, j), nd(i + 1, j), nd(i, j + 1)))

    def block(self, pid: int, xs: np.ndarray, ys: np.ndarray, zs: np.ndarray) -> None:
        """CHEXA on the axis-aligned grid xs x ys x zs (ascending)."""
        for i in range(len(xs) - 1):
            for j in range(len(ys) - 1):
                for k in range(len(zs) - 1):
                    c = [
                        (xs[i], ys[j]),
                        (xs[i + 1], ys[j]),
                        (xs[i + 1], ys[j + 1]),
                        (xs[i], ys[j + 1]),
                    ]
                    bottom = [self.node(x, y, zs[k]) for x, y in c]
                    top = [self.node(x, y, zs[k + 1]) for x, y in c]
                    self.hexas.append((pid, *bottom, *top))

    def near(self, centre, radius: float, normal) -> list[int]:
        """Existing nodes within ``radius`` of ``centre`` in the plane through it normal to
        ``normal`` (within 0.01), the centre itself excluded, ascending."""
        c = np.asarray(centre, float)
        nrm = np.asarray(normal, float) / np.linalg.norm(normal)
        X = np.asarray(self.xyz)
        d = X - c
        off = d @ nrm
        inplane = np.linalg.norm(d - off[:, None] * nrm, axis=1)
        hit = np.flatnonzero((np.abs(off) < 0.01) & (inplane < radius) & (inplane > 0.01))
        return (hit + 1).tolist()
