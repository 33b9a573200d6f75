"""Independent parts of an eigenproblem: sets of DOF that no nonzero of K or M couples.

K phi = lambda M phi with K and M block-diagonal after a permutation is as many problems as
blocks, and its roots are the union of theirs. A flat shell or a planar frame is such a
problem (its membrane and bending DOF, its in-plane and out-of-plane motions, do not couple),
and so is a model of several bodies that nothing joins. Solved part by part, a part whose
lowest root lies above the roots wanted needs no Lanczos basis at all (see
:func:`femcal.solve.eigen.solve_modes`), and each solve and basis product reads only its part.

The parts follow the values, not the stored pattern: an assembly that stores whole 6 x 6
node blocks keeps the zero membrane-bending coupling of a flat shell as explicit zeros.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from .lanczos import is_diagonal

#: A connected set of DOF is a part of its own when it holds at least this share of the DOF
#: and PART_MIN DOF; smaller sets are gathered in one part (any union of connected sets is
#: independent of the rest), since a split of small problems saves nothing.
PART_SHARE = 0.05
PART_MIN = 2000


def independent_parts(K: sp.spmatrix, M: sp.spmatrix) -> list[np.ndarray]:
    """The DOF indices (ascending) of the problem's independent parts, the largest first and
    the gathered small sets last; one part, every DOF, when the problem does not split.

    Parameters
    ----------
    K, M : (n, n) symmetric sparse matrices of one pattern or not; explicit zeros couple
        nothing.
    """
    n = K.shape[0]
    whole = [np.arange(n)]
    if n < 2 * PART_MIN:
        return whole
    # (a diagonal M couples nothing; otherwise the two patterns' union, as a sum of ones:
    # a sum of the values would drop an entry where K_ij = -M_ij)
    graph = _coupling(K) if is_diagonal(M) else _ones(K) + _ones(M)
    count, label = _components(graph)
    if count < 2:
        return whole
    size = np.bincount(label, minlength=count)
    own = size >= max(PART_SHARE * n, PART_MIN)
    if not own.any():
        return whole
    order = np.argsort(label, kind="stable")  # DOF grouped by label, ascending within
    starts = np.concatenate([[0], np.cumsum(size)])
    parts = [order[starts[c] : starts[c + 1]] for c in np.flatnonzero(own)]
    parts.sort(key=len, reverse=True)
    rest = np.flatnonzero(~own[label])
    if len(rest):  # (with two sets or more, one part of its own leaves a rest)
        parts.append(rest)
    return parts


def _components(graph: sp.csr_matrix) -> tuple[int, np.ndarray]:
    """(count, label (n,)) of the graph's connected sets, an entry (i, j) joining i and j
    whichever way it points, numbered by their lowest vertex.

    The strongly connected sets are found first (Pearce's algorithm, on the graph as it is).
    A symmetric pattern's, K's and M's, are its connected sets; where an entry joins two of
    them (a pattern that is not symmetric) the weakly connected sets are found instead, on
    the graph and its transpose, whose construction costs several times the strong search
    on a large graph."""
    count, label = connected_components(graph, directed=True, connection="strong")
    if count > 1 and _joins_sets(graph, label):
        count, label = connected_components(graph, directed=True, connection="weak")
    # numbered by each set's lowest vertex, as the weak search numbers them (SciPy's strong
    # search does too on a symmetric pattern; the renumbering does not rely on it)
    running = np.maximum.accumulate(label)
    if running[0] != 0 or (np.diff(running) > 1).any() or running[-1] != count - 1:
        _, first = np.unique(label, return_index=True)
        rank = np.empty(count, dtype=label.dtype)
        rank[np.argsort(first, kind="stable")] = np.arange(count, dtype=label.dtype)
        label = rank[label]
    return count, label


def _joins_sets(graph: sp.csr_matrix, label: np.ndarray) -> bool:
    """Whether an entry of the graph lies between two of the labelled sets."""
    counts = np.diff(graph.indptr)
    rows = np.flatnonzero(counts)
    if not len(rows):
        return False
    theirs = label[graph.indices[: graph.indptr[-1]]]
    starts = graph.indptr[rows]
    low = np.minimum.reduceat(theirs, starts)
    high = np.maximum.reduceat(theirs, starts)
    own = label[rows]
    return bool((low != own).any() or (high != own).any())


def _coupling(A: sp.spmatrix) -> sp.csr_matrix:
    """The graph of A's nonzero values, for SciPy's graph searches (A untouched). A CSR
    matrix of float64 values in canonical form (sorted, no duplicates: the strong search
    never ends on a duplicated entry) without stored zeros is its own graph, without a copy
    (SciPy's searches would convert any other type to float64); else :func:`_ones`."""
    A = sp.csr_matrix(A)
    if (A.dtype == np.float64 and A.has_canonical_format
            and np.count_nonzero(A.data[: A.nnz]) == A.nnz):  # fmt: skip
        return A
    return _ones(A)


def _ones(A: sp.spmatrix) -> sp.csr_matrix:
    """A's pattern of nonzero values as a canonical CSR graph of float64 ones (twos where
    duplicates that are not zero meet: entries that cancel still couple); A untouched."""
    A = sp.csr_matrix(A)
    keep = (A.data != 0).astype(np.float64)
    G = sp.csr_matrix((keep, A.indices.copy(), A.indptr.copy()), shape=A.shape)
    G.eliminate_zeros()
    G.sum_duplicates()
    return G
