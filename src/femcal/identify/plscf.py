"""The poly-reference least-squares complex frequency-domain estimator (pLSCF, "PolyMAX").

Written from Peeters, Van der Auweraer, Guillaume and Leuridan, "The PolyMAX frequency-domain
method: a new standard for modal parameter estimation?", Shock and Vibration 11 (2004)
395-409, and Guillaume, Verboven, Vanlanduit, Van der Auweraer and Peeters, "A
poly-reference implementation of the least-squares complex frequency-domain estimator",
IMAC XXI (2003). No implementation was copied.

The FRFs of ``p`` outputs to ``m`` references (``m <= p``: the references are the smaller
side of the measurement) are modelled as a right matrix fraction in the z-domain,

    H(w) = N(w) D(w)^-1,   N(w) = sum_r z^r beta_r (p x m),   D(w) = sum_r z^r alpha_r (m x m),

with ``z = exp(i w dt)`` and real coefficients, r = 0..n. The equation error of output o,
``E_o(w) = N_o(w) - H_o(w) D(w)`` (1 x m), is linear in the coefficients; the numerator
coefficients of each output are eliminated from the normal equations, which leaves the
reduced system ``M alpha = 0`` with

    M = 2 sum_o (T_o - S_o^T R_o^-1 S_o),
    R_o = Re(X_o^H X_o),  S_o = Re(X_o^H Y_o),  T_o = Re(Y_o^H Y_o),
    X_o[f, r] = w_o(f) z_f^r,  Y_o[f, (r, i)] = -w_o(f) z_f^r H_o(f),

(n + 1) m square. The highest coefficient is fixed, ``alpha_n = I``, and the rest follow by
least squares. The normal matrices are never formed: the same reduced problem is solved
through QR factorisations (:class:`NormalEquations`), which keeps high orders over narrow
bands, where the powers ``z^r`` are nearly parallel, from losing their precision. The
poles are the eigenvalues of the companion matrix of
``sum_r z^r alpha_r^T`` (``s = ln(z) / dt``); its eigenvectors' first block rows are the
modal participation vectors (the left null vectors of D at the pole). The normal matrices of
every order up to ``n_max`` are leading blocks of those of ``n_max``, so a whole
stabilisation diagram costs one pass over the data.

Choice of dt: the band [f_lo, f_hi] is mapped on the upper half of the unit circle
symmetrically about i, ``w dt`` from ``pi f_lo / (f_lo + f_hi)`` to ``pi f_hi / (f_lo +
f_hi)``: for a band from 0 this is the usual ``dt = 1 / (2 f_hi)``; for a narrow band far
from 0 it keeps the band away from its mirror image at negative frequencies (z near -1 or
1), where the real-coefficient model would have to fit both at once.

Array conventions: H is (p, m, K) = (outputs, references, frequencies); frequencies in Hz.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla


@dataclass(frozen=True)
class NormalEquations:
    """The pLSCF least-squares problem of the largest order, factorised so that every lower
    order's reduced system is a small computation.

    For output o the columns ``[x_0, y_0, x_1, y_1, ..., x_n, y_n]`` (``x_r`` the weighted
    ``z^r``, ``y_r`` the m weighted ``-z^r H_o``, real and imaginary parts stacked) are
    factorised once, ``W_o = Q_o R_o``; the leading block of ``R_o`` is the factor of any
    lower order's columns. The reduced system of order n is then the triangular factor of
    the y-columns once the x-columns are eliminated (a small QR of that block with its
    columns reordered), which is the normal equations' ``T_o - S_o^T R_o^-1 S_o`` without
    squaring their condition.

    Attributes
    ----------
    R : (p, C, C) upper triangular, C = (n_max + 1)(1 + m).
    dt : the z-domain map's time step, s. m : number of references. n_max : largest order.
    """

    R: np.ndarray
    dt: float
    m: int
    n_max: int


def sampling_step(f_lo: float, f_hi: float) -> float:
    """dt (s) that maps [f_lo, f_hi] on the unit circle's upper half symmetrically about i
    (see the module docstring)."""
    return 1.0 / (2.0 * (f_lo + f_hi))


def normal_equations(freq_hz: np.ndarray, H: np.ndarray, n_max: int, *,
                     weights: np.ndarray | None = None,
                     dt: float | None = None) -> NormalEquations:  # fmt: skip
    """The factorised least-squares problem of order ``n_max`` for FRFs H (p, m, K) at
    freq_hz (K,).

    Parameters
    ----------
    weights : (K,) one weight per frequency for all outputs, or (p, K) per output and
        frequency (e.g. from the coherence); None: 1.
    dt : the map's time step; default :func:`sampling_step` of the frequencies' span.
    """
    f = np.asarray(freq_hz, float)
    H = np.asarray(H, complex)
    p, m, K = H.shape
    if dt is None:
        dt = sampling_step(float(f.min()), float(f.max()))
    z = np.exp(2j * np.pi * f * dt)
    nb = n_max + 1
    Z = z[:, None] ** np.arange(nb)[None, :]  # (K, n+1)
    w = np.ones(K) if weights is None else np.asarray(weights, float)
    C = nb * (1 + m)
    R = np.empty((p, C, C))
    for o in range(p):
        wo = w if w.ndim == 1 else w[o]
        Xo = Z * wo[:, None]  # (K, n+1)
        Yo = -Xo[:, :, None] * H[o].T[:, None, :]  # (K, n+1, m)
        Wc = np.concatenate([Xo[:, :, None], Yo], axis=2).reshape(K, C)
        Wr = np.concatenate([Wc.real, Wc.imag], axis=0)
        Ro = sla.qr(Wr, mode="r", overwrite_a=True, check_finite=False)[0]
        if Ro.shape[0] < C:  # fewer rows than columns: pad the factor
            Ro = np.vstack([Ro, np.zeros((C - Ro.shape[0], C))])
        R[o] = Ro[:C]
    return NormalEquations(R, float(dt), m, n_max)


def reduced_factor(ne: NormalEquations, n: int) -> np.ndarray:
    """The triangular factor F ((n+1) m square) of the reduced problem of order n <= n_max:
    every output's y-columns with its x-columns eliminated, stacked and compressed by one
    more QR, so that ``||F alpha||^2`` is the reduced cost."""
    m = ne.m
    c = (n + 1) * (1 + m)
    cols = np.arange(c).reshape(n + 1, 1 + m)
    order = np.concatenate([cols[:, 0], cols[:, 1:].ravel()])
    nx = n + 1
    R2 = np.linalg.qr(ne.R[:, :c, :c][:, :, order], mode="r")  # (p, c, c), batched
    stacked = R2[:, nx:c, nx:c].reshape(-1, c - nx)
    return sla.qr(stacked, mode="r", check_finite=False)[0][: c - nx]


def denominator(F: np.ndarray, m: int) -> np.ndarray:
    """The denominator coefficients alpha ((n+1) m, m) minimising ``||F alpha||`` with the
    highest block fixed to the identity (columns scaled to unit norm for the solve).

    Raises
    ------
    numpy.linalg.LinAlgError
        When the order's problem has lost all precision (values that are not finite).
    """
    k = F.shape[1] - m
    A1, A2 = F[:, :k], F[:, k:]
    if not (np.isfinite(A1).all() and np.isfinite(A2).all()):
        raise np.linalg.LinAlgError("the pLSCF least squares lost all precision")
    scale = np.linalg.norm(A1, axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    low = -sla.lstsq(A1 / scale, A2, lapack_driver="gelsy", check_finite=False)[0]
    return np.vstack([low / scale[:, None], np.eye(m)])


def poles_and_participation(alpha: np.ndarray, m: int, dt: float
                            ) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Continuous-time poles (n m,) and participation vectors (m, n m) of a denominator with
    alpha_n = I: the companion matrix of ``sum_r z^r alpha_r^T``."""
    n = alpha.shape[0] // m - 1
    blocks = [alpha[r * m:(r + 1) * m].T for r in range(n)]  # alpha_r^T, r < n
    comp = np.zeros((n * m, n * m))
    if n > 1:
        comp[: (n - 1) * m, m:] = np.eye((n - 1) * m)
    comp[(n - 1) * m:, :] = -np.hstack(blocks)
    zeta, V = np.linalg.eig(comp)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.log(zeta.astype(complex)) / dt
    L = V[:m]
    norms = np.linalg.norm(L, axis=0)
    L = L / np.where(norms > 0, norms, 1.0)
    return s, L


@dataclass(frozen=True)
class Order:
    """The pLSCF estimate of one order: every pole (n m,) with its participation (m, n m)."""

    order: int
    poles: np.ndarray
    participation: np.ndarray


def estimate(ne: NormalEquations, n: int) -> Order:
    """Poles and participation vectors of order n (1 <= n <= n_max)."""
    if not 1 <= n <= ne.n_max:
        raise ValueError(f"order {n} is outside 1..{ne.n_max}")
    alpha = denominator(reduced_factor(ne, n), ne.m)
    s, L = poles_and_participation(alpha, ne.m, ne.dt)
    return Order(n, s, L)


def orders_for(n_modes: int, m: int, K: int) -> range:
    """The orders of a pLSCF stabilisation diagram for a part expected to hold about
    ``n_modes`` modes, with m references and K frequencies: every order from 1 to
    ``(4 n_modes + 24) / sqrt(m)``, room for twice the modes and for the computational
    poles that take the noise and the out-of-band modes (an order gives m pole pairs, but
    close modes and weak ones need orders well above the bare count to settle), at most
    what the frequencies can support."""
    want = int(np.ceil((4 * n_modes + 24) / np.sqrt(m)))
    cap = max(2, min(MAX_ORDER, (K - 1) // 2))
    return range(1, max(2, min(want, cap)) + 1)


#: Highest pLSCF order (polynomial order; the model has order x references poles).
MAX_ORDER = 120


def diagram_poles(freq_hz: np.ndarray, H: np.ndarray, orders: range, *,
                  weights: np.ndarray | None = None,
                  ) -> list[tuple[int, np.ndarray, np.ndarray]]:  # fmt: skip
    """Every order's poles and participation vectors: the input of
    :func:`femcal.identify.stabilization.stable_columns`."""
    ne = normal_equations(freq_hz, H, max(orders), weights=weights)
    out = []
    for n in orders:
        try:
            o = estimate(ne, n)
        except (np.linalg.LinAlgError, ValueError):
            continue
        out.append((n, o.poles, o.participation))
    return out
