"""Frequency-domain subspace identification of continuous-time models from FRF data.

The algorithm is McKelvey, Akçay and Ljung (1996), "Subspace-based multivariable system
identification from frequency response data", IEEE Trans. Automatic Control 41(7), in its
form for arbitrarily spaced frequencies, applied to continuous-time data through the
bilinear (Tustin) map, as the paper proposes:

1. The frequencies w_k (rad/s) map to discrete ones on the unit circle,
   ``theta_k = 2 arctan(w_k T / 2)``, ``z_k = exp(i theta_k)``; a continuous model
   ``G(s)`` equals the discrete model ``G_d(z)`` of its Tustin transform at these points.
   T is chosen so the band's geometric centre maps to theta = pi/2.
2. With ``W_q(z) = [1, z, ..., z^(q-1)]^T`` the data matrices are
   ``Y = [W_q(z_k) (x) G_k]_k`` (q p x K m) and ``U = [W_q(z_k) (x) I_m]_k`` (q m x K m);
   since ``z X = A X + B``, ``G = C X + D`` for ``X(z) = (zI - A)^-1 B``, their block rows
   obey ``Y = O_q X + Gamma_q U`` with the extended observability matrix O_q (q p x n).
3. Real and imaginary parts side by side, an LQ factorisation of ``[U; Y]`` removes the U
   part; the n leading left singular vectors of the remaining block L22 span O_q.
4. ``C_d`` is the first block row of that basis and ``A_d`` solves the shift equation
   (block rows 1..q-1 times A_d = block rows 2..q) in the least-squares sense.
5. Back to continuous time: ``A = (2/T)(A_d - I)(A_d + I)^-1`` (same eigenvectors, so C_d
   stays a valid output matrix up to per-mode scaling, which B absorbs). Unstable poles are
   reflected into the left half plane when stability is enforced.
6. B and D follow by linear least squares on the data at ``s_k = i w_k``
   (:func:`femcal.identify.lsq.fit_b`).

Everything here is written from the paper; no implementation was copied.
Array conventions: H is (n_out, n_in, n_freq) = (p, m, K); frequencies in Hz.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla


@dataclass(frozen=True)
class SubspaceBasis:
    """What the orders of one subspace run share: the left singular vectors of L22 and its
    singular values, with the bilinear map's T.

    Attributes
    ----------
    U : (q p, r) left singular vectors, r = min(q p, columns).
    singular_values : (r,) descending.
    T : bilinear map constant, s.
    p : number of outputs; q : block rows.
    """

    U: np.ndarray
    singular_values: np.ndarray
    T: float
    p: int
    q: int

    def max_order(self) -> int:
        """Largest order the basis allows (the shift equation needs (q-1) p >= n)."""
        return int(min(self.U.shape[1], (self.q - 1) * self.p))


def bilinear_constant(freq_hz: np.ndarray) -> float:
    """T (s) that maps the geometric centre of the band to theta = pi/2."""
    f = np.asarray(freq_hz, float)
    f = f[f > 0]
    if len(f) == 0:
        raise ValueError("the band needs positive frequencies")
    centre = np.sqrt(f.min() * f.max())
    return 2.0 / (2.0 * np.pi * centre)


def default_block_rows(n_max: int, p: int) -> int:
    """Block rows q for orders up to n_max with p outputs: enough for the shift equation
    ((q-1) p >= n_max + 2) and at least 4, at most n_max + 1."""
    need = -(-(n_max + 2) // p) + 1
    return int(max(4, min(max(need, 4), n_max + 1)))


def subspace_basis(freq_hz: np.ndarray, H: np.ndarray, q: int, *,
                   T: float | None = None) -> SubspaceBasis:  # fmt: skip
    """Steps 1-3: the basis of the extended observability matrix's range.

    Parameters
    ----------
    freq_hz : (K,) Hz, positive.
    H : (p, m, K) complex FRFs (scale the channels beforehand if they differ widely).
    q : block rows.
    T : bilinear map constant; default :func:`bilinear_constant`.
    """
    f = np.asarray(freq_hz, float)
    H = np.asarray(H, complex)
    p, m, K = H.shape
    if len(f) != K:
        raise ValueError(f"H has {K} frequencies, freq_hz {len(f)}")
    if q < 2:
        raise ValueError("the subspace method needs at least 2 block rows")
    T = bilinear_constant(f) if T is None else T
    theta = 2.0 * np.arctan(2.0 * np.pi * f * T / 2.0)
    z = np.exp(1j * theta)
    Wq = z[None, :] ** np.arange(q)[:, None]  # (q, K)
    # Y[(j, o), (k, i)] = z_k^j H[o, i, k]; U[(j, a), (k, i)] = z_k^j delta_ai
    Y = np.einsum("jk,oik->joki", Wq, H).reshape(q * p, K * m)
    eye = np.eye(m)
    Uc = np.einsum("jk,ai->jaki", Wq, eye).reshape(q * m, K * m)
    stacked = np.vstack([np.hstack([Uc.real, Uc.imag]), np.hstack([Y.real, Y.imag])])
    # LQ of stacked = QR of its transpose; only R is needed
    R = sla.qr(stacked.T, mode="r", overwrite_a=True, check_finite=False)[0]
    L = R.T  # lower triangular (rows of stacked) x (min dims)
    qm = q * m
    L22 = L[qm:, qm:]
    Us, s, _ = sla.svd(L22, full_matrices=False, check_finite=False)
    return SubspaceBasis(Us, s, T, p, q)


def model_of_order(basis: SubspaceBasis, n: int, *, stable: bool = True
                   ) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Steps 4-5: continuous-time A (n, n) and C (p, n) of order n from the basis.

    Raises
    ------
    ValueError
        If n exceeds what the basis allows.
    """
    if not 1 <= n <= basis.max_order():
        raise ValueError(f"order {n} is outside 1..{basis.max_order()} for {basis.q} block "
                         f"rows and {basis.p} outputs")  # fmt: skip
    Os = basis.U[:, :n]
    p = basis.p
    Cd = Os[:p]
    Ad = np.linalg.lstsq(Os[:-p], Os[p:], rcond=None)[0]
    eye = np.eye(n)
    A = (2.0 / basis.T) * np.linalg.solve((Ad + eye).T, (Ad - eye).T).T
    if stable:
        A = reflect_unstable(A)
    return A, Cd


def reflect_unstable(A: np.ndarray) -> np.ndarray:
    """A with every eigenvalue of positive real part mirrored into the left half plane
    (same eigenvectors); A itself if all are stable."""
    lam, V = np.linalg.eig(A)
    if not (lam.real > 0).any():
        return A
    lam = np.where(lam.real > 0, -lam.real + 1j * lam.imag, lam)
    Ar = V @ np.diag(lam) @ np.linalg.inv(V)
    return Ar.real if np.isrealobj(A) else Ar


def diagram_poles(freq_hz: np.ndarray, H: np.ndarray, orders: range | list[int], *,
                  stable: bool = True) -> tuple[list[tuple[int, np.ndarray, np.ndarray]],
                                                np.ndarray]:  # fmt: skip
    """Every order's poles and shapes at the outputs (C times the eigenvectors) from one
    subspace basis, and the basis's singular values: the input of
    :func:`femcal.identify.stabilization.stable_columns`. Orders the data cannot support are
    left out. The basis takes twice the block rows the shift equation of the highest order
    needs: the extra rows average the noise of measured FRFs (heavily damped modes come out
    much steadier over the orders)."""
    orders = sorted(set(int(n) for n in orders))
    basis = subspace_basis(freq_hz, H, 2 * default_block_rows(orders[-1], H.shape[0]))
    out = []
    for n in orders:
        if n > basis.max_order():
            break
        A, C = model_of_order(basis, n, stable=stable)
        lam, V = np.linalg.eig(A)
        out.append((n, lam, C @ V))
    return out, basis.singular_values
