"""Helpers shared by the shell kernel tests: isotropic plate stiffness, a dense assembly,
a constrained solve and the rigid-body modes of a node set."""

from __future__ import annotations

import numpy as np


def iso(E: float, nu: float, t: float, k: float = 5.0 / 6.0) -> tuple[np.ndarray, ...]:
    """Isotropic A (3, 3), D (3, 3), S (2, 2) of a plate of thickness t."""
    Q = E / (1 - nu**2) * np.array([[1, nu, 0], [nu, 1, 0], [0, 0, (1 - nu) / 2]])
    return t * Q, t**3 / 12 * Q, k * t * E / (2 * (1 + nu)) * np.eye(2)


def assemble(Ke: np.ndarray, conn: np.ndarray, n_nodes: int) -> np.ndarray:
    """Dense global matrix (6 n_nodes, 6 n_nodes) from element matrices (n, k, k)."""
    dofs = (6 * conn[:, :, None] + np.arange(6)).reshape(len(conn), -1)
    Kg = np.zeros((6 * n_nodes, 6 * n_nodes))
    np.add.at(Kg, (dofs[:, :, None], dofs[:, None, :]), Ke)
    return Kg


def solve(K: np.ndarray, fixed: np.ndarray, u_fixed: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Solve K u = f with u[fixed] = u_fixed; return the full u."""
    n = K.shape[0]
    free = np.setdiff1d(np.arange(n), fixed)
    u = np.zeros(n)
    u[fixed] = u_fixed
    u[free] = np.linalg.solve(K[np.ix_(free, free)], f[free] - K[np.ix_(free, fixed)] @ u_fixed)
    return u


def rigid_modes(xyz: np.ndarray) -> np.ndarray:
    """Rigid-body modes (6 nn, 6) of nodes xyz (nn, 3): 3 translations, 3 rotations."""
    nn = len(xyz)
    R = np.zeros((nn, 6, 6))
    for i in range(3):
        e = np.eye(3)[i]
        R[:, i, i] = 1.0
        R[:, 0:3, 3 + i] = np.cross(e, xyz)
        R[:, 3 + i, 3 + i] = 1.0
    return R.reshape(6 * nn, 6)
