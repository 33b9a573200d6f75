"""Concentrated masses: CONM2 (mass, offset and inertia) and CONM1 (6 x 6 mass matrix)."""

from __future__ import annotations

import numpy as np

from .line import skew


def conm2_matrix(
    m: np.ndarray, offset: np.ndarray, inertia: np.ndarray, T: np.ndarray
) -> np.ndarray:
    """6 x 6 mass matrices of CONM2 at their grids, in basic.

    Parameters
    ----------
    m : (n,) mass.
    offset : (n, 3) vector from the grid to the centre of gravity, in basic.
    inertia : (n, 6) I11, I21, I22, I31, I32, I33 as written on the card (about the centre of
        gravity, in the CID frame). NASTRAN's sign convention: the inertia tensor is
        [[I11, -I21, -I31], [-I21, I22, -I32], [-I31, -I32, I33]].
    T : (n, 3, 3) CID frame: columns are its axes in basic.

    Returns
    -------
    (n, 6, 6) on [T1 T2 T3 R1 R2 R3] of the grid, basic frame.
    """
    i11, i21, i22, i31, i32, i33 = (inertia[:, k] for k in range(6))
    J = np.stack(
        [
            np.stack([i11, -i21, -i31], axis=1),
            np.stack([-i21, i22, -i32], axis=1),
            np.stack([-i31, -i32, i33], axis=1),
        ],
        axis=1,
    )
    J = T @ J @ np.swapaxes(T, 1, 2)
    S = skew(offset)
    n = len(m)
    M = np.zeros((n, 6, 6))
    M[:, 0:3, 0:3] = m[:, None, None] * np.eye(3)
    M[:, 0:3, 3:6] = -m[:, None, None] * S
    M[:, 3:6, 0:3] = m[:, None, None] * S
    M[:, 3:6, 3:6] = J - m[:, None, None] * (S @ S)
    return M


def conm1_matrix(lower: np.ndarray, T: np.ndarray) -> np.ndarray:
    """6 x 6 mass matrices of CONM1 in basic.

    Parameters
    ----------
    lower : (n, 21) M11, M21, M22, M31, M32, M33, ... M66 (row-wise lower triangle, CID frame).
    T : (n, 3, 3) CID frame: columns are its axes in basic.
    """
    n = len(lower)
    M = np.zeros((n, 6, 6))
    k = 0
    for i in range(6):
        for j in range(i + 1):
            M[:, i, j] = M[:, j, i] = lower[:, k]
            k += 1
    T6 = np.zeros((n, 6, 6))
    T6[:, 0:3, 0:3] = T
    T6[:, 3:6, 3:6] = T
    return T6 @ M @ np.swapaxes(T6, 1, 2)
