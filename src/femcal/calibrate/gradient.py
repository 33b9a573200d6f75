"""The full model's exact FRF Jacobian at a surrogate's centre, and the first-order
correction that makes the surrogate agree with it there.

The surrogate is the full model at its centre, but its Jacobian there is not the full
model's: its eigenvector derivatives are truncated to the basis. The trust-region cycles
then converge only linearly, and slowly where the test informs a parameter weakly. With the
full model's Jacobian J at the centre c, the surrogate's residuals get the linear correction
``eps~(p) = eps_s(p) + (J - J_s(c)) (p - c)``, which makes it agree with the full model to
first order at c (Alexandrov et al. 1998, first-order consistent trust regions): near a
solution the cycles converge like Gauss-Newton on the full model.

The Jacobian of the full model's FRF, ``H = sum_{j<m} (C phi_j)(B phi_j)^T q_j(lam_j)``
(+ the residual flexibility ``R = C K^-1 B^T - sum_{j<m} (C phi_j)(B phi_j)^T / lam_j``),
needs the eigenvalue derivatives (Fox and Kapoor) and the sensors' view of the eigenvector
derivatives, ``C dphi_j`` and ``B dphi_j``. With the r computed modes
(M-orthonormal) and their eigenvalues,
``dphi_j = sum_{k != j} phi_k phi_k^T f_j / (lam_k - lam_j) - phi_j phi_j^T dM phi_j / 2``
with ``f_j = -(dK - lam_j dM) phi_j``. The modes k < r are at hand; the part over the modes
above them is summed through the shifted factor of the eigen solution (s < 0):
``1 / (lam_k - lam_j) = sum_n (lam_j - s)^n / (lam_k - s)^(n+1)``, so that
``S sum_{k>=r} phi_k phi_k^T f_j / (lam_k - lam_j) = sum_n (lam_j - s)^n Z_n^T f_j`` with
``Z_n = Q (K - sM)^-1 [M (K - sM)^-1]^n S^T``, Q removing the r modes, and S the sensor
and input rows (a few dozen): N block solves serve every mode and parameter (adjoint
form). The series converges as ``((lam_j - s) / (lam_r - s))^N``: fast for FRF modes well
below the basis's top (the residual form with ``modal_hz``), slowly for the top modes of a
basis that all enter the FRFs (the number of terms is capped, and the progress line says
so).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from threadpoolctl import threadpool_limits

from ..parallel import usable_cores
from ..parallel.cluster import result_of
from ..parallel.executors import beside
from ..response.modal import modal_factors_and_slopes, static_factor
from ..solve.factor import factorize
from .derivatives import GroupPolynomial, polynomial_derivative_rows
from .metric import jacobian
from .sensitivity import eigen_derivatives, inverse_gaps
from .surrogate import STATIC_SHIFT, Surrogate

#: Relative accuracy asked of the series for the out-of-basis part.
SERIES_TOL = 1e-10
#: The series' size (a-set DOF x sensors x terms) from which half the sensors' series runs
#: beside (with ``beside_ok``): below it, a fork costs about what it saves.
SPLIT_WORK = 2e7
#: At most this many series terms per mode (each one block solve with n_out + n_in
#: columns); a mode 0.28 of the basis's top frequency converges in 12 (ratio 0.08).
MAX_TERMS = 12


@dataclass(frozen=True)
class CentreDerivatives:
    """The full model's FRF ingredients and their exact parameter derivatives at a centre.

    lam : (m,) eigenvalues (rad^2/s^2) of the modes the FRFs sum.
    S : (n_out, m) outputs C phi_j; P : (n_in, m) inputs B phi_j.
    dlam : (n_p, m); d_S : (n_p, n_out, m); d_P : (n_p, n_in, m), per unit of scaled p.
    R, d_R : (n_out, n_in) residual flexibility and (n_p, n_out, n_in) its derivatives, or
        None without the residual.
    terms : series terms taken; tail : bound on the relative truncation of the series for
        the highest FRF mode (0 when converged to SERIES_TOL).
    exact_to_hz : the FRF modes up to this frequency (Hz) have converged series (every
        mode when ``tail`` is 0): ``modal_hz`` at most this makes every derivative exact.
    """

    lam: np.ndarray
    S: np.ndarray
    P: np.ndarray
    dlam: np.ndarray
    d_S: np.ndarray  # noqa: N815 (the docstring's symbols)
    d_P: np.ndarray  # noqa: N815
    R: np.ndarray | None
    d_R: np.ndarray | None  # noqa: N815
    terms: int
    tail: float
    exact_to_hz: float = float("inf")

    def frf_and_jacobian(self, freq_hz: np.ndarray, zeta: float, quantity: str
                         ) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
        """H (n_out, n_in, n_f) and dH/dp (n_p, n_out, n_in, n_f) of the full model."""
        q, dq = modal_factors_and_slopes(self.lam, freq_hz, zeta, quantity)
        H = np.einsum("oj,ij,jf->oif", self.S, self.P, q, optimize=True)
        dH = (np.einsum("poj,ij,jf->poif", self.d_S, self.P, q, optimize=True)
              + np.einsum("oj,pij,jf->poif", self.S, self.d_P, q, optimize=True)
              + np.einsum("oj,ij,pj,jf->poif", self.S, self.P, self.dlam, dq, optimize=True))
        if self.R is not None:
            stat = static_factor(freq_hz, quantity)
            H = H + self.R[:, :, None] * stat[None, None, :]
            dH = dH + self.d_R[:, :, :, None] * stat[None, None, None, :]
        return H, dH


def centre_derivatives(polys: list[GroupPolynomial], center: np.ndarray, M: sp.spmatrix,
                       red: object, Phi: np.ndarray, lam: np.ndarray, Cg: sp.spmatrix,
                       Bg: sp.spmatrix, m: int, *, shifted_solve: Callable | None = None,
                       static_solve: Callable | None = None, residual: bool = False,
                       K: sp.spmatrix | None = None, beside_ok: bool = False
                       ) -> CentreDerivatives:  # fmt: skip
    """Exact derivatives of the FRF ingredients at ``center`` (see the module docstring).

    Parameters
    ----------
    polys : the group polynomials about p = 0 (their derivatives at ``center`` are exact).
    M : g-set mass at the centre; K too when no ``shifted_solve`` is given.
    red : the constraint reduction (solves on its a-set).
    Phi : (n_g, r) the mass-normalised modes at the centre, lam (r,) their eigenvalues.
    Cg, Bg : (n_out, n_g), (n_in, n_g) output and input rows.
    m : the FRFs sum the m lowest modes.
    shifted_solve : the a-set's (K - STATIC_SHIFT M)^-1 (the eigen solution's factor); its
        answers are new arrays of the caller's (they are worked on in place).
    static_solve : the a-set's K^-1, needed with ``residual``.
    beside_ok : the series of half the sensors may run in a forked process beside this one
        (:func:`femcal.parallel.executors.beside`; where the OS forks, there are two cores
        and the series is large, :data:`SPLIT_WORK`): about twice as fast; each sensor's
        numbers then differ from one process's in their last bits (the solves' blocks hold
        fewer columns).
    """
    center = np.asarray(center, float)
    Phi = np.asarray(Phi)
    r = Phi.shape[1]
    lam = np.asarray(lam, float)[:r]
    if not 0 < m <= r:
        raise ValueError(f"the FRFs' modes ({m}) must be between 1 and the basis's ({r})")
    Ma = red.reduce(M)
    if shifted_solve is None:
        if K is None:
            raise ValueError("centre_derivatives needs K or the shifted factor")
        shifted_solve, _ = factorize((red.reduce(K) - STATIC_SHIFT * Ma).tocsc())
    T = red.T
    Tt = T.T.tocsr()
    Sg = sp.vstack([sp.csr_matrix(Cg), sp.csr_matrix(Bg)]).tocsr()  # (n_s, n_g)
    n_out, n_s = Cg.shape[0], Sg.shape[0]
    Sr = np.asarray(Sg @ Phi)  # (n_s, r)
    lm = lam[:m]
    # series terms per mode: ratio bound (lam_j - s) / (lam_r - s) (lam_r is a lower bound
    # of the next mode's); modes that would need more than MAX_TERMS are capped there
    ratio = np.clip((lm - STATIC_SHIFT) / (lam[-1] - STATIC_SHIFT), 1e-300, 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        need = np.where(ratio < 1.0, np.ceil(np.log(SERIES_TOL * (1 - ratio)) / np.log(ratio)),
                        np.inf)  # fmt: skip
    per_mode = np.clip(need, 1, MAX_TERMS).astype(int)  # (m,)
    terms = int(per_mode.max())
    rho = float(ratio.max())
    tail = float(rho**terms / (1 - rho)) if rho < 1.0 else float("inf")
    tail = 0.0 if tail <= SERIES_TOL else tail
    # Z_n (n_g, n_s) scaled by (lam_r - s)^n, and the weights by its inverse (no overflow)
    top = lam[-1] - STATIC_SHIFT
    # Q on the a-set, after every solve: each solve multiplies what is left of the low modes
    # by (lam_r - s) / (lam_k - s), up to 1e4 and more
    Pa = np.ascontiguousarray(Phi[red.a_dofs])  # the modes' a-set rows (T u_a = u_g)

    def off_modes(Y: np.ndarray, passes: int = 1) -> np.ndarray:
        """Y less its M-projection on the modes, in place (Y is a solve's own result)."""
        for _ in range(passes):
            Y -= Pa @ (Pa.T @ (Ma @ Y))
        return Y

    inv_gap = inverse_gaps(lm, lam)  # (r, m)
    n_p = center.size
    dlam = np.zeros((n_p, m))
    dSP = np.zeros((n_p, n_s, m))
    # the known modes' part, and each parameter's -f_j = (dK - lam_j dM) phi_j on the rows
    # its elements touch (kept for the series)
    loads: list[tuple[np.ndarray, np.ndarray]] = []
    for i in range(n_p):
        rows, dKX, dMX = polynomial_derivative_rows(polys, center, i, Phi[:, :m])
        Pr = Phi[rows]
        G, N = Pr.T @ dKX, Pr.T @ dMX  # (r, m)
        dlam[i], Cc = eigen_derivatives(G, N, lm, inv_gap)
        dSP[i] = Sr @ Cc
        loads.append((rows, dKX - dMX * lm[None, :]))
    # the modes above the basis: term n adds (lam_j - s)^n Z_n^T f_j, one Z_n at a time;
    # each sensor's series is its own (its column of Z_n), so that two halves of them can
    # run side by side
    # parameters whose elements touch the same rows (a group's thickness and modulus) share
    # their rows of each Z_n
    first_of: dict[bytes, int] = {}
    share = [first_of.setdefault(rows.tobytes(), i) for i, (rows, _) in enumerate(loads)]
    sensors_t = np.asarray((Tt @ Sg.T).todense())  # (n_a, n_s)

    def series(sensors: slice) -> np.ndarray:
        """dSP[:, sensors] with the modes above the basis added: (n_p, n_sensors, m)."""
        out = dSP[:, sensors].copy()
        # the sensors' solve holds the modes in full: twice (the first pass leaves rounding
        # of their size); a later solve of a vector without them makes them again only from
        # rounding, amplified by (lam_r - s) / (lam_k - s): one pass removes that
        Y = off_modes(np.ascontiguousarray(shifted_solve(sensors_t[:, sensors])), passes=2)
        for n in range(terms):
            Zn = T @ Y
            # the modes whose series is still running: the highest ones (their terms grow
            # with the mode), so a slice of the columns, not a copy of them
            active = np.flatnonzero(per_mode > n)
            cols = (slice(active[0], active[-1] + 1)
                    if active.size and active[-1] - active[0] + 1 == active.size else active)
            w = ((lm[cols] - STATIC_SHIFT) / top) ** n
            taken: dict[int, np.ndarray] = {}
            for i, (rows, neg_f) in enumerate(loads):
                if rows.size:
                    if share[i] not in taken:
                        taken[share[i]] = Zn[rows]
                    out[i][:, cols] -= (taken[share[i]].T @ neg_f[:, cols]) * w[None, :]
            if n + 1 < terms:
                # (CHOLMOD answers column-major; the sparse products below want rows)
                Y = np.ascontiguousarray(shifted_solve(Ma @ Y))
                Y *= top
                Y = off_modes(Y)
        return out

    if beside_ok and n_s > 1 and Ma.shape[0] * n_s * terms >= SPLIT_WORK:
        # the second half in a forked process (it shares this one's factor and arrays), the
        # cores shared out between the two: the solves are the time, and one solve gains
        # little from a second core
        half = slice(n_s // 2, n_s)
        threads = max(1, usable_cores() // 2)
        with (beside(series, half, blas_threads=threads) as call,
              threadpool_limits(threads)):  # fmt: skip
            first = series(slice(0, n_s // 2))
            second = result_of(call.future, "the exact FRF derivatives' second half")
        dSP[:, : n_s // 2], dSP[:, half] = first, second
    else:
        dSP = series(slice(None))
    S, P = Sr[:n_out, :m], Sr[n_out:, :m]
    dS, dP = dSP[:, :n_out], dSP[:, n_out:]
    R = dR = None
    if residual:
        if static_solve is None:
            raise ValueError("the residual's derivatives need the factor of K")
        if (lm <= 0).any():
            raise ValueError("the residual flexibility needs a restrained model: an FRF mode "
                             "is a rigid-body mode")  # fmt: skip
        X = T @ static_solve(np.asarray((Tt @ Sg.T).todense()))  # K^-1 S^T (n_g, n_s)
        XC, XB = X[:, :n_out], X[:, n_out:]
        R = np.asarray(Cg @ XB) - (S / lm) @ P.T
        dR = np.zeros((n_p, n_out, P.shape[0]))
        for i in range(n_p):
            rows, dKXB, _ = polynomial_derivative_rows(polys, center, i, XB)
            touched = np.any(dKXB != 0, axis=1)
            rows, dKXB = rows[touched], dKXB[touched]
            static = -(XC[rows].T @ dKXB) if rows.size else 0.0
            dR[i] = (static - (dS[i] / lm) @ P.T - (S / lm) @ dP[i].T
                     + (S * (dlam[i] / lm**2)) @ P.T)  # fmt: skip
    converged = np.flatnonzero(need <= MAX_TERMS)
    exact_to = (float("inf") if tail == 0.0 else
                float(np.sqrt(max(lm[converged].max(), 0.0)) / (2 * np.pi))
                if len(converged) else 0.0)  # fmt: skip
    return CentreDerivatives(lm, S, P, dlam, dS, dP, R, dR, terms, tail, exact_to)


def first_order_correction(sur: Surrogate, exact: CentreDerivatives, freq: np.ndarray,
                           H_test: np.ndarray, metric: str) -> np.ndarray:  # fmt: skip
    """E (n_residuals, n_p) = J_full(c) - J_surrogate(c) of the metric's residuals: added
    as ``E (p - c)`` to the surrogate's residuals it makes their Jacobian the full model's at
    the centre c."""
    c = sur.p_center
    H_s, dH_s = sur.frf_and_jacobian(c, freq)
    H_f, dH_f = exact.frf_and_jacobian(freq, sur.zeta, sur.quantity)
    return jacobian(H_f, dH_f, metric, H_test) - jacobian(H_s, dH_s, metric, H_test)
