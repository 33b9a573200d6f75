"""Sparse assembly of element matrices into the g-set, in each node's displacement frame.

The sparsity pattern is built once from node connectivity: every pair of nodes joined by an
element couples all their DOF. Within a row, the DOF of each neighbouring node are
contiguous and in node order, so the place of any (row DOF, column DOF) entry in the CSR
data array follows from the node pair's entry in the node graph plus the components: element
contributions are scattered with one ``np.add.at`` per chunk, with no COO sort and no
per-element Python loop.
"""

from __future__ import annotations

from concurrent.futures import Future
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..parallel import in_background

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
    indptr, indices : CSR structure (indices int32 or int64, sorted within rows). The
        scatter needs only ``indptr``; ``indices`` may still be computed in a background
        thread (see :meth:`build`) and is waited for when first read.
    keys : (m,) sorted node-pair keys ``a * n_nodes + b`` of the node graph.
    prefix : (m,) offset, within each row of node a, of node b's first DOF.
    """

    n_nodes: int
    n_dof: int
    dof_start: np.ndarray
    ndof: np.ndarray
    dof_node: np.ndarray
    indptr: np.ndarray
    _indices: list  # [array] or [Future of the array]
    keys: np.ndarray
    prefix: np.ndarray

    @property
    def indices(self) -> np.ndarray:
        v = self._indices[0]
        if isinstance(v, Future):
            v = v.result()
            self._indices[0] = v
        return v

    @property
    def nnz(self) -> int:
        return int(self.indptr[-1])

    @classmethod
    def build(
        cls,
        dof_start: np.ndarray,
        ndof: np.ndarray,
        pairs: list[np.ndarray],
        *,
        background: bool = False,
        diagonal: np.ndarray | None = None,
    ) -> Pattern:
        """Pattern from node pairs.

        With ``background``, the column indices (the pattern's largest array, which the
        scatter does not need) are computed in a separate thread while the caller goes on.

        Parameters
        ----------
        dof_start, ndof : (n_nodes,) per node.
        pairs : arrays (m, 2) of node indices that elements couple (both orders are added,
            as is every node's diagonal block; entries with a negative index are ignored).
        diagonal : the nodes whose diagonal blocks the pattern holds (default every node);
            the rows of the others hold only what ``pairs`` couple, none if nothing does (a
            pattern of a few elements in a large model).
        """
        n = len(ndof)
        n_dof = int(ndof.sum())
        own = np.arange(n, dtype=np.int64) if diagonal is None else np.asarray(diagonal, np.int64)
        chunks = [own * (n + 1)]  # diagonal a*n + a
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
        dof_node = np.repeat(np.arange(n), ndof)  # DOF are numbered node by node
        row_len = row_len_node[dof_node]
        indptr = np.concatenate([[0], np.cumsum(row_len)]).astype(np.int64)
        nnz = int(indptr[-1])
        itype = np.int32 if max(nnz, n_dof) < 2**31 - 1 else np.int64
        args = (dof_start, ndof, b, blk, node_ptr, start_of_row, row_len_node, nnz, itype)
        indices = in_background(_expand_columns, *args) if background else _expand_columns(*args)
        indptr = indptr.astype(itype)  # scipy wants indptr and indices of one dtype
        return cls(n, n_dof, dof_start, ndof, dof_node, indptr, [indices], keys, prefix)

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
        nc = self.dof_node[cols]
        q = self.pair_index(self.dof_node[rows], nc)
        return self.indptr[rows] + self.prefix[q] + (cols - self.dof_start[nc])


#: Nodes whose rows are expanded together (bounds the temporaries to a few MB, which is far
#: faster than one pass over the whole matrix: big fresh arrays cost page faults).
_EXPAND_NODES = 4096


def _expand_columns(dof_start: np.ndarray, ndof: np.ndarray, b: np.ndarray, blk: np.ndarray,
                    node_ptr: np.ndarray, start_of_row: np.ndarray, row_len_node: np.ndarray,
                    nnz: int, itype: type) -> np.ndarray:  # fmt: skip
    """CSR column indices (nnz,) of the pattern, rows in node order.

    Node a couples to the nodes ``b[node_ptr[a]:node_ptr[a+1]]`` (sorted), each with ``blk``
    DOF; its column segment (their DOF in order, ``row_len_node[a]`` of them) starts at
    ``start_of_row[a]`` in the concatenation of all segments. Each of node a's ``ndof[a]``
    DOF rows holds that same segment.
    """
    n = len(ndof)
    indices = np.empty(nnz, dtype=itype)
    out = 0
    for lo in range(0, n, _EXPAND_NODES):
        hi = min(lo + _EXPAND_NODES, n)
        p0, p1 = node_ptr[lo], node_ptr[hi]
        if p1 == p0:  # no entries in these rows
            continue
        nb = blk[p0:p1]
        cum = np.cumsum(nb)
        seg = (np.repeat(dof_start[b[p0:p1]] - (cum - nb), nb) + np.arange(cum[-1])).astype(itype)
        rows = np.repeat(np.arange(lo, hi), ndof[lo:hi])  # node of each DOF row of the range
        rows = rows[row_len_node[rows] > 0]  # (rows without entries take no place)
        r_len = row_len_node[rows]
        r_start = start_of_row[rows] - start_of_row[lo]
        total = int(r_len.sum())
        # where in seg each entry comes from: a running sum restarting at every row
        step = np.ones(total, dtype=itype)
        step[np.cumsum(r_len) - r_len] = r_start - np.concatenate([[0], (r_start + r_len - 1)[:-1]])
        indices[out : out + total] = seg[np.cumsum(step, dtype=itype)]
        out += total
    return indices


class Assembler:
    """Accumulates element matrices into g-set matrices sharing one :class:`Pattern`.

    ``n_matrices`` matrices (e.g. K and M) are accumulated together, so the scatter positions
    of an element block are computed once for all of them. Element matrices that couple no
    two nodes (a lumped mass) are summed per node in small (n_nodes, 6, 6) blocks instead of
    the full pattern, whose data array is then only allocated if something else needs it:
    for a lumped mass matrix that saves a pattern-sized array and half the scatter.
    """

    def __init__(self, pattern: Pattern, frames: np.ndarray | None = None, n_matrices: int = 1,
                 positions: dict | None = None):  # fmt: skip
        """``frames``: (n_nodes, 3, 3) displacement frames (columns = axes in basic); element
        matrices given in basic are rotated into them. None: every frame is basic.
        ``positions``: a dict in which the CSR positions of element blocks are kept by their
        nodes, for assemblers that add the same elements to the same pattern again."""
        self.pattern = pattern
        self._positions = positions
        self._data: list[np.ndarray | None] = [None] * n_matrices
        self._node_blocks: list[np.ndarray | None] = [None] * n_matrices
        #: per matrix, the node indices its node blocks were added at (arrays, in turn)
        self._node_hits: list[list[np.ndarray]] = [[] for _ in range(n_matrices)]
        self.frames = frames
        self._basic = (
            None if frames is None else np.all(np.abs(frames - np.eye(3)) < 1e-15, axis=(1, 2))
        )

    def _full(self, which: int) -> np.ndarray:
        if self._data[which] is None:
            self._data[which] = np.zeros(self.pattern.nnz)
        return self._data[which]

    def add_blocks(self, nodes: np.ndarray, dof_per_node: int, *mats: np.ndarray | None) -> None:
        """Add element matrices, one array per accumulated matrix (None to skip one).

        Parameters
        ----------
        nodes : (n, k) node indices; -1 for an absent node (its rows/columns are dropped).
        dof_per_node : 3 (translations) or 6 (translations and rotations) per node, in the
            element matrices' node-major DOF order.
        mats : (n, k*d, k*d) element matrices in basic.
        """
        self.scatter(self.prepare(nodes, dof_per_node, *mats))

    def prepare(self, nodes: np.ndarray, dof_per_node: int, *mats: np.ndarray | None) -> list:
        """The work of :meth:`add_blocks` that does not touch the accumulated matrices
        (rotation into the displacement frames, CSR positions), so that it may run in
        worker threads; :meth:`scatter` adds the result. Arguments as for ``add_blocks``.

        Returns a list of (positions (m,) or None, [per matrix: None, values (m,), or
        ("nodes", node indices (p,), d, blocks (p, d, d)) for node-diagonal matrices]).
        """
        n = len(nodes)
        d = dof_per_node
        out = []
        for s in range(0, n, CHUNK_ELEMENTS):
            nd = nodes[s : s + CHUNK_ELEMENTS]
            chunk = [None if m is None else self._rotate(nd, d, m[s : s + CHUNK_ELEMENTS])
                     for m in mats]  # fmt: skip
            if (nd >= 0).all():
                values: list = [None if m is None else _node_diagonal(nd, d, m) for m in chunk]
                full = [i for i, m in enumerate(chunk) if m is not None and values[i] is None]
                pos = self._block_positions(nd, d) if full else None
                for i in full:
                    values[i] = chunk[i].ravel()
                out.append((pos, values))
                continue
            safe = np.where(nd < 0, 0, nd)
            dofs = (self.pattern.dof_start[safe][:, :, None] + np.arange(d)).reshape(len(nd), -1)
            present = np.repeat(nd >= 0, d, axis=1)
            keep = present[:, :, None] & present[:, None, :]
            shape = (len(nd), dofs.shape[1], dofs.shape[1])
            rows = np.broadcast_to(dofs[:, :, None], shape)[keep]
            cols = np.broadcast_to(dofs[:, None, :], shape)[keep]
            pos = self.pattern.positions(rows, cols)
            out.append((pos, [None if m is None else m[keep] for m in chunk]))
        return out

    def _block_positions(self, nodes: np.ndarray, d: int) -> np.ndarray:
        """:meth:`Pattern.block_positions`, flattened; kept in ``positions`` if given."""
        if self._positions is None:
            return self.pattern.block_positions(nodes, d).ravel()
        key = (d, nodes.shape, nodes.tobytes())
        pos = self._positions.get(key)
        if pos is None:
            pos = self._positions[key] = self.pattern.block_positions(nodes, d).ravel()
        return pos

    def scatter(self, prepared: list) -> None:
        """Add what :meth:`prepare` returned to the accumulated matrices (not thread-safe:
        call from one thread, in a fixed order for reproducible sums)."""
        for pos, values in prepared:
            for which, v in enumerate(values):
                if v is None:
                    continue
                if isinstance(v, tuple):
                    _, idx, d, blocks = v
                    if self._node_blocks[which] is None:
                        self._node_blocks[which] = np.zeros((self.pattern.n_nodes, 6, 6))
                    np.add.at(self._node_blocks[which][:, :d, :d], idx, blocks)
                    self._node_hits[which].append(idx)
                else:
                    np.add.at(self._full(which), pos, v)

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
            np.add.at(self._full(which), self.pattern.positions(rows, cols), vals)

    def data(self, which: int = 0) -> np.ndarray:
        """Matrix number ``which`` as its values (nnz,) on the pattern, node blocks
        included (the accumulated array itself: add nothing more after taking it)."""
        out = self._full(which)
        if self._node_blocks[which] is not None:
            rows, cols, vals = self._node_entries(which)
            np.add.at(out, self.pattern.positions(rows, cols), vals)
        return out

    def _node_entries(self, which: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(rows, columns, values) of matrix ``which``'s node blocks' nonzero entries."""
        p = self.pattern
        # only the nodes something was added at (a part of a large model touches few of
        # them); in ascending order, as a search of the whole array would give them
        hit = np.unique(np.concatenate(self._node_hits[which]))
        blocks = self._node_blocks[which]
        at, i, j = np.nonzero(blocks[hit])
        node = hit[at]
        if (p.ndof[node] < 6).any():
            raise ValueError("a 6 x 6 node block was added to a scalar point")
        start = p.dof_start[node]
        return start + i, start + j, blocks[node, i, j]

    def matrix(self, which: int = 0) -> sp.csr_matrix:
        """Assembled matrix number ``which``. Without node blocks it shares the accumulated
        data and the pattern's index arrays (no copy): add nothing more to this matrix after
        taking it."""
        p = self.pattern
        m = sp.csr_matrix((p.n_dof, p.n_dof))
        if self._data[which] is not None or self._node_blocks[which] is None:
            m.data, m.indices, m.indptr = self._full(which), p.indices, p.indptr
        if self._node_blocks[which] is None:
            return m
        rows, cols, vals = self._node_entries(which)
        b = sp.csr_matrix((vals, (rows, cols)), shape=m.shape)
        return b if self._data[which] is None else (m + b).tocsr()


def _node_diagonal(nodes: np.ndarray, d: int, m: np.ndarray):
    """("nodes", node indices (n k,), d, blocks (n k, d, d)) if the element matrices m
    (n, k d, k d) couple no two of their nodes, else None."""
    n, k = nodes.shape
    m5 = m.reshape(n, k, d, k, d)
    if k > 1:
        off = ~np.eye(k, dtype=bool)
        # the first element alone first: a stiffness couples its nodes in every element
        if np.any(m5[:1].transpose(1, 3, 0, 2, 4)[off]):
            return None
    ar = np.arange(k)
    blocks = m5[:, ar, :, ar, :].transpose(1, 0, 2, 3)  # (n, k, d, d)
    if k > 1 and np.count_nonzero(m) != np.count_nonzero(blocks):  # entries off the blocks
        return None
    return ("nodes", nodes.ravel(), d, blocks.reshape(n * k, d, d))
