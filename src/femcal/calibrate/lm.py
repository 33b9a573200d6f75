"""Levenberg-Marquardt least squares within bounds.

Minimises ``F(p) = |r(p)|^2 / 2`` for p in the box [lower, upper]. Each step solves
``(J^T J + mu D) dp = -J^T r`` with D the diagonal of J^T J (Marquardt's scaling, floored),
over the free parameters only: a parameter at a bound whose gradient pushes it outward is
held there, as is one whose bounds meet (its Jacobian column is not looked at). The trial
point is projected onto the box; it is kept if it lowers F (mu is then
divided by 3), otherwise mu is multiplied by 4 and the step solved again.

Stops when the relative fall of F in an accepted step is below ``ftol`` and the largest
parameter change below ``xtol``, when the projected gradient vanishes, after ``max_iter``
accepted steps, or when mu exceeds 1e12 (no descent left).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class LMResult:
    """Outcome of a run.

    p : (n,) solution; cost : F(p) = |r|^2 / 2; residuals (m,), jacobian (m, n) at p;
    iterations : accepted steps; evaluations : residual evaluations; history : F after
    each accepted step (first: the start); converged, message : why it stopped.
    """

    p: np.ndarray
    cost: float
    residuals: np.ndarray
    jacobian: np.ndarray
    iterations: int
    evaluations: int
    history: list[float] = field(default_factory=list)
    converged: bool = False
    message: str = ""


def levenberg_marquardt(fun: Callable[[np.ndarray], tuple[np.ndarray, object]],
                        p0: np.ndarray, lower: np.ndarray, upper: np.ndarray, *,
                        max_iter: int = 50, ftol: float = 1e-8, xtol: float = 1e-6,
                        mu0: float = 1e-3,
                        callback: Callable[[int, np.ndarray, float], None] | None = None,
                        ) -> LMResult:  # fmt: skip
    """Minimise |fun(p)[0]|^2 / 2 within the box. ``fun`` returns (r (m,), J), J the
    Jacobian (m, n) or a callable that computes it (only called for accepted points)."""
    lo, hi = np.asarray(lower, float), np.asarray(upper, float)
    if (lo > hi).any():
        raise ValueError("lower bounds above upper bounds")
    p = np.clip(np.asarray(p0, float), lo, hi)
    r, J = fun(p)
    J = J() if callable(J) else J
    evals = 1
    cost = 0.5 * float(r @ r)
    history = [cost]
    mu = mu0
    it = 0
    converged, message = False, f"{max_iter} iterations"
    while it < max_iter:
        g = J.T @ r
        at_lo = (p <= lo) & (g > 0)
        at_hi = (p >= hi) & (g < 0)
        free = ~(at_lo | at_hi) & (lo < hi)  # (a parameter whose bounds meet is held)
        if not free.any() or np.abs(g[free]).max() <= 1e-14 * max(1.0, cost):
            converged, message = True, "gradient zero within the bounds"
            break
        # J_f^T J_f from the free columns gathered as rows of J^T (quicker than by a mask),
        # the second factor a column-major copy: the operands' layouts of J[:, free].T @
        # J[:, free], so the same BLAS kernel and numbers, and two arrays, so not NumPy's
        # symmetric rank-k update for X^T X of one array, whose last bits differ
        JfT = J.T[np.flatnonzero(free)]
        A = JfT @ JfT.T.copy(order="F")
        d = np.maximum(np.diag(A), 1e-12 * max(np.diag(A).max(), 1e-300))
        accepted = False
        while mu <= 1e12:
            try:
                step = np.linalg.solve(A + mu * np.diag(d), -g[free])
            except np.linalg.LinAlgError:
                mu *= 4.0
                continue
            trial = p.copy()
            trial[free] += step
            trial = np.clip(trial, lo, hi)
            r_t, J_t = fun(trial)
            evals += 1
            cost_t = 0.5 * float(r_t @ r_t)
            if np.isfinite(cost_t) and cost_t < cost:
                accepted = True
                break
            mu *= 4.0
        if not accepted:
            converged, message = True, "no further descent (damping at its limit)"
            break
        dp = np.abs(trial - p).max()
        fall = (cost - cost_t) / max(cost, 1e-300)
        p, r, cost = trial, r_t, cost_t
        J = J_t() if callable(J_t) else J_t
        mu = max(mu / 3.0, 1e-12)
        it += 1
        history.append(cost)
        if callback is not None:
            callback(it, p, cost)
        if fall < ftol and dp < xtol:
            converged, message = True, "cost and parameters settled"
            break
    return LMResult(p, cost, r, J, it, evals, history, converged, message)


def latin_hypercube(n: int, lower: np.ndarray, upper: np.ndarray,
                    rng: np.random.Generator) -> np.ndarray:  # fmt: skip
    """n points (n, d) in the box, one in each of n equal slices of every coordinate."""
    lo, hi = np.asarray(lower, float), np.asarray(upper, float)
    d = len(lo)
    u = (rng.permuted(np.tile(np.arange(n), (d, 1)), axis=1).T + rng.random((n, d))) / n
    return lo + u * (hi - lo)
