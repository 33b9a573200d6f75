"""The FRF deviation metric of the calibration and its Jacobian.

``delta = eps^H eps`` with ``eps(p) = log10 vect(H_A(p)) - log10 vect(H_X)`` over all output
and input pairs and the selected frequencies: magnitudes by default (``log10 |H|``), or the
complex logarithm (``complex-log``), whose imaginary part is the phase difference over
ln 10 and so weighs phase too. The phase difference enters as ``2 sin(dphi / 2)``, which is
dphi for small differences but, unlike the principal value of dphi, does not jump by 2 pi
where the two FRFs are in opposite phase (near antiresonances): a metric with such jumps
defeats Levenberg-Marquardt. The Jacobian of the magnitude form is
``Re(dH/dp / H) / ln 10``, of the phase part ``cos(dphi / 2) Im(dH/dp / H) / ln 10``.

Frequencies are sampled at equal logarithmic steps with ``n`` samples per half-power
bandwidth ``2 zeta0 w``: ``f_{k+1} = f_k (1 + 2 zeta0 / n)``.
"""

from __future__ import annotations

import numpy as np

METRICS = ("log-magnitude", "complex-log")
_LN10 = np.log(10.0)


def log_frequencies(f_lo: float, f_hi: float, zeta0: float, per_bandwidth: float = 3.0
                    ) -> np.ndarray:  # fmt: skip
    """Frequencies (Hz) from f_lo to f_hi (inclusive ends) at the ratio 1 + 2 zeta0 / n."""
    if not 0 < f_lo < f_hi:
        raise ValueError(f"frequency band {f_lo}-{f_hi} Hz: expected 0 < f_lo < f_hi")
    if not zeta0 > 0 or not per_bandwidth > 0:
        raise ValueError("zeta0 and the samples per bandwidth must be positive")
    ratio = 1.0 + 2.0 * zeta0 / per_bandwidth
    n = int(np.ceil(np.log(f_hi / f_lo) / np.log(ratio))) + 1
    return np.geomspace(f_lo, f_hi, max(n, 2))


def residuals(H_model: np.ndarray, H_test: np.ndarray, metric: str = "log-magnitude"
              ) -> np.ndarray:  # fmt: skip
    """eps as a real vector: (n_out n_in n_f,) for log-magnitude, twice that for complex-log
    (magnitude part, then phase part)."""
    if metric not in METRICS:
        raise ValueError(f"metric must be one of {', '.join(METRICS)}, not {metric!r}")
    ratio = H_model / H_test
    mag = np.log10(np.abs(ratio)).ravel()
    if metric == "log-magnitude":
        return mag
    return np.concatenate([mag, (2.0 * np.sin(np.angle(ratio) / 2.0) / _LN10).ravel()])


def jacobian(H_model: np.ndarray, dH: np.ndarray, metric: str = "log-magnitude",
             H_test: np.ndarray | None = None) -> np.ndarray:  # fmt: skip
    """d eps / dp as (n_residuals, n_p) from H (n_out, n_in, n_f) and dH (n_p, ...); the
    complex-log form needs H_test too (:func:`jacobian_of_parts` of dH's real and
    imaginary parts)."""
    return jacobian_of_parts(H_model, np.concatenate([dH.real, dH.imag], axis=-1), metric,
                             H_test)  # fmt: skip


def jacobian_of_parts(H_model: np.ndarray, X: np.ndarray, metric: str = "log-magnitude",
                      H_test: np.ndarray | None = None, *, out: np.ndarray | None = None,
                      columns: np.ndarray | None = None) -> np.ndarray:  # fmt: skip
    """d eps / dp as (n_residuals, n_p) from H (n_out, n_in, n_f) and dH given as its real
    and imaginary parts side by side, X (n_p, n_out, n_in, 2 n_f) (``dH = X[..., :n_f] +
    i X[..., n_f:]``); the complex-log form needs H_test too. ``dH / H`` is taken as
    ``dH conj(H) / |H|^2`` in real arithmetic and written straight into J: a new array, or
    ``out`` (n_residuals, n_cols) at its ``columns`` (n_p,), which is returned."""
    if metric not in METRICS:
        raise ValueError(f"metric must be one of {', '.join(METRICS)}, not {metric!r}")
    n_p, n_f = X.shape[0], H_model.shape[2]
    n = H_model.size
    complex_log = metric == "complex-log"
    if complex_log and H_test is None:
        raise ValueError("the complex-log Jacobian needs the test FRFs")
    inv = 1.0 / H_model
    inv_re, inv_im = np.ascontiguousarray(inv.real), np.ascontiguousarray(inv.imag)
    half = np.cos(np.angle(H_model / H_test) / 2.0) / _LN10 if complex_log else None
    J = np.empty((2 * n if complex_log else n, n_p)) if out is None else out
    cols = slice(None) if columns is None else columns
    # a few outputs at a time: their buffers stay in cache and each is written into J as
    # whole rows (the same element-wise operations as on the whole array, so the same numbers)
    n_o, n_i = H_model.shape[:2]
    step = max(1, 32768 // max(n_p * n_i * n_f, 1))
    for o in range(0, n_o, step):
        rows = slice(o * n_i * n_f, min(o + step, n_o) * n_i * n_f)
        Xr, Xi = X[:, o : o + step, :, :n_f], X[:, o : o + step, :, n_f:]
        ir, ii = inv_re[o : o + step], inv_im[o : o + step]
        a = np.multiply(Xr, ir)
        b = np.multiply(Xi, ii)
        np.subtract(a, b, out=a)
        np.divide(a, _LN10, out=a)
        J[rows, cols] = a.reshape(n_p, -1).T
        if complex_log:
            np.multiply(Xr, ii, out=a)
            np.multiply(Xi, ir, out=b)
            np.add(a, b, out=a)
            np.multiply(half[o : o + step], a, out=a)
            J[n + rows.start : n + rows.stop, cols] = a.reshape(n_p, -1).T
    return J


def deviation(eps: np.ndarray) -> float:
    """delta = eps^T eps."""
    return float(eps @ eps)
