"""Huber's loss as least squares on transformed residuals: the transform's square is the loss,
its derivative is exact, and the minimum of a line fit with outliers is Huber's estimate."""

from __future__ import annotations

import numpy as np

from femcal.calibrate.lm import levenberg_marquardt
from femcal.calibrate.robust import huber_deviation, huber_transform, robust_scale


def _rho(e, c):
    a = np.abs(e)
    return np.where(a <= c, 0.5 * a * a, c * a - 0.5 * c * c)


def test_transform_squares_to_the_loss_and_its_derivative_is_exact():
    e = np.linspace(-3.0, 3.0, 601)
    c = 0.7
    t, d = huber_transform(e, c)
    np.testing.assert_allclose(0.5 * t * t, _rho(e, c), rtol=1e-12, atol=1e-15)
    h = 1e-6
    fd = (huber_transform(e + h, c)[0] - huber_transform(e - h, c)[0]) / (2 * h)
    away = np.abs(np.abs(e) - c) > 1e-3  # not across the kink
    np.testing.assert_allclose(d[away], fd[away], rtol=1e-6)
    assert huber_deviation(e, c) == np.sum(2 * _rho(e, c))
    assert huber_deviation(e, None) == e @ e


def test_robust_scale_is_the_standard_deviation_of_gaussian_residuals():
    rng = np.random.default_rng(5)
    e = 0.3 * rng.standard_normal(200_000)
    e[:1000] = 50.0  # outliers do not move it
    assert abs(robust_scale(e) / 0.3 - 1) < 0.02


def test_lm_on_the_transform_finds_hubers_line_through_outliers():
    rng = np.random.default_rng(2)
    x = np.linspace(0, 1, 200)
    y = 1.0 + 2.0 * x + 0.01 * rng.standard_normal(200)
    y[::20] += 5.0  # one point in twenty far off
    c = 2.0 * 0.01

    def fun(p):
        t, d = huber_transform(p[0] + p[1] * x - y, c)
        return t, (lambda: d[:, None] * np.column_stack([np.ones_like(x), x]))

    p = levenberg_marquardt(fun, np.zeros(2), -10 * np.ones(2), 10 * np.ones(2),
                            max_iter=200).p  # fmt: skip
    np.testing.assert_allclose(p, [1.0, 2.0], atol=0.01)
    ls = np.polyfit(x, y, 1)[::-1]  # least squares is pulled off by the outliers
    assert abs(ls[0] - 1.0) > 0.2
