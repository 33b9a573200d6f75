"""Huber's robust loss for the log-FRF metric.

The metric's residuals are far from Gaussian: near the antiresonances the logarithm of an FRF
that passes close to zero swings by orders of magnitude for differences that are small in
absolute terms, so a few per cent of the residuals can carry most of their sum of squares
(measured on the bundled hammer test by benchmarks/calibration_weight.py: 5 % carry 78 % at
the nominal model, 93 % after calibration). Least squares lets those few points
set the parameters. Huber's loss (Huber 1964) is quadratic within ``c`` of zero and linear
beyond, ``rho(e) = e^2 / 2`` for ``|e| <= c`` and ``c |e| - c^2 / 2`` otherwise, so outliers
weigh by their count rather than their square. ``c`` is ``huber_c`` (2 by default) robust
standard deviations of the nominal model's residual (1.4826 times its median absolute value),
or of the given noise level.

Levenberg-Marquardt minimises it as least squares on transformed residuals ``t(e)`` with
``t^2 / 2 = rho(e)`` (``t = e`` within c, ``sign(e) sqrt(2 c |e| - c^2)`` beyond) and the
Jacobian ``dt/de J``: for Huber's convex loss this is Gauss-Newton on the loss itself (Triggs
et al., Bundle adjustment - a modern synthesis, 2000, section 3.3). The likelihood, the
posterior and the identifiability analysis use the transformed residuals and Jacobian, so
they measure what the search minimises.
"""

from __future__ import annotations

import numpy as np

#: Huber's threshold in robust standard deviations of the residual, by default.
HUBER_C = 2.0


def robust_scale(eps: np.ndarray, axis: int | None = None) -> float | np.ndarray:
    """A robust standard deviation of the residuals: 1.4826 times their median absolute
    value (the standard deviation for Gaussian residuals, unmoved by a few outliers); of all
    of them (a float), or along ``axis`` (an array)."""
    s = 1.4826 * np.median(np.abs(eps), axis=axis)
    return float(s) if axis is None else s


def huber_transform(eps: np.ndarray, c: float) -> tuple[np.ndarray, np.ndarray]:
    """(t, dt/de) of the residuals (see the module docstring); ``t @ t / 2`` is Huber's loss."""
    e = np.asarray(eps, float)
    a = np.abs(e)
    big = a > c
    t = e.copy()
    d = np.ones_like(e)
    root = np.sqrt(2.0 * c * a[big] - c * c)
    t[big] = np.sign(e[big]) * root
    d[big] = c / root
    return t, d


def huber_deviation(eps: np.ndarray, c: float | None) -> float:
    """The robust deviation ``sum 2 rho(e)``: the sum of squares where |e| <= c, growing
    linearly beyond (None: the plain sum of squares)."""
    e = np.asarray(eps, float)
    if c is None:
        return float(e @ e)
    a = np.abs(e)
    return float(np.sum(np.where(a <= c, a * a, 2.0 * c * a - c * c)))
