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
    rigid_share,
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


def test_comac_and_sign_agreement_per_channel():
    from femcal.correlate import comac, sign_agreement

    rng = np.random.default_rng(2)
    A = rng.standard_normal((12, 5))
    T = 3.0 * A.copy()  # a scale per mode changes nothing
    T[4] *= -1  # a sensor mounted reversed: CoMAC cannot see it, the sign agreement can
    T[7] = rng.standard_normal(5)  # a sensor that reads something else
    co, sg = comac(T, A), sign_agreement(T, A)
    np.testing.assert_allclose(comac(3.0 * A, A), 1.0, rtol=1e-12)
    sound = [i for i in range(12) if i not in (4, 7)]
    # the odd channel moves each shape's length a little: the sound channels stay near 1
    assert (co[sound] > 0.99).all() and co[sound].max() <= 1.0 + 1e-12
    np.testing.assert_allclose(sg[sound], 1.0, rtol=1e-12)
    assert co[4] > 0.99 and sg[4] == pytest.approx(-1.0)
    assert co[7] < 0.9 and abs(sg[7]) < 1
    # by hand for one channel: (sum |t a|)^2 / (sum t^2 sum a^2), shapes unit length
    t, a = T / np.linalg.norm(T, axis=0), A / np.linalg.norm(A, axis=0)
    assert co[7] == pytest.approx(np.sum(np.abs(t[7] * a[7])) ** 2
                                  / (np.sum(t[7] ** 2) * np.sum(a[7] ** 2)))
    assert comac(np.zeros((2, 3)), A[:2, :3]).tolist() == [0.0, 0.0]


def test_rigid_share_is_the_rigid_motions_part_of_a_shape():
    rng = np.random.default_rng(3)
    xyz = rng.normal(size=(40, 3)) * [2000.0, 400.0, 150.0] + [5000.0, -300.0, 800.0]
    r = xyz - xyz.mean(axis=0)
    t, theta = np.array([0.3, -1.0, 0.2]), np.array([1e-3, -4e-4, 2e-4])
    rigid = t + np.cross(theta, r)  # a translation and a small turn about the centre
    # a deformation with no rigid part: a random field less its rigid least-squares fit
    basis = np.concatenate([np.tile(np.eye(3), (40, 1))] + [np.cross(e, r).reshape(-1, 1)
                            for e in np.eye(3)], axis=1)  # fmt: skip
    field = rng.normal(size=120)
    deform = (field - basis @ np.linalg.lstsq(basis, field, rcond=None)[0]).reshape(40, 3)
    deform *= np.linalg.norm(rigid) / np.linalg.norm(deform)  # as large as the rigid part
    shares = rigid_share(xyz, np.stack([rigid, deform, rigid + deform, 5 * rigid + deform,
                                        np.zeros((40, 3))]))  # fmt: skip
    np.testing.assert_allclose(shares, [1.0, 0.0, 0.5, 25 / 26, 1.0], atol=1e-9)
