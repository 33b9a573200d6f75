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
    graph = _coupling(K)
    if not is_diagonal(M):
        graph = graph + _coupling(M)
    count, label = connected_components(graph, directed=True, connection="weak")
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


def _coupling(A: sp.spmatrix) -> sp.csr_matrix:
    """The graph of A's nonzero values (int8 ones; explicit zeros dropped; A untouched)."""
    A = sp.csr_matrix(A)
    keep = (A.data != 0).view(np.int8)
    G = sp.csr_matrix((keep, A.indices.copy(), A.indptr.copy()), shape=A.shape)
    G.eliminate_zeros()
    return G
