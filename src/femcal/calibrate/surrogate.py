"""The reduced surrogate of the FE model, evaluated: its matrices, modes and FRFs, and the
FRFs' Jacobian with respect to the parameters.

A :class:`Surrogate` is the FE model reduced on a basis Phi (n_g, r) about a centre p_c: the
reduced stiffness and mass there, ``K0 = Phi^T K Phi`` and ``M0 = Phi^T M Phi``, and the
reduced coefficient matrices ``Kt``, ``Mt`` of polynomial terms in the offsets
``d = p - p_c``::

    K~(p) = K0 + sum_t (prod_i d_i^e_ti) Kt_t
    M~(p) = M0 + sum_t (prod_i d_i^e_ti) Mt_t

With every term of the exact polynomial dependence of K and M on the parameters
(``order="exact"``) this is the full model's Rayleigh-Ritz reduction on the basis at any p,
and only the basis is approximate. With the first-order terms alone (``"first-order"``) it is
FEMCali's surrogate, ``K~(p) = K0 + sum_i d_i Phi^T dK/dp_i Phi`` and M~ alike: exact for one
parameter that K and M depend on linearly (moduli, areas, masses), first order for
thicknesses (bending goes with T^3) and for products (a shell's stiffness goes with E T).
How the basis and the terms are made (the full model's modes at the centre, 100 by default
as the reference study used its first 100 flexible modes, the enrichment and static vectors,
each element group's exact polynomial re-expanded about the centre) is
:mod:`femcal.calibrate.reduction` (:func:`~femcal.calibrate.reduction.build_surrogate`).

The surrogate's modes come from the small dense problem ``K~ psi = lam M~ psi`` (solved
inverted, :meth:`Surrogate.modes`), every mode gets the same modal damping zeta0, and the
FRFs at the sensor channels C (n_out, r) = C_g Phi and inputs B (n_in, r) sum the m =
``n_frf`` lowest modes::

    H(w) = sum_{j<m} (C psi_j)(B psi_j)^T q_j(w)
    q_j(w) = (i w)^a / (lam_j - w^2 + 2 i zeta0 sqrt(lam_j) w)

(a = 0, 1, 2 for receptance, mobility, accelerance), with the residual flexibility of the
other Ritz modes added if asked (``residual``). Their derivatives follow from the exact
eigen-derivatives of the small problem (all r modes are at hand):
``dlam_j = psi_j^T (dK~ - lam_j dM~) psi_j`` and
``dpsi_j = sum_k c_kj psi_k`` with ``c_kj = psi_k^T (dK~ - lam_j dM~) psi_j / (lam_j - lam_k)``
(k != j) and ``c_jj = -psi_j^T dM~ psi_j / 2``. The full model's exact FRF derivatives at the
centre, when computed, travel with the surrogate (``Surrogate.exact``) for the first-order
correction of :mod:`femcal.calibrate.gradient`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from ..response.modal import modal_factors_and_slopes, static_factor
from ..solve.eigen import DEFAULT_SHIFT_HZ
from .sensitivity import eigen_derivatives, inverse_gaps

#: Surrogate orders: every polynomial term, or the first-order terms alone (FEMCali's).
ORDERS = ("exact", "first-order")

#: The negative shift (rad^2/s^2 per unit modal mass) of the static solves: K - SHIFT M is
#: positive definite for free-free models too (their rigid-body modes are in the basis).
#: It is the eigen solution's shift, so that solution's factor serves the static solves.
STATIC_SHIFT = -((2 * np.pi * DEFAULT_SHIFT_HZ) ** 2)

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
        directions 1e4 times stiffer than its modes, and that rounding in the deviation is
        enough to stall LM) but the softest mode's here.

        The last point's answer is kept (read-only): a search asks for the modes at an
        accepted point twice, for its residuals and then for its Jacobian."""
        key = np.asarray(p, float).tobytes()
        last = self.__dict__.get("_modes_at")
        if last is not None and last[0] == key:
            return last[1]
        lam, psi = self._solve_modes(p)
        lam.flags.writeable = psi.flags.writeable = False
        object.__setattr__(self, "_modes_at", (key, (lam, psi)))  # (a cache, not a field)
        return lam, psi

    def __getstate__(self) -> dict:
        """The fields for pickling, without the kept modes (a copy elsewhere keeps its own)."""
        return {k: v for k, v in self.__dict__.items() if k != "_modes_at"}

    def _solve_modes(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`modes` without the kept answer."""
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
        return modal_factors_and_slopes(lam, freq_hz, self.zeta, self.quantity)

    def frf_and_jacobian(self, p: np.ndarray, freq_hz: np.ndarray,
                         which: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """H (n_out, n_in, n_f) and dH/dp (n_p, n_out, n_in, n_f) at p; with ``which``
        (n_p,) bool the derivatives by those parameters only (the others' are zero)."""
        H, sel, X = self.frf_and_jacobian_parts(p, freq_hz, which)
        n_f = H.shape[2]
        dH = np.zeros((self.n_params, *H.shape), complex)
        dH[sel] = X[..., :n_f] + 1j * X[..., n_f:]
        return H, dH

    def frf_and_jacobian_parts(self, p: np.ndarray, freq_hz: np.ndarray,
                               which: np.ndarray | None = None
                               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
        """H (n_out, n_in, n_f), the parameters differentiated by (``which``'s, all without
        it) as indices sel (n_sel,), and their dH/dp as real and imaginary parts side by
        side, X (n_sel, n_out, n_in, 2 n_f): ``dH[sel] = X[..., :n_f] + i X[..., n_f:]``.

        Every parameter's derivative is made at once: the real modal coefficients of all of
        them, (n_sel n_out n_in, 2 m) for the shapes' and the eigenvalues' parts, times the
        real and imaginary parts of q and dq/dlam, (2 m, 2 n_f), in one real product (half
        the arithmetic of a complex one, which would first turn the coefficients complex)."""
        lam_all, psi_all = self.modes(p)
        m = self._n_frf  # the FRF's modes: j < m; their derivatives use all r modes k
        lam, psi = lam_all[:m], psi_all[:, :m]
        q, dq = self._q(lam, freq_hz)
        S_all, P_all = self.C @ psi_all, self.B @ psi_all  # (n_out, r), (n_in, r)
        S, P = S_all[:, :m], P_all[:, :m]
        H = np.einsum("oj,ij,jf->oif", S, P, q, optimize=True)
        n_o, n_i, n_f = H.shape
        if self.residual:  # K~^-1 = Psi Lam^-1 Psi^T
            stat = self._static_factor(freq_hz)
            R = (S_all[:, m:] / lam_all[m:]) @ P_all[:, m:].T
            H = H + R[:, :, None] * stat[None, None, :]
        sel = np.arange(self.n_params) if which is None else np.flatnonzero(which)
        if not sel.size:
            return H, sel, np.zeros((0, n_o, n_i, 2 * n_f))
        W = self._weight_derivatives(p)[:, sel]  # (n_terms, n_sel)
        dK = np.tensordot(W.T, self.Kt, axes=1)  # (n_sel, r, r)
        dM = np.tensordot(W.T, self.Mt, axes=1)
        G = psi_all.T @ (dK @ psi)  # (n_sel, r, m)
        N = psi_all.T @ (dM @ psi)
        dlam, Cc = eigen_derivatives(G, N, lam, inverse_gaps(lam, lam_all))
        dS, dP = S_all @ Cc, P_all @ Cc  # (n_sel, n_out, m), (n_sel, n_in, m)
        # per parameter and output-input pair: m shape coefficients, then m of dlam
        A = np.empty((sel.size, n_o, n_i, 2 * m))
        A[..., :m] = dS[:, :, None, :] * P[None, None] + S[None, :, None, :] * dP[:, None]
        A[..., m:] = (S[:, None, :] * P[None, :, :])[None] * dlam[:, None, None, :]
        Q = np.empty((2 * m, 2 * n_f))
        Q[:m, :n_f], Q[:m, n_f:], Q[m:, :n_f], Q[m:, n_f:] = q.real, q.imag, dq.real, dq.imag
        X = (A.reshape(-1, 2 * m) @ Q).reshape(sel.size, n_o, n_i, 2 * n_f)
        if self.residual:  # d(C K~^-1 B^T) less the m modes' static part
            KiB = psi_all @ (P_all.T / lam_all[:, None])  # (r, n_in)
            CKi = (S_all / lam_all) @ psi_all.T  # (n_out, r)
            dR = (-(CKi @ dK @ KiB) - A[..., :m] @ (1.0 / lam)
                  + A[..., m:] @ (1.0 / lam**2))  # (n_sel, n_out, n_in)
            X[..., :n_f] += dR[..., None] * stat.real
            X[..., n_f:] += dR[..., None] * stat.imag
        return H, sel, X
