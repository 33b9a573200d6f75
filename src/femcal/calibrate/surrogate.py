"""The reduced surrogate of the FE model and its FRFs with analytic parameter derivatives.

Around a centre point p_c the FE model is reduced on its own mass-normalised modes Phi
(n_g, r) there (the study used the first 100 flexible modes). FEMCali's surrogate is first
order::

    K~(p) = Lambda + sum_i (p_i - p_c,i) Phi^T dK/dp_i Phi
    M~(p) = I      + sum_i (p_i - p_c,i) Phi^T dM/dp_i Phi

with dK/dp_i, dM/dp_i exact (:mod:`femcal.calibrate.derivatives`): the reduced model exactly
for one parameter that K and M depend on linearly (moduli, areas, masses), first order for
thicknesses (bending goes with T^3) and for products (a shell's stiffness goes with E T).
femcal's default (``order="exact"``) keeps every term instead: each group of elements that
shares its parameters contributes the exact polynomial in them
(:func:`femcal.calibrate.derivatives.group_polynomials`; where the dependence is rational,
as the CQUAD4's and CTRIA3's transverse shear in T, an interpolant of raised degree that
reproduces it to 1e-9), so the surrogate is the full model's Rayleigh-Ritz reduction on the
basis at any p, and only the basis is approximate.
The surrogate's modes come from the small dense problem
``K~ psi = lam M~ psi``, every mode gets the same modal damping zeta0, and the FRFs at the
sensor channels C (n_out, r) = C_g Phi and inputs B (n_in, r) are::

    H(w) = sum_j (C psi_j)(B psi_j)^T q_j(w)
    q_j(w) = (i w)^a / (lam_j - w^2 + 2 i zeta0 sqrt(lam_j) w)

(a = 0, 1, 2 for receptance, mobility, accelerance). Their derivatives follow from the
exact eigen-derivatives of the small problem (all r modes are at hand):
``dlam_j = psi_j^T (dK~ - lam_j dM~) psi_j`` and
``dpsi_j = sum_k c_kj psi_k`` with ``c_kj = psi_k^T (dK~ - lam_j dM~) psi_j / (lam_j - lam_k)``
(k != j) and ``c_jj = -psi_j^T dM~ psi_j / 2``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from math import comb

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from ..assembly import Options, assemble
from ..model import EigenRequest
from ..model.model import Model
from ..response.frf import QUANTITIES, channel_matrix
from ..solve.eigen import DEFAULT_SHIFT_HZ
from ..solve.factor import NotPositiveDefinite, factorize
from ..solve.normal_modes import solve_normal_modes
from .derivatives import GroupPolynomial, group_polynomials
from .parameters import Parameter, with_values

_POWER = {"receptance": 0, "mobility": 1, "accelerance": 2}
#: Surrogate orders: every polynomial term, or the first-order terms alone (FEMCali's).
ORDERS = ("exact", "first-order")


def modal_factors(lam: np.ndarray, freq_hz: np.ndarray, zeta: float, quantity: str
                  ) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Modal factors q (r, n_f) = (i w)^a / (lam - w^2 + 2 i zeta sqrt(lam) w) and
    dq/dlam (r, n_f) of eigenvalues lam (r,) (rad^2/s^2) at freq_hz (n_f,)."""
    w = 2 * np.pi * np.asarray(freq_hz, float)
    root = np.sqrt(np.maximum(lam, 0.0))
    Dn = lam[:, None] - w[None, :] ** 2 + 2j * zeta * root[:, None] * w[None, :]
    num = (1j * w[None, :]) ** _POWER[quantity]
    q = num / Dn
    safe = np.where(root > 0, root, 1.0)
    dD = 1.0 + np.where(root[:, None] > 0, 1j * zeta * w[None, :] / safe[:, None], 0.0)
    return q, -q * dD / Dn


def static_factor(freq_hz: np.ndarray, quantity: str) -> np.ndarray:
    """(i w)^a (n_f,): a static receptance as this quantity."""
    return (2j * np.pi * np.asarray(freq_hz, float)) ** _POWER[quantity]


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
    ``c_jj = -N_jj / 2`` (Fox and Kapoor; the modal method)."""
    diag = np.arange(len(lam))
    dlam = G[diag, diag] - lam * N[diag, diag]
    c = (G - N * lam[None, :]) * inv_gap
    c[diag, diag] = -0.5 * N[diag, diag]
    return dlam, c


@dataclass(frozen=True)
class Surrogate:
    """Reduced model around ``p_center`` (see the module docstring).

    Attributes
    ----------
    p_center : (n_p,) scaled parameters of the centre.
    K0, M0 : (r, r) reduced stiffness (rad^2/s^2 per unit modal mass) and mass at the centre.
    exponents : (n_terms, n_p) exponent of each offset ``p_i - p_c,i`` in each term.
    Kt, Mt : (n_terms, r, r) the terms' reduced coefficient matrices.
    C : (n_out, r) sensor channels on the basis; B : (n_in, r) inputs on the basis.
    zeta : modal damping ratio of every mode.
    quantity : receptance, mobility or accelerance.
    basis_hz : (n_modes,) frequencies of the basis modes at the centre.
    n_frf : how many of the lowest surrogate modes make the FRFs (0: all r). With an
        enriched basis (static eigenvector-derivative vectors after the modes) the FRFs sum
        the n_modes lowest modes, as the unenriched surrogate and the full model's modal
        FRFs do; the extra vectors serve the eigenvector derivatives.
    residual : the FRFs add the residual flexibility of the modes beyond the n_frf lowest,
        ``C K~^-1 B^T - sum_{j < n_frf} (C psi_j)(B psi_j)^T / lam_j``, which is the sum
        over the other Ritz modes (no cancellation). The basis then holds the static
        responses to the inputs, so at the centre this is the full model's residual
        flexibility (:func:`femcal.response.frf.residual_flexibility`).
    exact : the full model's exact FRF derivatives at the centre
        (:class:`femcal.calibrate.gradient.CentreDerivatives`), when asked for.
    """

    p_center: np.ndarray
    K0: np.ndarray
    M0: np.ndarray
    exponents: np.ndarray
    Kt: np.ndarray
    Mt: np.ndarray
    C: np.ndarray
    B: np.ndarray
    zeta: float
    quantity: str
    basis_hz: np.ndarray
    n_frf: int = 0
    residual: bool = False
    exact: object | None = None

    @property
    def n_params(self) -> int:
        return len(self.p_center)

    def _weights(self, p: np.ndarray) -> np.ndarray:
        """(n_terms,) value of each term's monomial at p."""
        d = np.asarray(p, float) - self.p_center
        return np.prod(d[None, :] ** self.exponents, axis=1)

    def _weight_derivatives(self, p: np.ndarray) -> np.ndarray:
        """(n_terms, n_p) derivative of each monomial with respect to each p_i."""
        d = np.asarray(p, float) - self.p_center
        E = self.exponents
        out = np.zeros(E.shape, float)
        for i in range(self.n_params):
            has = E[:, i] > 0
            if not has.any():
                continue
            Ei = E[has].copy()
            Ei[:, i] -= 1
            out[has, i] = E[has, i] * np.prod(d[None, :] ** Ei, axis=1)
        return out

    def matrices(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """K~(p), M~(p) (r, r)."""
        w = self._weights(p)
        K = self.K0 + np.tensordot(w, self.Kt, axes=1)
        M = self.M0 + np.tensordot(w, self.Mt, axes=1)
        return 0.5 * (K + K.T), 0.5 * (M + M.T)

    def derivatives(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """dK~/dp, dM~/dp (n_p, r, r) at p."""
        W = self._weight_derivatives(p)
        return np.tensordot(W.T, self.Kt, axes=1), np.tensordot(W.T, self.Mt, axes=1)

    def modes(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Eigenvalues (r,) ascending and M~-normalised eigenvectors (r, r) at p.

        Solved inverted, ``M~ psi = mu (K~ - s M~) psi`` with ``lam = s + 1 / mu`` (s =
        STATIC_SHIFT): the dense solver's error is eps times the largest |eigenvalue|, which
        is the stiffest direction's for ``K~ psi = lam M~ psi`` (an enriched basis holds
        directions 1e4 times stiffer than its modes: measured noise 5e-6 in a deviation of
        0.6, enough to stall LM) but the softest mode's here (noise 5e-10)."""
        K, M = self.matrices(p)
        try:
            mu, psi = sla.eigh(M, K - STATIC_SHIFT * M)
        except np.linalg.LinAlgError:  # K~ - s M~ not positive definite (far outside the box)
            return sla.eigh(K, M)
        mu, psi = mu[::-1], psi[:, ::-1]  # psi^T (K~ - s M~) psi = 1, so psi^T M~ psi = mu
        if not mu[0] > 0:  # M~ not positive semi-definite: let the direct solver say so
            return sla.eigh(K, M)
        # directions with (almost) no mass (static responses through massless rotations):
        # eigenvalues 1e13 times the softest stand for infinite ones
        mu = np.maximum(mu, 1e-13 * mu[0])
        return STATIC_SHIFT + 1.0 / mu, psi / np.sqrt(mu)

    def frequencies_hz(self, p: np.ndarray) -> np.ndarray:
        lam = self.modes(p)[0]
        return np.sign(lam) * np.sqrt(np.abs(lam)) / (2 * np.pi)

    def frf(self, p: np.ndarray, freq_hz: np.ndarray) -> np.ndarray:
        """H (n_out, n_in, n_f) at p."""
        lam_all, psi_all = self.modes(p)
        m = self._n_frf
        lam, psi = lam_all[:m], psi_all[:, :m]
        q = self._q(lam, freq_hz)[0]
        S, P = self.C @ psi, self.B @ psi
        H = np.einsum("oj,ij,jf->oif", S, P, q, optimize=True)
        if self.residual:  # K~^-1 = Psi Lam^-1 Psi^T: the Ritz modes beyond the m lowest
            rest = psi_all[:, m:]
            R = ((self.C @ rest) / lam_all[m:]) @ (self.B @ rest).T
            H = H + R[:, :, None] * self._static_factor(freq_hz)[None, None, :]
        return H

    def _static_factor(self, freq_hz: np.ndarray) -> np.ndarray:
        return static_factor(freq_hz, self.quantity)

    @property
    def _n_frf(self) -> int:
        return self.n_frf or self.K0.shape[0]

    def _q(self, lam: np.ndarray, freq_hz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return modal_factors(lam, freq_hz, self.zeta, self.quantity)

    def frf_and_jacobian(self, p: np.ndarray, freq_hz: np.ndarray
                         ) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
        """H (n_out, n_in, n_f) and dH/dp (n_p, n_out, n_in, n_f) at p."""
        lam_all, psi_all = self.modes(p)
        m = self._n_frf  # the FRF's modes: j < m; their derivatives use all r modes k
        lam, psi = lam_all[:m], psi_all[:, :m]
        q, dq = self._q(lam, freq_hz)
        S_all, P_all = self.C @ psi_all, self.B @ psi_all  # (n_out, r), (n_in, r)
        S, P = S_all[:, :m], P_all[:, :m]
        H = np.einsum("oj,ij,jf->oif", S, P, q, optimize=True)
        inv_gap = inverse_gaps(lam, lam_all)  # (r, m)
        n_o, n_i, n_f = H.shape
        dH = np.empty((self.n_params, n_o, n_i, n_f), complex)
        SP = np.einsum("oj,ij->oij", S, P).reshape(n_o * n_i, -1)  # (o i, m)
        dK, dM = self.derivatives(p)
        if self.residual:  # K~^-1 = Psi Lam^-1 Psi^T
            KiB = psi_all @ (P_all.T / lam_all[:, None])  # (r, n_in)
            CKi = (S_all / lam_all) @ psi_all.T  # (n_out, r)
            R = (S_all[:, m:] / lam_all[m:]) @ P_all[:, m:].T
            stat = self._static_factor(freq_hz)
            H = H + R[:, :, None] * stat[None, None, :]
        for i in range(self.n_params):
            G = psi_all.T @ (dK[i] @ psi)  # (r, m)
            N = psi_all.T @ (dM[i] @ psi)
            dlam, Cc = eigen_derivatives(G, N, lam, inv_gap)
            dS, dP = S_all @ Cc, P_all @ Cc
            shape_part = (np.einsum("oj,ij->oij", dS, P) + np.einsum("oj,ij->oij", S, dP))
            dH[i] = (shape_part.reshape(n_o * n_i, -1) @ q
                     + (SP * dlam[None, :]) @ dq).reshape(n_o, n_i, n_f)  # fmt: skip
            if self.residual:  # d(C K~^-1 B^T) less the m modes' static part
                dR = (-CKi @ dK[i] @ KiB
                      - (shape_part.reshape(n_o * n_i, -1) @ (1.0 / lam)).reshape(n_o, n_i)
                      + (SP * (dlam / lam**2)[None, :]).sum(axis=1).reshape(n_o, n_i))
                dH[i] += dR[:, :, None] * stat[None, None, :]
        return H, dH


def _shift_weight(a, b, c) -> float:
    """Weight of the term ``prod d_i^a_i`` (about p = 0) in the term ``prod (d_i - c_i)^b_i``
    about c: ``prod_i binom(a_i, b_i) c_i^(a_i - b_i)`` (0 unless a >= b). With b a unit
    vector it is the monomial's derivative at c."""
    if any(ai < bi for ai, bi in zip(a, b, strict=True)):
        return 0.0
    return float(np.prod([comb(int(ai), int(bi)) * ci ** (ai - bi)
                          for ai, bi, ci in zip(a, b, c, strict=True)]))  # fmt: skip


def _touched_rows(mats: list) -> np.ndarray:
    """Sorted indices of the rows with a stored entry in any of the CSR matrices (symmetric
    matrices: the same indices are their columns)."""
    hit = np.zeros(mats[0].shape[0], bool)
    for A in mats:
        hit[np.flatnonzero(np.diff(A.indptr))] = True
    return np.flatnonzero(hit)


def _reexpand(polys: list[GroupPolynomial], Phi: np.ndarray, center: np.ndarray, n_p: int, *,
              first_order: bool) -> tuple[list, list, list]:  # fmt: skip
    """Reduce each group's terms about p = 0 on the basis and re-expand them about the
    centre: ``C'_b = sum_{a >= b} C_a prod_i binom(a_i, b_i) c_i^(a_i - b_i)``; returns
    exponents (n_p,), reduced K and M of the non-constant terms (first order only if asked)."""
    exps, Kt, Mt = [], [], []
    for g in polys:
        idx = list(g.params)
        # a group's matrices touch only its elements' DOF: reduce on those rows of Phi
        rows = _touched_rows(g.K + g.M)
        P = np.ascontiguousarray(Phi[rows])

        def on_basis(A, rows=rows, P=P) -> np.ndarray:
            return P.T @ (A[rows][:, rows] @ P) if A.nnz else np.zeros((P.shape[1],) * 2)

        red = {tuple(a): (on_basis(Kc), on_basis(Mc))
               for a, Kc, Mc in zip(g.exponents, g.K, g.M, strict=True)}  # fmt: skip
        c = center[idx]
        for b in red:
            if sum(b) == 0 or (first_order and sum(b) > 1):
                continue
            Kb = np.zeros_like(red[b][0])
            Mb = np.zeros_like(red[b][1])
            for a, (Ka, Ma) in red.items():
                w = _shift_weight(a, b, c)
                if w:
                    Kb += w * Ka
                    Mb += w * Ma
            e = np.zeros(n_p, int)
            e[idx] = b
            exps.append(e)
            Kt.append(Kb)
            Mt.append(Mb)
    return exps, Kt, Mt


#: The negative shift (rad^2/s^2 per unit modal mass) of the static solves: K - SHIFT M is
#: positive definite for free-free models too (their rigid-body modes are in the basis).
#: It is the eigen solution's shift, so that solution's factor serves the static solves.
STATIC_SHIFT = -((2 * np.pi * DEFAULT_SHIFT_HZ) ** 2)
#: Derivative vectors whose own eigenvalue is above this times the basis's largest are
#: dropped (frequencies 100 times the basis's top).
STIFF_CUTOFF = 1e4


def _polynomial_derivative(polys: list[GroupPolynomial], center: np.ndarray, j: int,
                           X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """dK/dp_j X and dM/dp_j X (n_g, m) at ``center`` from the group polynomials about 0.

    The terms' matrices are summed with their weights first (one pass over their entries
    each), then multiplied once: a group of high degree has many terms, and X many columns.
    """
    dK, dM = [], []
    for g in polys:
        if j not in g.params:
            continue
        idx = list(g.params)
        unit = np.zeros(len(idx), int)
        unit[idx.index(j)] = 1
        c = center[idx]
        for a, Kc, Mc in zip(g.exponents, g.K, g.M, strict=True):
            w = _shift_weight(a, unit, c)
            if w == 0.0:
                continue
            if Kc.nnz:
                dK.append(w * Kc)
            if Mc.nnz:
                dM.append(w * Mc)
    dKX = sum(dK[1:], dK[0]) @ X if dK else np.zeros(X.shape)
    dMX = sum(dM[1:], dM[0]) @ X if dM else np.zeros(X.shape)
    return dKX, dMX


def _mass_root(M) -> sp.csr_matrix | None:
    """R (n_m, n) with R^T R = M when M is diagonal (lumped mass): the n_m rows with mass,
    scaled by the root of their mass. None when M has off-diagonal terms."""
    M = sp.csr_matrix(M)
    d = M.diagonal()
    if (d < 0).any() or M.count_nonzero() != np.count_nonzero(d):
        return None
    rows = np.flatnonzero(d)
    return sp.csr_matrix((np.sqrt(d[rows]), (np.arange(len(rows)), rows)),
                         shape=(len(rows), M.shape[0]))  # fmt: skip


def _gram(Y: np.ndarray) -> np.ndarray:
    """Y^T Y (k, k) of Y (n, k) by a symmetric rank-k update (half a general product)."""
    upper = sla.blas.dsyrk(1.0, np.asfortranarray(Y.T) if not Y.T.flags.f_contiguous else Y.T)
    return np.triu(upper) + np.triu(upper, 1).T


def _m_compress(X: np.ndarray, M, Phi: np.ndarray, n_keep: int) -> np.ndarray:
    """The at most ``n_keep`` strongest directions of X (n_g, k), unit-normalised, after
    making it M-orthogonal to the M-orthonormal basis Phi (n_g, r): (n_g, q) M-orthonormal
    columns, M-orthogonal to Phi. Directions below 1e-10 of the strongest are dropped. X is
    overwritten when M is not diagonal.
    """
    # X' = X - Phi C, M-orthogonal to the basis (two passes: the static vectors lie mostly in
    # the basis, so one pass leaves rounding behind), and the Gram matrix X'^T M X'
    R = _mass_root(M)
    if R is not None:  # lumped mass: the M-products run over the rows with mass only
        Y, P = R @ X, R @ Phi
        C = np.zeros((Phi.shape[1], X.shape[1]))
        for _ in range(2):
            D = P.T @ Y
            Y -= P @ D
            C += D
        del P
        norms = np.sqrt(np.einsum("nk,nk->k", Y, Y))
        G = _gram(Y)
        del Y
    else:
        C = None
        for _ in range(2):
            X -= Phi @ (Phi.T @ (M @ X))
        MX = M @ X
        norms = np.sqrt(np.maximum(np.einsum("nk,nk->k", X, MX), 0.0))
        G = X.T @ MX
        del MX
    # the strongest directions of the unit-normalised set
    big = norms > 1e-12 * max(float(norms.max()), 1e-300)
    G = G[np.ix_(big, big)] / np.outer(norms[big], norms[big])
    w, V = np.linalg.eigh(0.5 * (G + G.T))
    order = np.argsort(w)[::-1]
    w, V = w[order], V[:, order]
    keep = w > 1e-10 * w[0]
    keep[n_keep:] = False
    W = V[:, keep] / np.sqrt(w[keep]) / norms[big][:, None]
    Q = X[:, big] @ W
    if C is not None:
        Q -= Phi @ (C[:, big] @ W)
    Q -= Phi @ (Phi.T @ (M @ Q))
    return Q


def derivative_vectors(polys: list[GroupPolynomial], center: np.ndarray, K: object,
                       M: object, red: object, Phi: np.ndarray, lam_basis: np.ndarray,
                       m: int, n_keep: int, depth: int = 2,
                       solve: Callable | None = None) -> np.ndarray:  # fmt: skip
    """Static eigenvector-derivative vectors to enrich a modal basis.

    The part of a mode's derivative dphi_i/dp_j outside the basis Phi is, up to terms in
    lam_i / lam_k of the modes k not in the basis, ``(K - s M)^-1 (dK_j - lam_i dM_j) phi_i``
    (s a small negative shift); ``depth`` terms of the series
    ``(K - lam M)^-1 = K^-1 + lam K^-1 M K^-1 + ...`` are taken. These vectors for the first
    m modes and every parameter, M-orthogonalised against Phi (n_g, r) and compressed to
    the ``n_keep`` strongest directions of the unit-normalised set, make the Rayleigh-Ritz
    surrogate's eigenvector derivatives (and so its FRF Jacobian) right at the centre, where
    the modes alone truncate them.

    Parameters
    ----------
    K, M : g-set matrices at the centre (sparse). red : the constraint reduction
        (:class:`femcal.assembly.constraints.Reduction`): the solves are on its a-set.
    Phi : (n_g, r) M-orthonormal basis at the centre whose first len(lam_basis) columns are
        the modes, lam_basis their eigenvalues; the first m modes get derivative vectors.
    solve : a factor of the a-set's K - STATIC_SHIFT M if one is at hand (the eigen
        solution's, :func:`femcal.solve.eigen.solve_modes` ``on_factor``); factored here if not.

    Returns
    -------
    (n_g, q) M-orthonormal vectors, M-orthogonal to Phi, q <= n_keep.
    """
    lam = lam_basis[:m]
    Ka, Ma = red.reduce(K), red.reduce(M)
    if solve is None:
        solve, _ = factorize((Ka - STATIC_SHIFT * Ma).tocsc())
    Tt = red.T.T.tocsr()
    cols = []
    for j in range(center.size):
        dKX, dMX = _polynomial_derivative(polys, center, j, Phi[:, :m])
        F = Tt @ (dKX - dMX * lam[None, :])
        if not np.any(F):
            continue
        Y = solve(F)
        cols.append(red.T @ Y)
        for _ in range(1, depth):  # (K - lam M)^-1 = K^-1 + lam K^-1 M K^-1 + ...
            Y = solve(Ma @ Y)
            cols.append(red.T @ Y)
    if not cols:
        return np.zeros((Phi.shape[0], 0))
    X = np.hstack(cols)
    del cols
    Q = _m_compress(X, M, Phi, n_keep)
    # the vectors' own modes (K- and M-orthogonal); those far above the basis (stiff
    # directions: axial bars, springs, drilling) are dropped: they add ~lam_i / theta to the
    # derivatives and would spoil the small eigenproblem's accuracy (its error is ~eps times
    # its largest eigenvalue)
    theta, U = sla.eigh(Q.T @ (K @ Q), Q.T @ (M @ Q))
    keep = theta <= STIFF_CUTOFF * float(np.max(np.abs(lam_basis)))
    return Q @ U[:, keep]


def stiffness_solve(K: object, red: object) -> Callable[[np.ndarray], np.ndarray]:
    """A factor of the a-set's K (unshifted) for static solves.

    Raises
    ------
    ValueError
        When K is singular (a free model has no static flexibility).
    """
    try:
        solve, _ = factorize(red.reduce(K).tocsc())
    except NotPositiveDefinite:
        raise ValueError("the residual flexibility needs a restrained model (K is singular: "
                         "free-free, or a mechanism)") from None  # fmt: skip
    return solve


def static_vectors(polys: list[GroupPolynomial], center: np.ndarray, solve: Callable,
                   red: object, Bg: object) -> np.ndarray:  # fmt: skip
    """The static responses to the inputs, X = K^-1 B_g^T (n_g, n_in), and their parameter
    derivatives ``-K^-1 dK/dp_j X`` for every parameter: (n_g, n_in (1 + n_p)) at most.
    ``solve`` is the a-set's K^-1 (:func:`stiffness_solve`)."""
    Tt = red.T.T.tocsr()
    B = np.asarray(sp.csr_matrix(Bg).T.todense())  # (n_g, n_in)
    X = red.T @ solve(Tt @ B)
    cols = [X]
    for j in range(center.size):
        dKX, _ = _polynomial_derivative(polys, center, j, X)
        if np.any(dKX):
            cols.append(red.T @ solve(Tt @ dKX))
    return np.hstack(cols)


def build_surrogate(model: Model, params: list[Parameter], p_center: np.ndarray,
                    outputs: Sequence, inputs: Sequence, *, n_modes: int = 100,
                    zeta: float = 0.01, quantity: str = "accelerance", order: str = "exact",
                    polynomials: list | None = None, options: Options | None = None,
                    enrich_hz: float | None = None, n_enrich: int | None = None,
                    residual: bool = False, frf_modes: int | None = None,
                    frf_hz: float | None = None, exact_gradient: bool = False,
                    progress: Callable[[str], None] | None = None,
                    ) -> tuple[Surrogate, object]:  # fmt: skip
    """Reduce the (nominal) model at ``p_center`` on its first ``n_modes`` modes there.

    Parameters
    ----------
    outputs, inputs : channels (``femcal.testdata.data.Channel``) of the test data.
    order : ``exact`` (every polynomial term) or ``first-order`` (FEMCali's).
    polynomials : the model's group polynomials about p = 0 with their constant terms
        (:func:`femcal.calibrate.derivatives.group_polynomials` with ``constant=True``);
        computed here if not given. They do not depend on the centre, so a run computes
        them once and reduces them on each new basis.
    enrich_hz : with it, the basis gets static eigenvector-derivative vectors of the modes
        up to this frequency (:func:`derivative_vectors`), at most ``n_enrich`` of them
        (default ``n_modes``); the FRFs still sum the ``n_modes`` lowest modes. This makes
        the Jacobian right at the centre (the modes alone truncate the eigenvector
        derivatives), which the trust-region cycles near the solution need.
    residual : the FRFs get the residual flexibility of the modes beyond the ``frf_modes``
        lowest (as :func:`femcal.response.frf.residual_flexibility`), the basis the static responses
        to the inputs and their parameter derivatives (:func:`static_vectors`). Needs a
        restrained model.
    frf_modes : the FRFs sum this many lowest modes (default ``n_modes``); with
        ``residual`` the others enter as residual flexibility. Or ``frf_hz``: the modes up
        to this frequency at the centre (at least one).
    exact_gradient : also compute the full model's exact FRF derivatives at the centre
        (:func:`femcal.calibrate.gradient.centre_derivatives`), kept as ``Surrogate.exact``.

    Returns
    -------
    The surrogate and the full model's modes at the centre
    (:class:`femcal.solve.normal_modes.Modes`).
    """
    if quantity not in QUANTITIES:
        raise ValueError(f"quantity must be one of {', '.join(QUANTITIES)}")
    if order not in ORDERS:
        raise ValueError(f"order must be one of {', '.join(ORDERS)}, not {order!r}")
    say = progress or (lambda _m: None)
    values = [par.value(p) for par, p in zip(params, p_center, strict=True)]
    model_c = with_values(model, params, values)
    mats = assemble(model_c, options)
    factor: dict = {}

    def keep_factor(solve: Callable, sigma: float) -> None:
        if abs(sigma - STATIC_SHIFT) <= 1e-12 * abs(STATIC_SHIFT):
            factor["solve"] = solve

    modes, red = solve_normal_modes(model_c, matrices=mats, request=EigenRequest(nd=n_modes),
                              on_factor=keep_factor if enrich_hz is not None or exact_gradient
                              else None)  # fmt: skip
    Phi = modes.shapes  # (n_g, r), mass-normalised
    n_frf = Phi.shape[1]
    if frf_hz is not None:
        if frf_modes is not None:
            raise ValueError("give frf_modes or frf_hz, not both")
        frf_modes = max(int(np.searchsorted(modes.frequencies_hz, frf_hz, side="right")), 1)
    if frf_modes is not None:
        if not 1 <= frf_modes <= n_frf:
            raise ValueError(f"frf_modes = {frf_modes}: expected 1 to the {n_frf} modes solved")
        n_frf = int(frf_modes)
    say(f"surrogate: {Phi.shape[1]} modes up to {modes.frequencies_hz[-1]:.1f} Hz; the "
        f"{order} dependence of K and M on {len(params)} parameters")
    if polynomials is None:
        polynomials = group_polynomials(model, params, np.zeros(len(params)), options=options,
                                        constant=True)  # fmt: skip
    Cg = channel_matrix(model, outputs)
    Bg = channel_matrix(model, inputs)
    n_basis_modes = Phi.shape[1]
    if enrich_hz is not None:
        m = int(np.searchsorted(modes.frequencies_hz, enrich_hz, side="right"))
        if m:
            extra = derivative_vectors(polynomials, np.asarray(p_center, float), mats.K,
                                       mats.M, red, Phi, modes.eigenvalues[:n_basis_modes], m,
                                       n_enrich or n_modes,
                                       solve=factor.get("solve"))  # fmt: skip
            Phi = np.hstack([Phi, extra])
            say(f"surrogate basis enriched: {extra.shape[1]} static eigenvector-derivative "
                f"vectors of the {m} modes up to {enrich_hz:g} Hz (the stiffer ones dropped)")
    static_solve = None
    if residual:
        if (modes.eigenvalues <= 0).any():
            raise ValueError("the residual flexibility needs a restrained model: a basis mode "
                             "is a rigid-body mode")  # fmt: skip
        static_solve = stiffness_solve(mats.K, red)
        X = static_vectors(polynomials, np.asarray(p_center, float), static_solve, red, Bg)
        block = _m_compress(X, mats.M, Phi, n_keep=X.shape[1])
        Phi = np.hstack([Phi, block])
        say(f"surrogate basis: {block.shape[1]} static responses to the inputs and their "
            "parameter derivatives (residual flexibility)")
    exps, Kt, Mt = _reexpand(polynomials, Phi, np.asarray(p_center, float), len(params),
                             first_order=order == "first-order")  # fmt: skip
    r = Phi.shape[1]
    K0 = Phi.T @ (mats.K @ Phi)
    M0 = Phi.T @ (mats.M @ Phi)
    sur = Surrogate(np.asarray(p_center, float), 0.5 * (K0 + K0.T), 0.5 * (M0 + M0.T),
                    np.array(exps, int).reshape(-1, len(params)),
                    np.array(Kt).reshape(-1, r, r), np.array(Mt).reshape(-1, r, r),
                    np.asarray(Cg @ Phi), np.asarray(Bg @ Phi), float(zeta), quantity,
                    modes.frequencies_hz.copy(), n_frf, residual)  # fmt: skip
    if exact_gradient:
        from .gradient import centre_derivatives  # (it builds on this module)

        exact = centre_derivatives(polynomials, np.asarray(p_center, float), mats.M, red,
                                   modes.shapes, modes.eigenvalues, Cg, Bg, n_frf,
                                   shifted_solve=factor.get("solve"), static_solve=static_solve,
                                   residual=residual, K=mats.K)  # fmt: skip
        sur = replace(sur, exact=exact)
        say(f"the full model's exact FRF derivatives at the centre ({exact.terms} series terms "
            "for the modes above the basis" + (")" if exact.tail == 0.0 else
            f"; capped, the top FRF modes' part is approximate: set modal_hz below the "
            f"basis's top, {modes.frequencies_hz[-1]:.0f} Hz)"))  # fmt: skip
    return sur, modes
