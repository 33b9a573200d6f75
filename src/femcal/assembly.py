"""Sparse assembly of element matrices into the g-set, in each node's displacement frame.

The sparsity pattern is built once from node connectivity: every pair of nodes joined by an
element couples all their DOF. Within a row, the DOF of each neighbouring node are
contiguous and in node order, so the place of any (row DOF, column DOF) entry in the CSR
data array follows from the node pair's entry in the node graph plus the components: element
contributions are scattered with one ``np.add.at`` per chunk, with no COO sort and no
per-element Python loop.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

#: Elements handled per scatter chunk (bounds the temporary index arrays).
CHUNK_ELEMENTS = 16384


@dataclass(frozen=True)
class Pattern:
    """CSR sparsity pattern of the g-set matrices.

    Attributes
    ----------
    n_nodes, n_dof : sizes.
    dof_start : (n_nodes,) first DOF of each node.
    ndof : (n_nodes,) DOF per node (6 for GRID, 1 for SPOINT).
    dof_node : (n_dof,) node of each DOF.
    indptr, indices : CSR structure (indices int32 or int64, sorted within rows).
    keys : (m,) sorted node-pair keys ``a * n_nodes + b`` of the node graph.
    prefix : (m,) offset, within each row of node a, of node b's first DOF.
    """

    n_nodes: int
    n_dof: int
    dof_start: np.ndarray
    ndof: np.ndarray
    dof_node: np.ndarray
    indptr: np.ndarray
    indices: np.ndarray
    keys: np.ndarray
    prefix: np.ndarray

    @property
    def nnz(self) -> int:
        return int(self.indptr[-1])

    @classmethod
    def build(cls, dof_start: np.ndarray, ndof: np.ndarray, pairs: list[np.ndarray]) -> Pattern:
        """Pattern from node pairs.

        Parameters
        ----------
        dof_start, ndof : (n_nodes,) per node.
        pairs : arrays (m, 2) of node indices that elements couple (both orders are added,
            as is every node's diagonal block; entries with a negative index are ignored).
        """
        n = len(ndof)
        n_dof = int(ndof.sum())
        chunks = [np.arange(n, dtype=np.int64) * (n + 1)]  # diagonal a*n + a
        for p in pairs:
            p = np.asarray(p, dtype=np.int64).reshape(-1, 2)
            p = p[(p >= 0).all(axis=1)]
            chunks.append(p[:, 0] * n + p[:, 1])
            chunks.append(p[:, 1] * n + p[:, 0])
        keys = np.sort(np.concatenate(chunks))
        keys = keys[np.concatenate([[True], keys[1:] != keys[:-1]])]
        a = keys // n
        b = keys % n
        blk = ndof[b].astype(np.int64)
        node_ptr = np.searchsorted(a, np.arange(n + 1))
        cum = np.cumsum(blk)
        start_of_row = np.concatenate([[0], cum])[node_ptr[:-1]]  # offset of row a's segment
        seg_start = np.repeat(start_of_row, np.diff(node_ptr))
        prefix = cum - blk - seg_start
        row_len_node = np.concatenate([[0], cum])[node_ptr[1:]] - start_of_row
        dof_node = np.repeat(np.arange(n), ndof)
        row_len = row_len_node[dof_node]
        indptr = np.concatenate([[0], np.cumsum(row_len)]).astype(np.int64)
        nnz = int(indptr[-1])
        # Column DOF of each node row (once), then repeated for each DOF of that node.
        total = int(cum[-1]) if len(cum) else 0
        expanded = np.repeat(dof_start[b], blk) + (np.arange(total) - np.repeat(cum - blk, blk))
        itype = np.int32 if max(nnz, n_dof, total) < 2**31 - 1 else np.int64
        # gather[indptr[r] + t] = seg[r] + t: a running sum that jumps at each row start
        seg = start_of_row[dof_node]
        step = np.ones(nnz, dtype=itype)
        step[0] = seg[0]
        step[indptr[1:-1]] = seg[1:] - (seg[:-1] + row_len[:-1] - 1)
        gather = np.cumsum(step, dtype=itype)
        indices = expanded.astype(itype)[gather]
        del step, gather
        indptr = indptr.astype(itype)  # scipy wants indptr and indices of one dtype
        return cls(n, n_dof, dof_start, ndof, dof_node, indptr, indices, keys, prefix)

    def pair_index(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Index into ``keys``/``prefix`` of node pairs (a, b), any shape; ValueError if absent."""
        key = a * self.n_nodes + b
        q = np.minimum(np.searchsorted(self.keys, key), len(self.keys) - 1)
        if not np.array_equal(self.keys[q], key):
            bad = np.flatnonzero((self.keys[q] != key).ravel())[0]
            raise ValueError(
                f"node pair ({a.ravel()[bad]}, {b.ravel()[bad]}) is not in the sparsity "
                "pattern (an element was left out when the pattern was built)"
            )
        return q

    def block_positions(self, nodes: np.ndarray, d: int) -> np.ndarray:
        """CSR data positions (n, k*d, k*d) of element matrices on nodes (n, k), all present,
        with d DOF per node in node-major order."""
        n, k = nodes.shape
        q = self.pair_index(nodes[:, :, None], nodes[:, None, :])  # (n, k, k)
        comp = np.arange(d)
        rowstart = self.indptr[self.dof_start[nodes][:, :, None] + comp]  # (n, k, d)
        pos = (
            rowstart[:, :, :, None, None]
            + self.prefix[q][:, :, None, :, None]
            + comp[None, None, None, None, :]
        )
        return pos.reshape(n, k * d, k * d)

    def positions(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """Places in the CSR data array of entries (row DOF, column DOF), any shape."""
        nr = self.dof_node[rows]
        nc = self.dof_node[cols]
        key = nr * self.n_nodes + nc
        q = np.minimum(np.searchsorted(self.keys, key), len(self.keys) - 1)
        if not np.array_equal(self.keys[q], key):
            bad = np.flatnonzero((self.keys[q] != key).ravel())[0]
            raise ValueError(
                f"node pair ({nr.ravel()[bad]}, {nc.ravel()[bad]}) is not in the sparsity "
                "pattern (an element was left out when the pattern was built)"
            )
        return self.indptr[rows] + self.prefix[q] + (cols - self.dof_start[nc])


class Assembler:
    """Accumulates element matrices into g-set matrices sharing one :class:`Pattern`.

    ``n_matrices`` matrices (e.g. K and M) are accumulated together, so the scatter positions
    of an element block are computed once for all of them.
    """

    def __init__(self, pattern: Pattern, frames: np.ndarray | None = None, n_matrices: int = 1):
        """``frames``: (n_nodes, 3, 3) displacement frames (columns = axes in basic); element
        matrices given in basic are rotated into them. None: every frame is basic."""
        self.pattern = pattern
        self.data = [np.zeros(pattern.nnz) for _ in range(n_matrices)]
        self.frames = frames
        self._basic = (
            None if frames is None else np.all(np.abs(frames - np.eye(3)) < 1e-15, axis=(1, 2))
        )

    def add_blocks(self, nodes: np.ndarray, dof_per_node: int, *mats: np.ndarray | None) -> None:
        """Add element matrices, one array per accumulated matrix (None to skip one).

        Parameters
        ----------
        nodes : (n, k) node indices; -1 for an absent node (its rows/columns are dropped).
        dof_per_node : 3 (translations) or 6 (translations and rotations) per node, in the
            element matrices' node-major DOF order.
        mats : (n, k*d, k*d) element matrices in basic.
        """
        n = len(nodes)
        d = dof_per_node
        for s in range(0, n, CHUNK_ELEMENTS):
            nd = nodes[s : s + CHUNK_ELEMENTS]
            chunk = [None if m is None else self._rotate(nd, d, m[s : s + CHUNK_ELEMENTS])
                     for m in mats]  # fmt: skip
            if (nd >= 0).all():
                pos = self.pattern.block_positions(nd, d).ravel()
                for target, m in zip(self.data, chunk, strict=False):
                    if m is not None:
                        np.add.at(target, pos, m.ravel())
                continue
            safe = np.where(nd < 0, 0, nd)
            dofs = (self.pattern.dof_start[safe][:, :, None] + np.arange(d)).reshape(len(nd), -1)
            present = np.repeat(nd >= 0, d, axis=1)
            keep = present[:, :, None] & present[:, None, :]
            shape = (len(nd), dofs.shape[1], dofs.shape[1])
            rows = np.broadcast_to(dofs[:, :, None], shape)[keep]
            cols = np.broadcast_to(dofs[:, None, :], shape)[keep]
            pos = self.pattern.positions(rows, cols)
            for target, m in zip(self.data, chunk, strict=False):
                if m is not None:
                    np.add.at(target, pos, m[keep])

    def _rotate(self, nodes: np.ndarray, d: int, m: np.ndarray) -> np.ndarray:
        if self.frames is None:
            return m
        safe = np.where(nodes < 0, 0, nodes)
        if self._basic[safe].all():
            return m
        n, k = nodes.shape
        g = d // 3
        F = self.frames[safe]  # (n, k, 3, 3): u_basic = F u_cd
        m5 = m.reshape(n, k, g, 3, k, g, 3)
        out = np.einsum("nami,napmbql,nblj->napibqj", F, m5, F, optimize=True)
        return out.reshape(m.shape)

    def add_entries(self, rows: np.ndarray, cols: np.ndarray, vals: np.ndarray,
                    which: int = 0) -> None:  # fmt: skip
        """Add single entries (g-set DOF, already in the nodes' displacement frames) to matrix
        number ``which``."""
        if len(rows):
            np.add.at(self.data[which], self.pattern.positions(rows, cols), vals)

    def matrix(self, which: int = 0) -> sp.csr_matrix:
        """Assembled matrix number ``which``. It shares the accumulated data and the pattern's
        index arrays (no copy): add nothing more to this matrix after taking it."""
        p = self.pattern
        m = sp.csr_matrix((p.n_dof, p.n_dof))
        m.data, m.indices, m.indptr = self.data[which], p.indices, p.indptr
        return m
