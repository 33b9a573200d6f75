"""Eigen-sensitivities of mass-normalised modes: eigenvalue and eigenvector derivatives.

``dlam_j = phi_j^T (dK - lam_j dM) phi_j`` (Fox and Kapoor 1968). Eigenvector derivatives by
the modal method where the modes of a basis are at hand (the surrogate, the exact gradient's
known part), and by Nelson's method (1976, one sparse solve per mode, no other modes) on
the full matrices.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla


def _eigenvalue_derivatives(G_diag: np.ndarray, N_diag: np.ndarray,
                            lam: np.ndarray) -> np.ndarray:  # fmt: skip
    """dlam (m,) = phi^T dK phi - lam phi^T dM phi from those products' diagonals."""
    return G_diag - lam * N_diag


def inverse_gaps(lam: np.ndarray, lam_all: np.ndarray) -> np.ndarray:
    """(r, m) 1 / (lam_j - lam_k) for the m modes lam (m,) and all r modes lam_all (r,),
    0 where the pair is repeated. A pair counts as repeated relative to its own eigenvalues
    (not the basis's largest, which stiff or massless directions make huge)."""
    gap = lam[None, :] - lam_all[:, None]  # [k, j] = lam_j - lam_k
    tiny = 1e-12 * np.maximum(np.maximum(np.abs(lam)[None, :], np.abs(lam_all)[:, None]), 1.0)
    big = np.abs(gap) > tiny
    return np.where(big, 1.0 / np.where(big, gap, 1.0), 0.0)


def eigen_derivatives(G: np.ndarray, N: np.ndarray, lam: np.ndarray, inv_gap: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Eigenvalue derivatives dlam (m,) and eigenvector coefficients c (r, m), dphi_j =
    sum_k c_kj phi_k, of m mass-normalised modes from G = Phi^T dK Phi_m and
    N = Phi^T dM Phi_m (r, m), their eigenvalues lam (m,) and :func:`inverse_gaps`:
    ``dlam_j = G_jj - lam_j N_jj``, ``c_kj = (G_kj - lam_j N_kj) / (lam_j - lam_k)``,
    ``c_jj = -N_jj / 2`` (Fox and Kapoor; the modal method). G and N may carry leading
    axes (several parameters at once, (..., r, m)); dlam and c then carry them too."""
    diag = np.arange(len(lam))
    dlam = _eigenvalue_derivatives(G[..., diag, diag], N[..., diag, diag], lam)
    c = (G - N * lam) * inv_gap
    c[..., diag, diag] = -0.5 * N[..., diag, diag]
    return dlam, c


def eigenvalue_sensitivities(shapes: np.ndarray, eigenvalues: np.ndarray, dK: sp.spmatrix,
                             dM: sp.spmatrix) -> np.ndarray:  # fmt: skip
    """dlam (k,) = phi^T (dK - lam dM) phi for mass-normalised shapes (n, k)."""
    KP = dK @ shapes
    MP = dM @ shapes
    return _eigenvalue_derivatives(np.einsum("nk,nk->k", shapes, KP),
                                   np.einsum("nk,nk->k", shapes, MP), eigenvalues)  # fmt: skip


def eigenvector_sensitivity(K: sp.spmatrix, M: sp.spmatrix, phi: np.ndarray, lam: float,
                            dK: sp.spmatrix, dM: sp.spmatrix) -> np.ndarray:  # fmt: skip
    """dphi (n,) of one mass-normalised mode by Nelson's method (distinct eigenvalue).

    ``(K - lam M) v = -(dK - lam dM) phi + dlam M phi`` is solved with the component of
    largest amplitude fixed at zero (the matrix is singular along phi), then
    ``dphi = v + c phi`` with ``c = -phi^T M v - phi^T dM phi / 2`` keeps the mass
    normalisation.
    """
    K, M, dK, dM = (sp.csc_matrix(x) for x in (K, M, dK, dM))
    dlam = float(_eigenvalue_derivatives(phi @ (dK @ phi), phi @ (dM @ phi), lam))
    rhs = -(dK @ phi - lam * (dM @ phi)) + dlam * (M @ phi)
    A = (K - lam * M).tolil()
    k = int(np.argmax(np.abs(phi)))
    A[k, :] = 0.0
    A[:, k] = 0.0
    A[k, k] = 1.0
    rhs = rhs.copy()
    rhs[k] = 0.0
    v = spla.splu(sp.csc_matrix(A)).solve(rhs)
    c = -float(phi @ (M @ v)) - 0.5 * float(phi @ (dM @ phi))
    return v + c * phi
