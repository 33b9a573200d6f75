"""Correlation: MAC, pairing by MAC and frequency, SEREP pseudo-orthogonality, scale
factors, against hand-made shapes."""

from __future__ import annotations

import numpy as np
import pytest

from femcal.correlate.shapes import (
    frequency_difference,
    mac,
    modal_scale_factor,
    pair_modes,
    pseudo_orthogonality,
    real_shapes,
    serep_mass,
)


def test_mac_is_one_for_parallel_and_zero_for_orthogonal_shapes():
    a = np.array([[1.0, 0.0], [2.0, 0.0], [0.0, 1.0]])
    b = np.column_stack([-3 * a[:, 0] * np.exp(0.7j), a[:, 1]])
    M = mac(a, b)
    np.testing.assert_allclose(M, np.eye(2), atol=1e-15)
    x = np.array([1.0, 1.0, 0.0])
    assert mac(a[:, [0]], x[:, None])[0, 0] == pytest.approx(9 / (5 * 2))


def test_pairing_takes_the_best_mac_and_each_fe_mode_once():
    rng = np.random.default_rng(0)
    fe = rng.normal(size=(20, 5))
    test = fe[:, [2, 0, 4]] + 0.05 * rng.normal(size=(20, 3))
    pairs = pair_modes(test, [30.0, 10.0, 52.0], fe, [10.5, 20.0, 29.0, 40.0, 50.0])
    assert [(p.test, p.fe) for p in pairs] == [(0, 2), (1, 0), (2, 4)]
    assert pairs[0].frequency_difference == pytest.approx((30 - 29) / 29 * 100)
    assert all(p.mac > 0.98 for p in pairs)
    # a test mode far from every FE frequency stays unpaired
    assert len(pair_modes(test, [300.0, 10.0, 52.0], fe, [10.5, 20.0, 29.0, 40.0, 50.0])) == 2
    assert frequency_difference([11.0], [10.0])[0] == pytest.approx(10.0)


def test_pseudo_orthogonality_of_the_fe_shapes_themselves_is_the_identity():
    rng = np.random.default_rng(1)
    Phi = rng.normal(size=(12, 4))  # FE shapes at 12 sensors
    Ms = serep_mass(Phi)
    np.testing.assert_allclose(Phi.T @ Ms @ Phi, np.eye(4), atol=1e-12)
    # complex, scaled, sign-flipped test shapes still give the identity (signs made positive)
    test = Phi * np.array([2.0, -0.5, 1.0, 3.0]) * np.exp(0.3j)
    P = pseudo_orthogonality(test, Phi, Ms)
    np.testing.assert_allclose(np.abs(P), np.eye(4), atol=1e-12)
    np.testing.assert_allclose(np.abs(real_shapes(test)), np.abs(test), rtol=1e-12)
    s = modal_scale_factor(test[:, 0], Phi[:, 0])
    assert s == pytest.approx(2.0 * np.exp(0.3j))
