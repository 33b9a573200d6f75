"""Rows of NASTRAN ids in an id column: the one lookup every layer uses (nodes, properties,
materials)."""

from __future__ import annotations

import numpy as np


class IdIndex:
    """An id column (n,) sorted once for lookups; ``ascending=True`` says it already is
    (strictly ascending, as ``Model.node_ids``), which saves the sort."""

    def __init__(self, ids: np.ndarray, *, ascending: bool = False):
        ids = np.asarray(ids, dtype=np.int64)
        if ascending:
            self.order = None
            self.sorted = ids
        else:
            self.order = np.argsort(ids, kind="stable")
            self.sorted = ids[self.order]

    def rows(self, query: np.ndarray | list[int] | int) -> np.ndarray:
        """Rows (any shape of ``query``, at least 1-d) of the ids in the column, -1 where an id
        is not in it; the first row of an id that repeats."""
        q = np.atleast_1d(np.asarray(query, dtype=np.int64))
        if len(self.sorted) == 0:
            return np.full(q.shape, -1, np.int64)
        pos = np.minimum(np.searchsorted(self.sorted, q), len(self.sorted) - 1)
        found = self.sorted[pos] == q
        rows = pos if self.order is None else self.order[pos]
        return np.where(found, rows, -1)
