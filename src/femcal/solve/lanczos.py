"""Block shift-invert Lanczos for the lowest roots of K phi = lambda M phi.

The operator OP = (K - sigma M)^-1 M is self-adjoint in the M inner product; its eigenvalues
theta = 1 / (lambda - sigma) are largest for the lambda nearest above the shift sigma. A block
of b vectors spans the Krylov space of OP: each step applies OP to the newest block with ONE
solve of b right-hand sides (a sparse factor is read once per solve, whatever b is, so b
columns cost much less than b solves of one), M-orthogonalises the result
against the two newest blocks (the block three-term recurrence) and then once against the whole
basis (classical Gram-Schmidt as matrix products; a second pass only when the first removed
much of a column), and M-orthonormalises it within itself. The basis V then satisfies

    OP V_j = V_j T_j + Q_{j+1} R_j E_j^T,    T_j = V_j^T M OP V_j,

so the Ritz pairs (theta, V_j y) of T_j have residuals |R_j y_last| (y_last: y's entries on
the newest block), which decide convergence. No restart: the basis grows until the wanted
roots converge or ``max_dim`` is reached (then :class:`LanczosNotConverged`); when the caller
asks for more roots (``enough``), the same basis goes on growing.

This is the method NASTRAN's READ module uses (block shift-invert Lanczos). femcal prefers it
to the one-vector iteration (ARPACK) because the solves dominate the cost, and a block also
finds every copy of a repeated root up to its size (six rigid-body modes of a free-free model,
symmetric pairs).
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import AbstractContextManager, nullcontext

import numpy as np
import scipy.linalg as sl
import scipy.sparse as sp

from ..parallel.progress import Step

#: Columns per block.
DEFAULT_BLOCK = 8
#: Relative residual of theta at which a root counts as converged. The eigenvalues' error is
#: about the residual squared over the gap: 1e-8 gives them to rounding and the vectors to
#: about 1e-8 (max-norm, relative), in fewer block solves than a tighter tolerance.
DEFAULT_TOL = 1e-8
#: A direction of a new block whose M-norm is below this fraction of the block's largest is
#: numerically dependent (deflation) and is replaced by a random one.
_DEFLATE = 1e-10


class LanczosNotConverged(RuntimeError):
    """The wanted roots did not converge within the largest basis allowed."""

    def __init__(self, msg: str, converged: int):
        super().__init__(msg)
        self.converged = converged


def block_lanczos(solve: Callable[[np.ndarray], np.ndarray], M: sp.spmatrix, sigma: float,
                  k: int, *, block: int = DEFAULT_BLOCK, tol: float = DEFAULT_TOL,
                  max_dim: int | None = None, seed: int = 20191,
                  progress: Callable[[str], None] | None = None,
                  enough: Callable[[np.ndarray], bool] | None = None,
                  wide: Callable[[], AbstractContextManager] | None = None,
                  lowest: tuple[float, Callable[[float], None]] | None = None,
                  ) -> tuple[np.ndarray, np.ndarray, int]:  # fmt: skip
    """The k roots lambda nearest above ``sigma`` and their vectors.

    Parameters
    ----------
    solve : x = (K - sigma M)^-1 b for b (n, b) (a factorisation).
    M : (n, n) symmetric positive semi-definite mass (massless DOF: infinite roots, never
        returned).
    sigma : shift (rad^2/s^2), below the wanted roots.
    k : number of roots.
    block : columns per block; tol : relative residual of theta = 1 / (lambda - sigma) at
        which a root counts as converged (ARPACK's meaning of tol).
    max_dim : largest basis (default min(n, max(6 k, 12 block) + 2 block), growing with k).
    seed : of the random start block (the same problem gives the same result every run).
    enough : asked with the converged roots (ascending) once k have converged; if it says
        False the iteration goes on for twice as many roots with the same basis (k doubles,
        the basis keeps growing), until it says True or every root of the problem is found.
        For "every root below V2" requests, whose count is not known beforehand.
    wide : a context in which the products with the whole basis run (the caller's way to give
        them more BLAS threads than the solves get); none: as the caller runs.
    lowest : (tol_low, said): ``said(lam)`` is called once, with the Ritz value lam of the
        largest theta, at the first step where that theta's residual is below tol_low theta
        (the lowest root then lies within tol_low of it; see
        :func:`femcal.solve.eigen._lowest_root`), if that comes before the end.

    Returns
    -------
    (lam (k,) ascending, vectors (n, k) M-orthonormal, number of block solves).
    """
    n = M.shape[0]
    b = max(1, min(block, n))
    k = min(k, n)
    grow = max_dim is None
    if max_dim is None:
        max_dim = _default_dim(n, k, b)
    max_dim = max(min(max_dim, n), k)
    rng = np.random.default_rng(seed)
    mass = mass_product(M)
    # columns contiguous: a new block is one contiguous write, the products read it in place
    V = np.empty((n, max_dim + b), order="F")
    T = np.zeros((max_dim + b, max_dim + b))
    # the start block in the range of OP (no components along massless directions)
    W = solve(mass(rng.standard_normal((n, b))))
    solves = 1
    bq, _ = _orthonormalize(W, mass, V[:, :0], rng, V[:, :b])
    m = prev = 0  # the newest block's and the one before's first column
    while True:
        W = solve(mass(V[:, m : m + bq]))
        solves += 1
        top = m + bq
        # T's new columns, the projections of OP Q on the basis: first on the two newest
        # blocks (the three-term recurrence, nearly all of it), then once on the whole basis
        # for what rounding left, and once more if that pass removed much (Kahan's rule)
        C = np.zeros((top, bq))
        with wide() if wide is not None else nullcontext():
            C[prev:top] = V[:, prev:top].T @ mass(W)
            W -= V[:, prev:top] @ C[prev:top]
            for _ in range(2):
                before = np.linalg.norm(W, axis=0)
                C2 = V[:, :top].T @ mass(W)
                W -= V[:, :top] @ C2
                C += C2
                if (np.linalg.norm(W, axis=0) >= 0.5 * before).all():
                    break
        T[:top, m:top] = C
        T[m:top, :top] = C.T
        Ts = T[:top, :top]
        theta, Y = np.linalg.eigh(0.5 * (Ts + Ts.T))  # ascending: the wanted at the end
        want = min(k, top)
        # the next block is written straight into the basis (no copy of it)
        b_next, R = (_orthonormalize(W, mass, V[:, :top], rng, V[:, top : top + bq])
                     if top < n else (0, np.zeros((0, bq))))  # fmt: skip
        resid = np.linalg.norm(R @ Y[m:top, -want:], axis=0)
        done = resid <= tol * np.abs(theta[-want:])
        if lowest is not None and theta[-1] > 0 and resid[-1] <= lowest[0] * theta[-1]:
            lowest[1](sigma + 1.0 / theta[-1])
            lowest = None
        if progress:
            progress(Step(f"block Lanczos: basis {top}, {int(done.sum())} of {k} roots "
                          "converged", task=f"block Lanczos: {k} roots", done=int(done.sum()),
                          total=k))  # fmt: skip
        converged = (want == k and done.all()) or top >= n
        if converged and (enough is None or top >= n or k >= n
                          or enough(_roots(theta[-want:], sigma))):  # fmt: skip
            break
        if converged:  # not enough yet: twice as many roots, on the same basis
            k = min(2 * k, n)
            if grow and _default_dim(n, k, b) > max_dim:
                max_dim = _default_dim(n, k, b)
                V, T = _wider(V, top + b_next, max_dim + b), _larger(T, top, max_dim + b)
            if progress:
                progress(f"block Lanczos: going on for {k} roots")
        if top + b_next > max_dim:
            raise LanczosNotConverged(
                f"block Lanczos: {int(done.sum())} of {k} roots converged with a basis of "
                f"{top} vectors (the largest allowed)", int(done.sum()))
        bq, prev, m = b_next, m, top
    theta, Y = theta[-want:][::-1], Y[:, -want:][:, ::-1]  # largest theta: lowest lambda
    ok = theta > 0
    lam = sigma + 1.0 / theta[ok]
    vec = V[:, :top] @ Y[:, ok]
    return lam, vec, solves


def _default_dim(n: int, k: int, b: int) -> int:
    return min(n, max(6 * k, 12 * b) + 2 * b)


def _roots(theta: np.ndarray, sigma: float) -> np.ndarray:
    """lambda (ascending) of the Ritz values theta = 1 / (lambda - sigma) > 0."""
    return np.sort(sigma + 1.0 / theta[theta > 0])


def _wider(V: np.ndarray, used: int, cols: int) -> np.ndarray:
    """V (n, c) copied into a column-major (n, cols), its first ``used`` columns kept."""
    out = np.empty((V.shape[0], cols), order="F")
    out[:, :used] = V[:, :used]
    return out


def _larger(T: np.ndarray, used: int, size: int) -> np.ndarray:
    """T (c, c) copied into a zero (size, size), its leading ``used`` x ``used`` block kept."""
    out = np.zeros((size, size))
    out[:used, :used] = T[:used, :used]
    return out


def mass_product(M: sp.spmatrix) -> Callable[[np.ndarray], np.ndarray]:
    """X (n, b) -> M X, as a row scaling when M is diagonal (a lumped mass)."""
    M = sp.csr_matrix(M)
    d = M.diagonal()
    if is_diagonal(M):
        return lambda X: d[:, None] * X
    # (SciPy's product reads X row-major, copying a column-major X, a basis block or a
    # factor's answer, less quickly than NumPy does)
    return lambda X: np.asarray(M @ np.ascontiguousarray(X))


def is_diagonal(A: sp.spmatrix) -> bool:
    """Whether A's nonzero values all lie on its diagonal (an empty A is)."""
    A = sp.csr_matrix(A)
    return int(np.count_nonzero(A.data)) == int(np.count_nonzero(A.diagonal()))


def _orthonormalize(
    W: np.ndarray,
    mass: Callable[[np.ndarray], np.ndarray],
    V: np.ndarray,
    rng: np.random.Generator,
    out: np.ndarray,
) -> tuple[int, np.ndarray]:
    """Write Q (n, b) with W = Q R, Q M-orthonormal, into ``out`` (W already M-orthogonal to V).

    Returns (the number of columns written, R (b, b)). Directions of W that are (numerically)
    dependent on V or on each other are replaced by random vectors M-orthogonal to V and to
    the rest (their rows of R are zero), never more of them than the n - (V's columns)
    directions left; ``out`` has room for W's b columns."""
    n, b = W.shape
    MW = mass(W)
    G = W.T @ MW
    s, U = np.linalg.eigh(0.5 * (G + G.T))
    scale = max(float(s.max()), 0.0)
    keep = s > (_DEFLATE**2) * scale if scale > 0 else np.zeros(b, bool)
    Uk, sk = U[:, keep], np.sqrt(s[keep])
    Q = W @ (Uk / sk)
    R = np.zeros((b, b))
    nk = int(keep.sum())
    R[:nk] = (Uk * sk).T
    # a second pass (the first squares the condition number of W): Q = Q2 L2, L2 upper
    # triangular and near the identity, so Q2 = Q L2^-1 is one product written in place
    if nk:
        G2 = Q.T @ mass(Q)
        L2 = sl.cholesky(0.5 * (G2 + G2.T), lower=False)
        np.matmul(Q, sl.solve_triangular(L2, np.eye(nk), lower=False), out=out[:, :nk])
        R[:nk] = L2 @ R[:nk]
    # (never more columns than the space has left)
    d = min(b - nk, out.shape[1] - nk, n - V.shape[1] - nk)
    if d > 0:  # deflation: fresh random directions keep the block's size
        Q = out[:, :nk]
        Z = rng.standard_normal((n, d))
        for _ in range(2):
            Z -= V @ (V.T @ mass(Z))
            Z -= Q @ (mass(Q).T @ Z)
        G3 = Z.T @ mass(Z)
        L3 = sl.cholesky(0.5 * (G3 + G3.T), lower=False)
        np.matmul(Z, sl.solve_triangular(L3, np.eye(d), lower=False), out=out[:, nk : nk + d])
    return nk + max(d, 0), R
