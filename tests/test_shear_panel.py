"""CSHEAR shear panel: rigid motions carry no strain, pure shear gives G t A gamma^2 / 2."""

from __future__ import annotations

import numpy as np
import pytest

from femcal.elements.shear import shear_panel_matrices


@pytest.mark.parametrize("angle", [0.0, 0.3])
def test_shear_panel_rigid_modes_rank_and_energy(angle):
    a, b = 200.0, 100.0
    G, t, mass_area = 8.0e4, 2.0, 1e-6
    c, s = np.cos(angle), np.sin(angle)
    R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])  # panel axes in basic (columns)
    local = np.array([[0, 0, 0], [a, 0, 0], [a, b, 0], [0, b, 0]], float)
    xyz = local @ R.T + [5.0, -3.0, 2.0]
    K, M = shear_panel_matrices(xyz[None], np.array([G]), np.array([t]), np.array([mass_area]))
    k = K[0]
    assert np.allclose(k, k.T)
    w = np.linalg.eigvalsh(k)
    assert (w > 1e-9 * w.max()).sum() == 1  # one deformation mode: constant shear
    # pure shear u_x = gamma * y (panel axes): strain energy G t A gamma^2 / 2
    gamma = 1e-3
    u = np.zeros(24)
    for node in range(4):
        u[6 * node : 6 * node + 3] = R @ np.array([gamma * local[node, 1], 0.0, 0.0])
    assert 0.5 * u @ k @ u == pytest.approx(0.5 * G * t * a * b * gamma**2)
    # rigid translation and in-plane rotation carry no strain
    rot = np.zeros(24)
    for node in range(4):
        rot[6 * node : 6 * node + 3] = R @ np.array([-local[node, 1], local[node, 0], 0.0])
    assert abs(rot @ k @ rot) < 1e-9 * abs(u @ k @ u) / gamma**2
    # lumped mass: m A / 4 per node and direction
    assert M[0].trace() == pytest.approx(3 * mass_area * a * b)
