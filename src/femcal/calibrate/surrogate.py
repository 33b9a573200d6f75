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
(:func:`femcal.calibrate.derivatives.group_polynomials`), so the surrogate is the full
model's Rayleigh-Ritz reduction on the basis at any p, and only the basis is approximate.
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
from dataclasses import dataclass
from math import comb

import numpy as np
import scipy.linalg as sla

from ..deck.deck import Deck
from ..frf import QUANTITIES, channel_matrix
from ..modal import EigenRequest
from ..model.model import Model
from ..sol103 import solve_sol103
from ..structure import Options, assemble
from .derivatives import GroupPolynomial, group_polynomials
from .parameters import Parameter, with_values

_POWER = {"receptance": 0, "mobility": 1, "accelerance": 2}
#: Surrogate orders: every polynomial term, or the first-order terms alone (FEMCali's).
ORDERS = ("exact", "first-order")


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
    basis_hz : (r,) frequencies of the basis modes at the centre.
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
        """Eigenvalues (r,) ascending and M~-normalised eigenvectors (r, r) at p."""
        K, M = self.matrices(p)
        return sla.eigh(K, M)

    def frequencies_hz(self, p: np.ndarray) -> np.ndarray:
        lam = self.modes(p)[0]
        return np.sign(lam) * np.sqrt(np.abs(lam)) / (2 * np.pi)

    def frf(self, p: np.ndarray, freq_hz: np.ndarray) -> np.ndarray:
        """H (n_out, n_in, n_f) at p."""
        lam, psi = self.modes(p)
        q = self._q(lam, freq_hz)[0]
        S, P = self.C @ psi, self.B @ psi
        return np.einsum("oj,ij,jf->oif", S, P, q, optimize=True)

    def _q(self, lam: np.ndarray, freq_hz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Modal factors q (r, n_f) and dq/dlam (r, n_f)."""
        w = 2 * np.pi * np.asarray(freq_hz, float)
        root = np.sqrt(np.maximum(lam, 0.0))
        Dn = lam[:, None] - w[None, :] ** 2 + 2j * self.zeta * root[:, None] * w[None, :]
        num = (1j * w[None, :]) ** _POWER[self.quantity]
        q = num / Dn
        safe = np.where(root > 0, root, 1.0)
        dD = 1.0 + np.where(root[:, None] > 0, 1j * self.zeta * w[None, :] / safe[:, None], 0.0)
        return q, -q * dD / Dn

    def frf_and_jacobian(self, p: np.ndarray, freq_hz: np.ndarray
                         ) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
        """H (n_out, n_in, n_f) and dH/dp (n_p, n_out, n_in, n_f) at p."""
        lam, psi = self.modes(p)
        q, dq = self._q(lam, freq_hz)
        S, P = self.C @ psi, self.B @ psi  # (n_out, r), (n_in, r)
        H = np.einsum("oj,ij,jf->oif", S, P, q, optimize=True)
        gap = lam[None, :] - lam[:, None]  # [k, j] = lam_j - lam_k
        tiny = 1e-12 * max(float(np.abs(lam).max()), 1.0)
        inv_gap = np.where(np.abs(gap) > tiny, 1.0 / np.where(np.abs(gap) > tiny, gap, 1.0), 0.0)
        n_o, n_i, n_f = H.shape
        dH = np.empty((self.n_params, n_o, n_i, n_f), complex)
        SP = np.einsum("oj,ij->oij", S, P).reshape(n_o * n_i, -1)  # (o i, r)
        dK, dM = self.derivatives(p)
        for i in range(self.n_params):
            G = psi.T @ dK[i] @ psi
            N = psi.T @ dM[i] @ psi
            dlam = np.diag(G) - lam * np.diag(N)
            Cc = (G - N * lam[None, :]) * inv_gap
            np.fill_diagonal(Cc, -0.5 * np.diag(N))
            dS, dP = S @ Cc, P @ Cc
            shape_part = (np.einsum("oj,ij->oij", dS, P) + np.einsum("oj,ij->oij", S, dP))
            dH[i] = (shape_part.reshape(n_o * n_i, -1) @ q
                     + (SP * dlam[None, :]) @ dq).reshape(n_o, n_i, n_f)  # fmt: skip
        return H, dH


def _reexpand(polys: list[GroupPolynomial], Phi: np.ndarray, center: np.ndarray, n_p: int, *,
              first_order: bool) -> tuple[list, list, list]:  # fmt: skip
    """Reduce each group's terms about p = 0 on the basis and re-expand them about the
    centre: ``C'_b = sum_{a >= b} C_a prod_i binom(a_i, b_i) c_i^(a_i - b_i)``; returns
    exponents (n_p,), reduced K and M of the non-constant terms (first order only if asked)."""
    exps, Kt, Mt = [], [], []
    for g in polys:
        idx = list(g.params)
        red = {tuple(a): (Phi.T @ (Kc @ Phi), Phi.T @ (Mc @ Phi))
               for a, Kc, Mc in zip(g.exponents, g.K, g.M, strict=True)}  # fmt: skip
        c = center[idx]
        for b in red:
            if sum(b) == 0 or (first_order and sum(b) > 1):
                continue
            Kb = np.zeros_like(red[b][0])
            Mb = np.zeros_like(red[b][1])
            for a, (Ka, Ma) in red.items():
                if all(ai >= bi for ai, bi in zip(a, b, strict=True)):
                    w = float(np.prod([comb(ai, bi) * ci ** (ai - bi)
                                       for ai, bi, ci in zip(a, b, c, strict=True)]))  # fmt: skip
                    Kb += w * Ka
                    Mb += w * Ma
            e = np.zeros(n_p, int)
            e[idx] = b
            exps.append(e)
            Kt.append(Kb)
            Mt.append(Mb)
    return exps, Kt, Mt


def build_surrogate(deck: Deck, model: Model, params: list[Parameter], p_center: np.ndarray,
                    outputs: Sequence, inputs: Sequence, *, n_modes: int = 100,
                    zeta: float = 0.01, quantity: str = "accelerance", order: str = "exact",
                    polynomials: list | None = None, options: Options | None = None,
                    progress: Callable[[str], None] | None = None,
                    ) -> tuple[Surrogate, object]:  # fmt: skip
    """Reduce the (nominal) model at ``p_center`` on its first ``n_modes`` modes there.

    Parameters
    ----------
    outputs, inputs : channels (``femcal.frfdata.Channel``) of the test data.
    order : ``exact`` (every polynomial term) or ``first-order`` (FEMCali's).
    polynomials : the model's group polynomials about p = 0 with their constant terms
        (:func:`femcal.calibrate.derivatives.group_polynomials` with ``constant=True``);
        computed here if not given. They do not depend on the centre, so a run computes
        them once and reduces them on each new basis.

    Returns
    -------
    The surrogate and the full model's modes at the centre (:class:`femcal.sol103.Modes`).
    """
    if quantity not in QUANTITIES:
        raise ValueError(f"quantity must be one of {', '.join(QUANTITIES)}")
    if order not in ORDERS:
        raise ValueError(f"order must be one of {', '.join(ORDERS)}, not {order!r}")
    say = progress or (lambda _m: None)
    values = [par.value(p) for par, p in zip(params, p_center, strict=True)]
    model_c = with_values(model, params, values)
    mats = assemble(model_c, options)
    modes, _ = solve_sol103(deck, model_c, matrices=mats,
                            request=EigenRequest(nd=n_modes))  # fmt: skip
    Phi = modes.shapes  # (n_g, r), mass-normalised
    say(f"surrogate: {Phi.shape[1]} modes up to {modes.frequencies_hz[-1]:.1f} Hz; the "
        f"{order} dependence of K and M on {len(params)} parameters")
    if polynomials is None:
        polynomials = group_polynomials(model, params, np.zeros(len(params)), options=options,
                                        constant=True)  # fmt: skip
    exps, Kt, Mt = _reexpand(polynomials, Phi, np.asarray(p_center, float), len(params),
                             first_order=order == "first-order")  # fmt: skip
    r = Phi.shape[1]
    Cg = channel_matrix(model, outputs)
    Bg = channel_matrix(model, inputs)
    K0 = Phi.T @ (mats.K @ Phi)
    M0 = Phi.T @ (mats.M @ Phi)
    sur = Surrogate(np.asarray(p_center, float), 0.5 * (K0 + K0.T), 0.5 * (M0 + M0.T),
                    np.array(exps, int).reshape(-1, len(params)),
                    np.array(Kt).reshape(-1, r, r), np.array(Mt).reshape(-1, r, r),
                    np.asarray(Cg @ Phi), np.asarray(Bg @ Phi), float(zeta), quantity,
                    modes.frequencies_hz.copy())  # fmt: skip
    return sur, modes
