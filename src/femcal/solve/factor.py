"""Sparse symmetric factorisation: CHOLMOD (scikit-sparse) when installed, SciPy's SuperLU
otherwise. Both give a callable ``solve(b)`` for (n,) or (n, k) right-hand sides."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

try:  # pragma: no cover - depends on the machine
    from sksparse.cholmod import CholmodNotPositiveDefiniteError, cholesky

    HAVE_CHOLMOD = True
except ImportError:  # pragma: no cover
    HAVE_CHOLMOD = False


class NotPositiveDefinite(ValueError):
    """The matrix could not be factorised as positive definite."""


#: CHOLMOD's fill-reducing orderings femcal asks for: "default", CHOLMOD's own choice (AMD,
#: then METIS where AMD's fill is large, keeping the smaller fill whatever METIS's own time),
#: and "amd" (approximate minimum degree alone).
ORDERINGS = ("default", "amd")


def factorize(
    A: sp.spmatrix, *, backend: str = "auto", ordering: str = "default"
) -> tuple[Callable[[np.ndarray], np.ndarray], str]:
    """Factor a sparse symmetric positive definite matrix.

    Parameters
    ----------
    A : (n, n) symmetric positive definite.
    backend : "auto" (CHOLMOD if available), "cholmod" or "superlu".
    ordering : CHOLMOD's fill-reducing ordering, one of :data:`ORDERINGS` (SuperLU takes
        its own).

    Returns
    -------
    (solve, name): solve(b) returns A^-1 b; name is the backend used.

    Raises
    ------
    NotPositiveDefinite
        If CHOLMOD finds the matrix not positive definite (SuperLU factors any nonsingular
        matrix, so it raises only for a singular one).
    """
    if backend not in ("auto", "cholmod", "superlu"):
        raise ValueError(f"backend {backend!r}: expected 'auto', 'cholmod' or 'superlu'")
    if ordering not in ORDERINGS:
        raise ValueError(f"ordering {ordering!r}: expected one of {', '.join(ORDERINGS)}")
    A = sp.csc_matrix(A)
    if backend == "cholmod" and not HAVE_CHOLMOD:
        raise ValueError("CHOLMOD (scikit-sparse) is not installed")
    if backend in ("auto", "cholmod") and HAVE_CHOLMOD:
        try:
            factor = cholesky(A, ordering_method=ordering)
        except CholmodNotPositiveDefiniteError as e:
            raise NotPositiveDefinite(str(e)) from None
        return factor, "cholmod"
    try:
        lu = spla.splu(A, permc_spec="MMD_AT_PLUS_A", options={"SymmetricMode": True})
    except RuntimeError as e:  # "Factor is exactly singular"
        raise NotPositiveDefinite(str(e)) from None
    return lu.solve, "superlu"
