"""Two identifications of the same FRFs side by side (e.g. pLSCF and the subspace method):
their modes paired, nearest in frequency first, with the difference in frequency and
damping and the MAC of their shapes."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..correlate.shapes import mac
from .workflow import IdentifiedModel


@dataclass(frozen=True)
class ModePair:
    """One row: a mode of the first model, of the second, or both (indices 0-based, None
    where the other has no mode within ``tolerance`` of it)."""

    first: int | None
    second: int | None
    frequency_hz: tuple[float | None, float | None]
    damping_ratio: tuple[float | None, float | None]
    mac: float | None


def pair_models(a: IdentifiedModel, b: IdentifiedModel, tolerance: float = 0.02
                ) -> list[ModePair]:  # fmt: skip
    """The modes of ``a`` and ``b`` (identified from the same data, so with the same shape
    channels) paired one to one, nearest frequencies first, within ``tolerance``
    (relative); unpaired modes get a row of their own. Rows in ascending frequency."""
    fa, fb = np.asarray(a.frequency_hz), np.asarray(b.frequency_hz)
    cand = sorted((abs(x / y - 1), i, j) for i, x in enumerate(fa) for j, y in enumerate(fb)
                  if abs(x / y - 1) <= tolerance)  # fmt: skip
    ia: dict[int, int] = {}
    used: set[int] = set()
    for _, i, j in cand:
        if i not in ia and j not in used:
            ia[i] = j
            used.add(j)
    same = [c.label for c in a.shape_channels] == [c.label for c in b.shape_channels]
    rows = []
    for i in range(len(fa)):
        j = ia.get(i)
        m = (float(mac(a.shapes[:, [i]], b.shapes[:, [j]])[0, 0])
             if j is not None and same else None)  # fmt: skip
        rows.append(ModePair(i, j, (float(fa[i]), None if j is None else float(fb[j])),
                             (float(a.damping_ratio[i]),
                              None if j is None else float(b.damping_ratio[j])), m))
    for j in range(len(fb)):
        if j not in used:
            rows.append(ModePair(None, j, (None, float(fb[j])),
                                 (None, float(b.damping_ratio[j])), None))
    return sorted(rows, key=lambda r: r.frequency_hz[0] if r.frequency_hz[0] is not None
                  else r.frequency_hz[1])  # fmt: skip
