"""Identifiability: Fisher information and Cramér-Rao lower bounds of the parameters.

With residuals r (m,) of independent errors of standard deviation sigma and their Jacobian
J (m, n), the Fisher information is ``FIM = J^T J / sigma^2`` and no unbiased estimate of p
can have a covariance smaller than ``FIM^-1`` (Cramér-Rao). sigma is taken from the
residual at the solution, ``sigma^2 = r^T r / (m - n)``, unless given (e.g. the known noise
level of a noise-free synthetic test). A parameter whose bound is large against its range
(or infinite: FIM singular) cannot be informed by the test.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Fisher:
    """FIM (n, n), its pseudo-inverse (the CRLB matrix, covariance bound), sigma, the CRLB
    of each scaled parameter (n,) = sqrt(diag(covariance)) and the correlation matrix
    (n, n) of the bound."""

    fim: np.ndarray
    covariance: np.ndarray
    sigma: float
    crlb: np.ndarray
    correlation: np.ndarray


def fisher(J: np.ndarray, r: np.ndarray, *, sigma: float | None = None,
           rows: np.ndarray | None = None) -> Fisher:  # fmt: skip
    """FIM and CRLB from the Jacobian J (m, n) and residuals r (m,); ``rows`` selects the
    residuals to use (a frequency band, say)."""
    if rows is not None:
        J, r = J[rows], r[rows]
    m, n = J.shape
    if sigma is None:
        sigma = float(np.sqrt(r @ r / max(m - n, 1)))
    if not sigma > 0:
        raise ValueError("sigma must be positive (give it for noise-free data)")
    F = J.T @ J / sigma**2
    # an uninformed parameter makes F singular: its bound is infinite
    w, V = np.linalg.eigh(F)
    good = w > (w.max() * 1e-14 if w.max() > 0 else np.inf)
    cov = (V[:, good] / w[good]) @ V[:, good].T
    if not good.all():
        reach = (V[:, ~good] ** 2).sum(axis=1) > 1e-12  # parameters in the null space
        cov[reach, :] = np.inf
        cov[:, reach] = np.inf
    diag = np.diag(cov)
    crlb = np.sqrt(diag)
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.sqrt(np.outer(diag, diag))
    return Fisher(F, cov, sigma, crlb, corr)
