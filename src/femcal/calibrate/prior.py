"""The Bayesian side of the calibration: the prior on the parameters, the likelihood of the
test's residuals, and the posterior that replaces the bare Cramér-Rao bound.

Prior. Each scaled parameter p (P = P0 (1 + p)) is Gaussian about 0 (the nominal value) with
standard deviation ``std``: the engineer's ``confidence`` in the parameter file (a fraction of
the nominal), or else the bounds read as ``bounds_sigma`` standard deviations each side of the
nominal (3 by default: the bounds are where the engineer is all but sure the value lies).

Likelihood. The residuals eps (m,) of the log-FRF metric are Gaussian with a standard
deviation sigma each. When the test's noise level is known (``noise_sigma``) they are taken as
independent: the data term is ``|eps|^2 / sigma^2``. Otherwise the residuals are dominated by
what the model lacks, which is smooth across frequencies and shared by neighbouring sensors,
so they are far from independent and the m of them carry the information of a few: sigma is
estimated from the residual itself, ``sigma^2 = |eps|^2 / m``, and the data term counts as
``n_eff`` independent observations, ``(n_eff / m) |eps|^2 / sigma^2`` (a likelihood tempered
by its effective sample size). ``n_eff`` is the effective number of independent entries of the
residual matrix R (channels and real/imaginary parts by frequencies): for a covariance that
separates into a channel and a frequency part it is the product of their participation ratios,
``(tr C)^2 / tr(C^2)``, each estimated from R's singular values s as ``(sum s^2)^2 / sum s^4``.

Posterior. The maximum a posteriori estimate minimises ``|eps|^2 + |w p|^2`` with
``w = scale / std`` and ``scale = sigma sqrt(m / n_eff)``, which is what the Levenberg-Marquardt
search does with ``w`` as its regularisation rows; its covariance is
``(J^T J / scale^2 + diag(1 / std^2))^-1`` at the solution (J the metric's Jacobian). A
parameter whose posterior standard deviation stays near its prior's is not informed by the test.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .parameters import Parameter

#: How many prior standard deviations the bounds lie from the nominal, by default.
BOUNDS_SIGMA = 3.0


@dataclass(frozen=True)
class Prior:
    """Gaussian prior of the scaled parameters about the nominal.

    Attributes
    ----------
    std : (n_p,) standard deviation of each p.
    from_confidence : (n_p,) True where the parameter file gave the engineer's confidence,
        False where the bounds set it.
    """

    std: np.ndarray
    from_confidence: np.ndarray


def prior_of(params: Sequence[Parameter], bounds_sigma: float = BOUNDS_SIGMA) -> Prior:
    """The prior of ``params``: each one's ``confidence``, else the larger distance from the
    nominal to a bound over ``bounds_sigma``."""
    std, given = [], []
    for par in params:
        if par.confidence is not None:
            std.append(par.confidence)
            given.append(True)
        else:
            std.append(max(-par.p_lower, par.p_upper) / bounds_sigma)
            given.append(False)
    return Prior(np.array(std, float), np.array(given, bool))


def effective_observations(residuals: np.ndarray, n_freq: int) -> float:
    """The effective number of independent entries of the residual matrix: the residuals
    (m,) laid out as (m / n_freq) rows by ``n_freq`` frequencies; the square of the
    participation ratio of its singular values (see the module docstring). At most m."""
    R = np.asarray(residuals, float).reshape(-1, n_freq)
    s2 = np.linalg.svd(R, compute_uv=False) ** 2
    if not s2.sum() > 0:
        return float(R.size)
    ratio = s2.sum() ** 2 / (s2**2).sum()
    return float(min(ratio**2, R.size))


@dataclass(frozen=True)
class Likelihood:
    """How the test's residuals weigh against the prior.

    Attributes
    ----------
    sigma : standard deviation of one residual (log10 units).
    m : number of residuals; n_eff : how many independent observations they count as.
    estimated : sigma and n_eff come from the residual (else sigma is the known noise level
        and the residuals are independent).
    """

    sigma: float
    m: int
    n_eff: float
    estimated: bool

    @property
    def scale(self) -> float:
        """sigma sqrt(m / n_eff): the residual norm that one independent observation's
        unit of misfit stands for."""
        return self.sigma * np.sqrt(self.m / self.n_eff)

    def weights(self, prior: Prior) -> np.ndarray:
        """(n_p,) the regularisation rows' weights ``scale / std``."""
        return self.scale / prior.std


def likelihood_of(residuals: np.ndarray, n_freq: int,
                  noise_sigma: float | None = None) -> Likelihood:  # fmt: skip
    """The likelihood (see the module docstring): independent residuals of the given
    ``noise_sigma``, or sigma and n_eff estimated from ``residuals`` (m,), laid out by
    ``n_freq`` frequencies.

    Raises
    ------
    ValueError
        If the residuals are all zero and no noise level is given (nothing to estimate from).
    """
    r = np.asarray(residuals, float)
    m = r.size
    if noise_sigma is not None:
        return Likelihood(float(noise_sigma), m, float(m), False)
    sigma = float(np.sqrt(r @ r / m))
    if not sigma > 0:
        raise ValueError("the test's residuals are zero at the nominal model: give noise_sigma")
    return Likelihood(sigma, m, effective_observations(r, n_freq), True)


@dataclass(frozen=True)
class Posterior:
    """The Gaussian approximation of the posterior at a point.

    Attributes
    ----------
    covariance : (n_p, n_p) of p, zero in the rows and columns of parameters held at the
        nominal.
    std : (n_p,) posterior standard deviation of each p (0 where held).
    ratio : (n_p,) std over the prior's (1 where held: the test told nothing).
    correlation : (n_p, n_p) the posterior correlation (NaN where held).
    crlb : (n_p,) the data-only bound with the same likelihood (the Cramér-Rao bound; inf
        where the test does not inform the parameter).
    """

    covariance: np.ndarray
    std: np.ndarray
    ratio: np.ndarray
    correlation: np.ndarray
    crlb: np.ndarray


def posterior(J: np.ndarray, prior: Prior, likelihood: Likelihood,
              free: np.ndarray | None = None) -> Posterior:  # fmt: skip
    """The posterior of the ``free`` parameters (default all) from the metric's Jacobian
    J (m, n_p) at the point; see the module docstring."""
    n = J.shape[1]
    free = np.ones(n, bool) if free is None else np.asarray(free, bool)
    f = np.flatnonzero(free)
    info = J[:, f].T @ J[:, f] / likelihood.scale**2
    cov = np.zeros((n, n))
    cov[np.ix_(f, f)] = np.linalg.inv(info + np.diag(1.0 / prior.std[f] ** 2))
    std = np.sqrt(np.maximum(np.diag(cov), 0.0))
    ratio = np.where(free, std / prior.std, 1.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(std, std)
    corr[~free, :] = np.nan
    corr[:, ~free] = np.nan
    crlb = np.full(n, np.inf)
    w, V = np.linalg.eigh(info)
    good = w > (w.max() * 1e-14 if len(w) and w.max() > 0 else np.inf)
    bound = (V[:, good] / w[good]) @ V[:, good].T
    reach = (V[:, ~good] ** 2).sum(axis=1) > 1e-12  # in the null space: not informed
    crlb[f] = np.where(reach, np.inf, np.sqrt(np.maximum(np.diag(bound), 0.0)))
    return Posterior(cov, std, ratio, corr, crlb)


def collinearity_index(J: np.ndarray, columns: np.ndarray) -> float:
    """Brun's collinearity index of the sensitivity columns: 1 / sqrt(smallest eigenvalue of
    their normalised Gram matrix); near 1 for independent effects, large when some
    combination of the parameters hardly changes the response (1 for fewer than two)."""
    cols = np.flatnonzero(columns) if np.asarray(columns).dtype == bool else np.asarray(columns)
    if len(cols) < 2:
        return 1.0
    S = J[:, cols]
    S = S / np.linalg.norm(S, axis=0)
    w = np.linalg.eigvalsh(S.T @ S)
    return float(1.0 / np.sqrt(max(w[0], 1e-300)))
