"""Linear least squares for models with fixed poles: residues, B, C and D from FRF data.

With the poles fixed, ``H(s) = C (sI - A)^-1 B + D`` is linear in B (for fixed C) and in
C and D (for fixed B). The fit starts from a least-squares frequency-domain (LSFD) estimate
of each pole's residue matrix, which is linear in the residues and separable by channel;
each mode's residue is then cut to rank one (a mode has one shape and one participation
vector), the model is realised in real block-diagonal form, and B and then C, D are
re-estimated in turn until the cost stops falling. Each step minimises the same cost
``sum |H - H_model|^2`` over its unknowns exactly, so the cost never rises.

Residual states (poles placed outside the band to take the effect of modes out there) have
a fixed B with one oscillator per input, so their residue matrices are free (rank up to
the number of inputs) and only their C rows are estimated.

Conventions: H (p, m, K) complex, s (K,) = i w rad/s; A (n, n) real block-diagonal, B (n, m),
C (p, n), D (p, m) real.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla


@dataclass(frozen=True)
class FixedPoleModel:
    """A real state-space model in block-diagonal modal form, with its residual states.

    Attributes
    ----------
    A : (n, n) block diagonal: 2x2 blocks [[sigma, -w], [w, sigma]] for each physical
        pole sigma + i w, and per residual pole and input the same block.
    B : (n, m), C : (p, n), D : (p, m).
    residual : (n,) True for states of residual poles (their B rows are fixed).
    poles : (k,) the physical poles (upper half plane), in block order.
    residual_poles : (r,) the residual poles (upper half plane).
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    residual: np.ndarray
    poles: np.ndarray
    residual_poles: np.ndarray


def _pair_block(pole: complex) -> np.ndarray:
    return np.array([[pole.real, -pole.imag], [pole.imag, pole.real]])


def realize(poles: np.ndarray, residues: np.ndarray, residual_poles: np.ndarray, p: int, m: int,
            D: np.ndarray | None = None) -> FixedPoleModel:  # fmt: skip
    """Real block-diagonal model of physical poles with rank-one residues
    ``R_j = c_j b_j^T`` and residual poles with zero C (to be fitted).

    Parameters
    ----------
    poles : (k,) complex, Im > 0. residues : (k, p, m) complex (cut to rank one here).
    residual_poles : (r,) complex, Im > 0.
    """
    k, r = len(poles), len(residual_poles)
    n = 2 * k + 2 * m * r
    A = np.zeros((n, n))
    B = np.zeros((n, m))
    C = np.zeros((p, n))
    for j, (lam, R) in enumerate(zip(poles, residues, strict=True)):
        u, sv, vh = np.linalg.svd(R, full_matrices=False)
        c = u[:, 0] * np.sqrt(sv[0])
        b = np.sqrt(sv[0]) * vh[0]  # R ~ c b^T
        sl = slice(2 * j, 2 * j + 2)
        A[sl, sl] = _pair_block(lam)
        # x_c = x1 + i x2 with x_c' = lam x_c + b^T u and y = c x_c + conj(c x_c)
        B[2 * j] = b.real
        B[2 * j + 1] = b.imag
        C[:, 2 * j] = 2.0 * c.real
        C[:, 2 * j + 1] = -2.0 * c.imag
    residual = np.zeros(n, bool)
    for j, lam in enumerate(residual_poles):
        for i in range(m):
            at = 2 * k + 2 * (j * m + i)
            sl = slice(at, at + 2)
            A[sl, sl] = _pair_block(lam)
            B[at, i] = 1.0
            residual[sl] = True
    D = np.zeros((p, m)) if D is None else np.asarray(D, float)
    return FixedPoleModel(A, B, C, D, residual, np.asarray(poles, complex),
                          np.asarray(residual_poles, complex))  # fmt: skip


def _pole_regressors(s: np.ndarray, poles: np.ndarray) -> np.ndarray:
    """(K, 2k) complex regressors of real residue parts: for r = a + i b at a pole pair,
    ``r/(s-l) + conj(r)/(s-conj(l)) = a g1 + b g2``."""
    d1 = 1.0 / (s[:, None] - poles[None, :])
    d2 = 1.0 / (s[:, None] - np.conj(poles)[None, :])
    return np.concatenate([d1 + d2, 1j * (d1 - d2)], axis=1)


def _stack(X: np.ndarray) -> np.ndarray:
    """Complex rows -> real and imaginary parts stacked (2 rows each)."""
    return np.concatenate([X.real, X.imag], axis=0)


def _lstsq(X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """Least squares with the columns of X scaled to unit norm first (and the solution
    scaled back): columns of far poles are orders of magnitude smaller than those of
    in-band ones, and an unscaled solve would cut them off as rank deficiency."""
    norms = np.linalg.norm(X, axis=0)
    norms = np.where(norms > 0, norms, 1.0)
    sol = sla.lstsq(X / norms, Y, lapack_driver="gelsy", check_finite=False)[0]
    return sol / norms[:, None]


def lsfd(s: np.ndarray, H: np.ndarray, poles: np.ndarray, *, feedthrough: bool = True,
         weights: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Unconstrained residues of every pole pair and the real feedthrough.

    Parameters
    ----------
    s : (K,) i w. H : (p, m, K). poles : (k,) Im > 0. weights : (K,) per frequency.

    Returns
    -------
    residues (k, p, m) complex, D (p, m) real.
    """
    p, m, K = H.shape
    k = len(poles)
    w = np.ones(K) if weights is None else np.asarray(weights, float)
    G = _pole_regressors(s, poles)  # (K, 2k)
    if feedthrough:
        G = np.concatenate([G, np.ones((K, 1))], axis=1)
    X = _stack(G * w[:, None])
    Y = _stack(H.reshape(p * m, K).T * w[:, None])  # (2K, p m)
    sol = _lstsq(X, Y)
    a, b = sol[:k], sol[k : 2 * k]
    residues = (a + 1j * b).reshape(k, p, m)
    D = sol[2 * k].reshape(p, m) if feedthrough else np.zeros((p, m))
    return residues, D


class Resolvent:
    """``(s_k I - A)^-1`` applied through A's eigen-decomposition (computed once)."""

    def __init__(self, A: np.ndarray, s: np.ndarray):
        self.lam, self.V = np.linalg.eig(A)
        self.Vinv = np.linalg.inv(self.V)
        self.q = 1.0 / (s[:, None] - self.lam[None, :])  # (K, n)

    def times(self, X: np.ndarray) -> np.ndarray:
        """(K, n, m): (s_k I - A)^-1 X for X (n, m)."""
        return np.einsum("ab,kb,bm->kam", self.V, self.q, self.Vinv @ X, optimize=True)

    def left(self, Cm: np.ndarray) -> np.ndarray:
        """(K, p, n): C (s_k I - A)^-1 for C (p, n)."""
        return np.einsum("pb,kb,bn->kpn", Cm @ self.V, self.q, self.Vinv, optimize=True)


def response(model: FixedPoleModel, s: np.ndarray) -> np.ndarray:
    """H (p, m, K) of the model at s (K,)."""
    R = Resolvent(model.A, s)
    F = R.times(model.B)  # (K, n, m)
    return np.einsum("pn,knm->pmk", model.C, F) + model.D[:, :, None]


def fit_c(R: Resolvent, B: np.ndarray, H: np.ndarray, feedthrough: bool,
          weights: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """C (p, n) and D (p, m) minimising the (weighted) cost for fixed A (in R) and B."""
    p, m, K = H.shape
    w = np.ones(K) if weights is None else np.asarray(weights, float)
    F = R.times(B) * w[:, None, None]  # (K, n, m)
    n = F.shape[1]
    X = np.transpose(F, (0, 2, 1)).reshape(K * m, n)  # rows (k, i)
    if feedthrough:
        X = np.concatenate([X, np.kron(w[:, None], np.eye(m))], axis=1)
    Y = np.transpose(H * w[None, None, :], (2, 1, 0)).reshape(K * m, p)  # rows (k, i)
    sol = _lstsq(_stack(X), _stack(Y)).real
    C = sol[:n].T
    D = sol[n:].T if feedthrough else np.zeros((p, m))
    return C, D


def fit_b(R: Resolvent, B: np.ndarray, C: np.ndarray, D: np.ndarray, H: np.ndarray,
          free: np.ndarray, feedthrough: bool,
          weights: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """B (free rows re-estimated, the others kept) and D minimising the (weighted) cost for
    fixed A (in R) and C. D is eliminated by centring the real parts over frequency with
    the weights."""
    p, m, K = H.shape
    w = np.ones(K) if weights is None else np.asarray(weights, float)
    G = R.left(C)  # (K, p, n)
    fixed = ~free
    target = np.transpose(H, (2, 0, 1)).astype(complex)  # (K, p, m)
    if fixed.any():
        target = target - np.einsum("kpn,nm->kpm", G[:, :, fixed], B[fixed])
    Gf = G[:, :, free]
    Xr, Xi = Gf.real, Gf.imag
    Yr, Yi = target.real, target.imag
    w2 = w**2 / np.sum(w**2)
    if feedthrough:  # D[o, i] adds to the real part only: centre the real rows (weighted)
        Xr = Xr - np.tensordot(w2, Xr, axes=1)
        Yr = Yr - np.tensordot(w2, Yr, axes=1)
    nf = int(free.sum())
    ww = w[:, None, None]
    X = np.concatenate([(Xr * ww).reshape(K * p, nf), (Xi * ww).reshape(K * p, nf)])
    Y = np.concatenate([(Yr * ww).reshape(K * p, m), (Yi * ww).reshape(K * p, m)])
    Bf = _lstsq(X, Y)
    B = B.copy()
    B[free] = Bf
    if feedthrough:
        resid = target.real - np.einsum("kpn,nm->kpm", Gf, Bf).real
        D = np.tensordot(w2, resid, axes=1)
    else:
        D = np.zeros((p, m))
    return B, D


def cost(R: Resolvent, B: np.ndarray, C: np.ndarray, D: np.ndarray, H: np.ndarray,
         weights: np.ndarray | None = None) -> float:  # fmt: skip
    """``sum w_k^2 |C (s_k I - A)^-1 B + D - H_k|^2`` over channels and frequencies."""
    F = R.times(B)
    E = np.einsum("pn,knm->pmk", C, F) + D[:, :, None] - H
    if weights is not None:
        E = E * np.asarray(weights, float)[None, None, :]
    return float(np.vdot(E, E).real)


def fit_fixed_poles(s: np.ndarray, H: np.ndarray, poles: np.ndarray,
                    residual_poles: np.ndarray | None = None, *,
                    feedthrough: bool = True, max_iter: int = 50, tol: float = 1e-7,
                    weights: np.ndarray | None = None,
                    ) -> tuple[FixedPoleModel, list[float]]:  # fmt: skip
    """The model with the given poles that fits H best: LSFD residues of all poles (the
    residual ones included), rank-one cut and realisation, then alternating B and (C, D)
    estimates until the relative fall of the cost is below ``tol``.

    Parameters
    ----------
    s : (K,) i w, rad/s. H : (p, m, K). poles, residual_poles : Im > 0.

    Returns
    -------
    The model and the cost after each (C, D) estimate.
    """
    p, m, _ = H.shape
    poles = np.asarray(poles, complex)
    residual_poles = np.asarray([] if residual_poles is None else residual_poles, complex)
    if (poles.imag <= 0).any() or (residual_poles.imag <= 0).any():
        raise ValueError("poles must be given by their member with positive imaginary part")
    everything = np.concatenate([poles, residual_poles])
    residues, D0 = lsfd(s, H, everything, feedthrough=feedthrough, weights=weights)
    model = realize(poles, residues[: len(poles)], residual_poles, p, m, D0)
    R = Resolvent(model.A, s)
    B = model.B
    free = ~model.residual
    C, D = fit_c(R, B, H, feedthrough, weights)
    history = [cost(R, B, C, D, H, weights)]
    for _ in range(max_iter):
        if not free.any():
            break
        B, D = fit_b(R, B, C, D, H, free, feedthrough, weights)
        C, D = fit_c(R, B, H, feedthrough, weights)
        history.append(cost(R, B, C, D, H, weights))
        if history[-2] - history[-1] <= tol * history[-2]:
            break
    out = FixedPoleModel(model.A, B, C, D, model.residual, poles, residual_poles)
    return out, history
