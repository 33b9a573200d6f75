"""Real eigenvalue analysis (SOL 103): K phi = lambda M phi on the a-set.

Shift-invert Lanczos on a factor of K - sigma M for large problems (block Lanczos,
:mod:`femcal.solve.lanczos`, by default; ARPACK's eigsh with our own OPinv on request or when
the block iteration does not converge), a dense solution for small ones. The shift is
negative so free-free models give their rigid-body modes. EIGRL semantics: all roots in
[V1, V2] (Hz), at most ND of them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sl
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from threadpoolctl import threadpool_limits

from ..errors import SolverError
from ..model.analysis import EigenRequest
from .factor import NotPositiveDefinite, factorize
from .lanczos import LanczosNotConverged, block_lanczos

#: Below this a-set size the dense solver is used.
DENSE_LIMIT = 600
#: |sigma| of the default negative shift, sigma = -(2 pi DEFAULT_SHIFT_HZ)^2.
DEFAULT_SHIFT_HZ = 1.0


@dataclass(frozen=True)
class EigenResult:
    """Eigenpairs on the a-set, ascending.

    Attributes
    ----------
    eigenvalues : (k,) lambda = omega^2 (rad^2/s^2).
    vectors : (n_a, k) mode shapes, normalised as requested.
    generalized_mass, generalized_stiffness : (k,) phi^T M phi and phi^T K phi.
    backend : factorisation used ("cholmod", "superlu", "dense").
    """

    eigenvalues: np.ndarray
    vectors: np.ndarray
    generalized_mass: np.ndarray
    generalized_stiffness: np.ndarray
    backend: str

    @property
    def radians(self) -> np.ndarray:
        return np.sqrt(np.abs(self.eigenvalues)) * np.sign(self.eigenvalues)

    @property
    def frequencies_hz(self) -> np.ndarray:
        return self.radians / (2.0 * np.pi)


def _to_lambda(f_hz: float) -> float:
    return (2.0 * np.pi * f_hz) ** 2


def solve_modes(
    K: sp.spmatrix,
    M: sp.spmatrix,
    request: EigenRequest,
    *,
    shift_hz: float = DEFAULT_SHIFT_HZ,
    backend: str = "auto",
    method: str = "block",
    progress: Callable[[str], None] | None = None,
    on_factor: Callable[[Callable[[np.ndarray], np.ndarray], float], None] | None = None,
) -> EigenResult:
    """Lowest eigenpairs of K phi = lambda M phi satisfying the request.

    Parameters
    ----------
    K, M : (n, n) symmetric; K positive semi-definite, M positive semi-definite (massless DOF
        give infinite eigenvalues, which are never returned).
    shift_hz : |sigma| of the negative shift, sigma = -(2 pi shift_hz)^2.
    backend : factorisation for the sparse path ("auto", "cholmod", "superlu").
    method : the sparse path's Lanczos: "block" (:mod:`femcal.solve.lanczos`, one solve per
        block of 8 vectors; ARPACK if it does not converge) or "arpack" (scipy's eigsh with
        our OPinv, one solve per vector).
    progress : called with short status lines during long solves.
    on_factor : called as ``on_factor(solve, sigma)`` with the sparse path's factor of
        K - sigma M (``solve(b)`` for b (n,) or (n, k)), for callers that solve with the
        same matrix afterwards (not called on the dense path).

    Raises
    ------
    SolverError
        When K - sigma M cannot be factorised (a mechanism: a DOF with neither stiffness nor
        mass that no constraint removes), or the iteration does not converge (the converged
        pairs are in ``partial``).
    """
    n = K.shape[0]
    if n == 0:
        raise SolverError("the model has no free DOF after constraints")
    sigma = -_to_lambda(shift_hz)  # below the spectrum; V1 filters the roots afterwards
    lam_lo = -np.inf if request.v1 is None else _to_lambda(request.v1) * (1 - 1e-9)
    lam_hi = np.inf if request.v2 is None else _to_lambda(request.v2) * (1 + 1e-9)
    if request.nd is None and request.v2 is None:
        raise SolverError("EIGRL needs ND or V2 (how many roots, or up to which frequency)")
    if method not in ("block", "arpack"):
        raise ValueError(f"method {method!r}: expected 'block' or 'arpack'")
    if n <= DENSE_LIMIT:
        lam, vec, name = _dense(K, M, sigma)
    else:
        lam, vec, name = _lanczos(K, M, sigma, request, lam_lo, lam_hi, backend, progress,
                                  on_factor, method)
    keep = (lam >= lam_lo) & (lam <= lam_hi)
    lam, vec = lam[keep], vec[:, keep]
    if request.nd is not None:
        lam, vec = lam[: request.nd], vec[:, : request.nd]
    gm = np.einsum("ik,ik->k", vec, M @ vec)
    if request.norm.upper() == "MAX":
        big = vec[np.argmax(np.abs(vec), axis=0), np.arange(vec.shape[1])]
        vec = vec / big
    else:
        vec = vec / np.sqrt(np.where(gm > 0, gm, 1.0))
    gm = np.einsum("ik,ik->k", vec, M @ vec)
    gk = np.einsum("ik,ik->k", vec, K @ vec)
    return EigenResult(lam, vec, gm, gk, name)


def _arpack(K, M, sigma, solve, k):
    """k roots nearest above sigma by ARPACK's one-vector shift-invert Lanczos."""
    n = K.shape[0]
    op = spla.LinearOperator((n, n), matvec=solve, dtype=float)
    # a fixed start vector: the same matrices give the same modes, to the last digit, every run
    v0 = np.random.default_rng(20191).standard_normal(n)
    try:
        return spla.eigsh(K, k=k, M=M, sigma=sigma, OPinv=op, which="LM", mode="normal",
                          tol=1e-10, v0=v0)  # fmt: skip
    except spla.ArpackNoConvergence as e:
        raise SolverError(
            f"Lanczos did not converge for {k} roots ({len(e.eigenvalues)} converged)",
            partial=(e.eigenvalues, e.eigenvectors),
        ) from None


def _shifted_factor(K, M, sigma, backend):
    A = (K - sigma * M).tocsc()
    try:
        return factorize(A, backend=backend)
    except NotPositiveDefinite as e:
        raise SolverError(
            "K - sigma M is singular or not positive definite: the model has a mechanism "
            f"(DOF with neither stiffness nor mass, or negative stiffness) [{e}]"
        ) from None


def _dense(K, M, sigma):
    Kd = K.toarray() if sp.issparse(K) else np.asarray(K)
    Md = M.toarray() if sp.issparse(M) else np.asarray(M)
    A = Kd - sigma * Md
    try:
        L = np.linalg.cholesky(A)
    except np.linalg.LinAlgError:
        raise SolverError(
            "K - sigma M is not positive definite: the model has a mechanism (DOF with neither "
            "stiffness nor mass) or negative stiffness"
        ) from None
    Li = sl.solve_triangular(L, np.eye(len(A)), lower=True)
    C = Li @ Md @ Li.T
    mu, y = np.linalg.eigh((C + C.T) / 2)
    tol = 1e-12 * max(mu.max(), 1e-300)
    finite = mu > tol
    mu, y = mu[finite][::-1], y[:, finite][:, ::-1]
    lam = sigma + 1.0 / mu
    vec = sl.solve_triangular(L.T, y, lower=False)
    return lam, vec, "dense"


def _lanczos(K, M, sigma, request, lam_lo, lam_hi, backend, progress, on_factor=None,
             method="block"):  # fmt: skip
    n = K.shape[0]
    solve, name = _shifted_factor(K, M, sigma, backend)
    if on_factor is not None:
        on_factor(solve, sigma)
    want = request.nd if request.nd is not None else 20
    k = min(max(want + 2, 12), n - 2)
    lam = vec = None

    def answered(lam: np.ndarray) -> bool:
        """Whether the roots found (ascending) answer the request: the ND lowest roots in
        range are all there, or every root below V2 is."""
        in_range = (lam >= lam_lo) & (lam <= lam_hi)
        if request.nd is not None and in_range.sum() >= request.nd:
            return True
        return bool(np.isfinite(lam_hi) and len(lam) and lam[-1] > lam_hi)

    def enough(lam: np.ndarray) -> bool:
        if answered(lam):
            return True
        if progress:
            n_in = int(((lam >= lam_lo) & (lam <= lam_hi)).sum())
            progress(f"Lanczos: {n_in} roots in range so far, going on")
        return False

    while True:
        if progress:
            progress(f"Lanczos: {k} roots of {n} DOF ({name}, {method})")
        # One BLAS thread per pool during the iteration: the Lanczos' and CHOLMOD's OpenBLAS
        # pools otherwise compete for the cores and slow every solve down.
        finished = False
        with threadpool_limits(limits=1, user_api="blas"):
            if method == "block":
                try:
                    # more roots wanted on the same basis, not from scratch: it returns
                    # when enough() says so or when every root of the problem is found
                    lam, vec, _ = block_lanczos(solve, M, sigma, k, enough=enough)
                    finished = True
                except LanczosNotConverged as e:
                    if progress:
                        progress(f"{e}: ARPACK instead")
                    lam, vec = _arpack(K, M, sigma, solve, k)
            else:
                lam, vec = _arpack(K, M, sigma, solve, k)
        order = np.argsort(lam)
        lam, vec = lam[order], vec[:, order]
        if finished or answered(lam) or k >= n - 2:
            return lam, vec, name
        k = min(2 * k, n - 2)
