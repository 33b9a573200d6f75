"""Levenberg-Marquardt within bounds, Latin hypercube starts and the Cramér-Rao bound."""

from __future__ import annotations

import numpy as np
import pytest

from femcal.calibrate.lm import latin_hypercube, levenberg_marquardt
from femcal.calibrate.prior import Likelihood, Prior, likelihood_of, posterior


def rosenbrock(p):
    x, y = p
    r = np.array([10 * (y - x**2), 1 - x])
    J = np.array([[-20 * x, 10.0], [-1.0, 0.0]])
    return r, J


def test_unbounded_minimum_is_found():
    res = levenberg_marquardt(rosenbrock, [-1.2, 1.0], [-5, -5], [5, 5], max_iter=200,
                              ftol=1e-14, xtol=1e-12)  # fmt: skip
    np.testing.assert_allclose(res.p, [1.0, 1.0], atol=1e-7)
    assert res.converged and res.cost < 1e-14
    assert all(b < a for a, b in zip(res.history, res.history[1:], strict=False))


def test_a_bound_holds_and_the_other_parameter_is_optimal_given_it():
    # minimum of |A p - b|^2 with p0 <= 0.5 where the free minimum has p0 = 2
    rng = np.random.default_rng(0)
    A = rng.normal(size=(30, 2))
    b = A @ np.array([2.0, -1.0])
    res = levenberg_marquardt(lambda p: (A @ p - b, A), [0.0, 0.0], [-1, -3], [0.5, 3],
                              ftol=1e-14, xtol=1e-12)  # fmt: skip
    assert res.p[0] == 0.5
    # given p0 = 0.5, p1 minimises |A[:,1] p1 - (b - 0.5 A[:,0])|
    p1 = np.linalg.lstsq(A[:, 1:], b - 0.5 * A[:, 0], rcond=None)[0][0]
    assert res.p[1] == pytest.approx(p1, rel=1e-8)


def test_a_parameter_whose_bounds_meet_is_held_whatever_its_column():
    """A parameter with lower == upper is held: the search takes the same steps to the same
    point whether its Jacobian column is computed, zero or anything else."""
    rng = np.random.default_rng(5)
    A = rng.normal(size=(40, 4))
    b = A @ np.array([1.0, -2.0, 0.5, 3.0]) + 0.1 * rng.normal(size=40)
    lo, hi = np.array([-5.0, 0.2, -5.0, -5.0]), np.array([5.0, 0.2, 5.0, 5.0])

    def fun(column):
        def f(p):  # r = A p - b + 0.1 sin(p_0 + p_2), mildly nonlinear
            J = A.copy()
            J[:, 0] += 0.1 * np.cos(p[0] + p[2])
            J[:, 2] += 0.1 * np.cos(p[0] + p[2])
            J[:, 1] = column
            return A @ p - b + 0.1 * np.sin(p[0] + p[2]), J
        return f

    runs = [levenberg_marquardt(fun(c), np.zeros(4), lo, hi, ftol=1e-14, xtol=1e-12)
            for c in (A[:, 1], 0.0, rng.normal(size=40))]  # fmt: skip
    for r in runs:
        assert r.p[1] == 0.2
        assert np.array_equal(r.p, runs[0].p) and r.history == runs[0].history
    assert runs[0].iterations > 1


def test_latin_hypercube_puts_one_point_in_each_slice():
    pts = latin_hypercube(8, [-0.2, 0.0, 1.0], [0.2, 1.0, 3.0], np.random.default_rng(1))
    assert pts.shape == (8, 3)
    for d, (lo, hi) in enumerate([(-0.2, 0.2), (0.0, 1.0), (1.0, 3.0)]):
        slots = np.floor((pts[:, d] - lo) / (hi - lo) * 8).astype(int)
        assert sorted(slots) == list(range(8))


def test_crlb_of_linear_regression_is_its_standard_error():
    rng = np.random.default_rng(3)
    X = np.column_stack([np.ones(200), np.linspace(0, 1, 200)])
    sigma = 0.1
    y = X @ [1.0, 2.0] + sigma * rng.normal(size=200)
    beta = np.linalg.lstsq(X, y, rcond=None)[0]
    r = X @ beta - y
    known = Likelihood(sigma=sigma, m=200, n_eff=200.0, estimated=False)
    vague = Prior(np.full(2, 1e8), np.zeros(2, bool))
    post = posterior(X, vague, known)
    se = sigma * np.sqrt(np.diag(np.linalg.inv(X.T @ X)))
    np.testing.assert_allclose(post.crlb, se, rtol=1e-12)
    np.testing.assert_allclose(post.std, se, rtol=1e-9)  # a vague prior adds nothing
    # sigma estimated from the residual
    assert likelihood_of(r, 200, None).sigma == pytest.approx(sigma, rel=0.15)
    # a parameter the data do not inform has an infinite bound; its posterior is its prior
    X3 = np.column_stack([X, np.zeros(200)])
    post3 = posterior(X3, Prior(np.array([1e8, 1e8, 0.1]), np.zeros(3, bool)), known)
    assert np.isinf(post3.crlb[2]) and np.allclose(post3.crlb[:2], se, rtol=1e-9)
    assert post3.ratio[2] == pytest.approx(1.0)
