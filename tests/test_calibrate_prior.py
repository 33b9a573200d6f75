"""The calibration's prior, likelihood and posterior (femcal.calibrate.prior) and the
identifiability analysis before the search (femcal.calibrate.identifiability)."""

from __future__ import annotations

import numpy as np
import pytest

from femcal.calibrate.identifiability import identifiability
from femcal.calibrate.lm import levenberg_marquardt
from femcal.calibrate.parameters import Parameter
from femcal.calibrate.prior import (
    Likelihood,
    Prior,
    collinearity_index,
    effective_observations,
    likelihood_of,
    posterior,
    prior_of,
)


def _params(n: int) -> list[Parameter]:
    return [Parameter(f"q{k}", "PSHELL", k + 1, "T", 5.0, 4.0, 6.5) for k in range(n)]


def test_the_prior_reads_the_bounds_or_the_confidence():
    params = _params(2)
    params[1] = Parameter("c", "MAT1", 1, "E", 2.0, 1.0, 3.0, confidence=0.04)
    prior = prior_of(params, bounds_sigma=3.0)
    # the wider side of [4, 6.5] about 5 is +30 %: three standard deviations
    np.testing.assert_allclose(prior.std, [0.1, 0.04])
    assert list(prior.from_confidence) == [False, True]


def test_effective_observations_of_correlated_and_of_white_residuals():
    rng = np.random.default_rng(3)
    smooth = np.outer(rng.standard_normal(40), np.sin(np.linspace(0, 3, 200)))  # one pattern
    assert effective_observations(smooth.ravel(), 200) == pytest.approx(1.0)
    white = rng.standard_normal((300, 300))
    # a square white matrix's singular values give a participation ratio of about n / 2, so
    # the estimate counts about a quarter of white residuals (it is meant for correlated ones)
    n_eff = effective_observations(white.ravel(), 300)
    assert white.size / 6 < n_eff < white.size / 3


def test_the_likelihood_is_the_given_noise_or_estimated_from_the_residual():
    r = np.random.default_rng(1).standard_normal(600) * 0.2
    known = likelihood_of(r, 100, noise_sigma=0.01)
    assert (known.sigma, known.n_eff, known.estimated) == (0.01, 600.0, False)
    assert known.scale == pytest.approx(0.01)
    est = likelihood_of(r, 100)
    assert est.estimated and est.sigma == pytest.approx(np.sqrt(r @ r / 600))
    assert est.scale == pytest.approx(est.sigma * np.sqrt(600 / est.n_eff))
    with pytest.raises(ValueError, match="residuals are zero at the nominal model"):
        likelihood_of(np.zeros(10), 5)


def test_the_search_with_the_prior_rows_finds_the_linear_map_and_its_covariance():
    """For a linear model the posterior is exact: the Levenberg-Marquardt minimum of
    |J p - y|^2 + |w p|^2 with w = scale / std is the closed-form maximum a posteriori."""
    rng = np.random.default_rng(7)
    J = rng.standard_normal((120, 4)) * [5.0, 1.0, 0.2, 0.01]
    y = rng.standard_normal(120)
    prior = Prior(np.array([0.1, 0.1, 0.05, 0.2]), np.zeros(4, bool))
    lik = Likelihood(sigma=0.3, m=120, n_eff=30.0, estimated=True)
    w = lik.weights(prior)

    def fun(p):
        r = np.concatenate([J @ p - y, w * p])
        return r, (lambda: np.vstack([J, np.diag(w)]))

    p = levenberg_marquardt(fun, np.zeros(4), -np.ones(4), np.ones(4), max_iter=100).p
    A = J.T @ J / lik.scale**2 + np.diag(1 / prior.std**2)
    np.testing.assert_allclose(p, np.linalg.solve(A, J.T @ y / lik.scale**2), rtol=1e-6,
                               atol=1e-9)  # fmt: skip
    post = posterior(J, prior, lik)
    np.testing.assert_allclose(post.covariance, np.linalg.inv(A), rtol=1e-10)
    np.testing.assert_allclose(post.ratio, np.sqrt(np.diag(np.linalg.inv(A))) / prior.std)
    assert post.ratio[0] < 0.2 < 0.9 < post.ratio[2] and post.ratio[3] > 0.999
    np.testing.assert_allclose(post.crlb, np.sqrt(np.diag(np.linalg.inv(J.T @ J))) * lik.scale,
                               rtol=1e-8)  # fmt: skip


def test_identifiability_holds_what_the_test_cannot_inform_and_names_pairs():
    rng = np.random.default_rng(11)
    base = rng.standard_normal((200, 3))
    J = np.column_stack([10 * base[:, 0] + 0.1 * base[:, 2],   # informed together with q3
                         0.3 * base[:, 1],                     # weakly informed
                         np.zeros(200),                        # not at all
                         10 * base[:, 0],                      # together with q0
                         4 * base[:, 2]])                      # on its own
    params = _params(5)
    prior = Prior(np.full(5, 0.1), np.zeros(5, bool))
    lik = Likelihood(sigma=1.0, m=200, n_eff=200.0, estimated=False)
    a = identifiability(J, params, prior, lik, hold_ratio=0.99, identifiable_ratio=0.5)
    assert list(a.held) == [False, False, True, False, False]
    assert list(a.identifiable) == [False, False, False, False, True]
    assert "weakly informed" in a.reasons[1]
    assert "held at the nominal" in a.reasons[2] and "cannot inform" in a.reasons[2]
    assert [(i, j) for i, j, _ in a.pairs] == [(0, 3)] and a.pairs[0][2] < -0.9
    assert "informed together with q3" in a.reasons[0] and "together" not in a.reasons[4]
    assert collinearity_index(J, np.array([0, 3])) > 100  # nearly the same column
    assert collinearity_index(J, np.array([0, 1])) < 2
