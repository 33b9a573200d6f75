"""Frequency response functions from normal modes, and the direct solution that checks them.

H has shape (n_out, n_in, n_freq): output ``o`` per unit harmonic input ``i`` at each
frequency. Outputs and inputs are rows of a sensor matrix ``C`` (n_out, n_g) and columns of
a load matrix ``B`` (n_g, n_in) on the g-set, in the nodes' displacement (CD) frames;
:func:`point_matrix` builds them for GRID components 1-6 and :func:`direction_matrix` for
any measurement direction given in the basic frame.

Modal superposition (mass-normalised shapes phi_r, circular frequencies w_r, modal damping
zeta_r)::

    H(w) = sum_r (C phi_r)(phi_r^T B) / (w_r^2 - w^2 + 2 i zeta_r w_r w)

gives receptance (displacement per force); mobility is ``i w H`` and accelerance ``-w^2 H``.
Damping: one ratio for all modes, one per mode, or Rayleigh ``C = alpha M + beta K``, for
which ``zeta_r = alpha / (2 w_r) + beta w_r / 2`` and the modal sum over all modes equals the
direct solution of ``(K + i w C - w^2 M) u = f`` (:func:`direct_frf`), which the tests use to
check the synthesis.

Residual flexibility (:func:`residual_flexibility`) adds what the modes left out contribute
at low frequency: the static flexibility minus that of the kept elastic modes, a constant
``R`` (n_out, n_in) added to the receptance. It needs a restrained model (K nonsingular).
With all finite modes kept it is exactly the part of massless DOF, so the sum then equals
the direct solution even when M is singular (a test checks).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..model.model import Model
from .modal import QUANTITIES, modal_factors, static_factor


@dataclass(frozen=True)
class Rayleigh:
    """Proportional damping ``C = alpha M + beta K`` (alpha in 1/s, beta in s)."""

    alpha: float = 0.0
    beta: float = 0.0

    def ratios(self, omega: np.ndarray) -> np.ndarray:
        """Modal damping ratios (k,) at circular frequencies omega (k,), rad/s; a rigid-body
        mode (omega = 0) takes none of the mass-proportional part."""
        w = np.asarray(omega, float)
        safe = np.where(w > 0, w, 1.0)
        return np.where(w > 0, self.alpha / (2.0 * safe), 0.0) + self.beta * w / 2.0


def point_matrix(model: Model, points: Sequence[tuple[int, int]]) -> sp.csr_matrix:
    """Sensor matrix (n_points, n_g) picking GRID components (grid id, component 1-6; a scalar
    point takes component 0 or 1) in the node's displacement frame.

    Raises
    ------
    ValueError
        For an unknown grid or a component it does not have, naming the point.
    """
    rows = []
    for gid, comp in points:
        idx = int(model.node_index(gid)[0])
        if idx < 0:
            raise ValueError(f"point {gid}:{comp}: no GRID or SPOINT {gid} in the model")
        if model.is_grid[idx]:
            if not 1 <= comp <= 6:
                raise ValueError(f"point {gid}:{comp}: a GRID has components 1-6")
            rows.append(int(model.dof_start[idx]) + comp - 1)
        else:
            if comp not in (0, 1):
                raise ValueError(f"point {gid}:{comp}: a scalar point has component 0 (or 1)")
            rows.append(int(model.dof_start[idx]))
    n = len(rows)
    return sp.csr_matrix((np.ones(n), (np.arange(n), rows)), shape=(n, model.n_dof))


def direction_matrix(
    model: Model, points: Sequence[tuple[int, Sequence[float]]], *, rotation: bool = False
) -> sp.csr_matrix:
    """Sensor matrix (n_points, n_g) for measurement directions given in the basic frame.

    Each point is (grid id, direction (3,)); the direction is normalised and taken into the
    node's displacement (CD) frame, so a sensor along (0, 0.6, 0.8) reads
    ``0.6 u_y + 0.8 u_z`` in basic coordinates whatever the node's CD system. With
    ``rotation`` the direction applies to the rotations (components 4-6) instead.

    Raises
    ------
    ValueError
        For an unknown grid, a scalar point or a zero direction, naming the point.
    """
    rows, cols, vals = [], [], []
    for r, (gid, vec) in enumerate(points):
        idx = int(model.node_index(gid)[0])
        if idx < 0 or not model.is_grid[idx]:
            raise ValueError(f"point {gid}: no GRID {gid} in the model")
        v = np.asarray(vec, float).reshape(3)
        norm = np.linalg.norm(v)
        if not norm > 0:
            raise ValueError(f"point {gid}: direction {tuple(v)} has no length")
        local = model.cd_frames[idx].T @ (v / norm)  # components in the CD frame
        start = int(model.dof_start[idx]) + (3 if rotation else 0)
        rows += [r] * 3
        cols += list(range(start, start + 3))
        vals += list(local)
    return sp.csr_matrix((vals, (rows, cols)), shape=(len(points), model.n_dof))


_AXES = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}


def channel_matrix(model: Model, channels: Sequence) -> sp.csr_matrix:
    """Sensor matrix (n, n_g) of measurement channels labelled ``GRID:DIR`` (objects with
    ``label``, ``grid`` and ``direction``, as :class:`femcal.testdata.data.Channel`).

    A signed axis (``+X``, ``-Y``, ``+RZ``) is a direction in the basic frame, taken into
    the node's displacement frame (:func:`direction_matrix`); a component number (``1``-``6``)
    is that component in the node's displacement frame (:func:`point_matrix`).

    Raises
    ------
    ValueError
        For a label that names no grid and direction, or a grid the model lacks.
    """
    rows = []
    for ch in channels:
        if ch.grid is None or ch.direction is None:
            raise ValueError(f"channel {ch.label!r}: expected GRID:DIRECTION (e.g. 1001:+Z)")
        d = ch.direction.upper()
        if d.lstrip("+-").isdigit():
            comp = int(d.lstrip("+-"))
            rows.append(point_matrix(model, [(ch.grid, comp)]) * (-1.0 if d[0] == "-" else 1.0))
            continue
        sign = -1.0 if d.startswith("-") else 1.0
        axis = d.lstrip("+-")
        rot = axis.startswith("R")
        vec = sign * np.array(_AXES[axis.lstrip("R")])
        rows.append(direction_matrix(model, [(ch.grid, vec)], rotation=rot))
    return sp.vstack(rows).tocsr() if rows else sp.csr_matrix((0, model.n_dof))


def modal_damping(
    omega: np.ndarray, damping: float | Sequence[float] | np.ndarray | Rayleigh
) -> np.ndarray:
    """Damping ratio per mode (k,) from one ratio, one per mode, or :class:`Rayleigh`."""
    omega = np.asarray(omega, float)
    if isinstance(damping, Rayleigh):
        return damping.ratios(omega)
    z = np.broadcast_to(np.asarray(damping, float), omega.shape).copy()
    if (z < 0).any():
        raise ValueError("damping ratios must not be negative")
    return z


def modal_frf(
    shapes: np.ndarray,
    omega: np.ndarray,
    C: sp.spmatrix | np.ndarray,
    B: sp.spmatrix | np.ndarray,
    freq_hz: np.ndarray,
    damping: float | Sequence[float] | np.ndarray | Rayleigh,
    quantity: str = "receptance",
    residual: np.ndarray | None = None,
) -> np.ndarray:
    """FRFs (n_out, n_in, n_freq) by modal superposition.

    Parameters
    ----------
    shapes : (n_g, k) mass-normalised mode shapes on the g-set.
    omega : (k,) circular natural frequencies, rad/s (rigid-body modes 0).
    C : (n_out, n_g) sensor matrix; B : (n_g, n_in) load matrix.
    freq_hz : (n_freq,) frequencies, Hz.
    damping : one ratio, one per mode (k,), or :class:`Rayleigh`.
    quantity : receptance (length/force), mobility (length/(force s)) or accelerance
        (length/(force s^2)).
    residual : (n_out, n_in) residual flexibility added to the receptance (see
        :func:`residual_flexibility`), or None.
    """
    if quantity not in QUANTITIES:
        raise ValueError(f"quantity must be one of {', '.join(QUANTITIES)}, not {quantity!r}")
    omega = np.asarray(omega, float)
    zeta = modal_damping(omega, damping)
    out_r = np.asarray(C @ shapes)  # (n_out, k)
    in_r = np.asarray(B.T @ shapes)  # (n_in, k)
    q = modal_factors(omega**2, freq_hz, zeta, omega=omega)  # (k, n_freq) modal receptances
    H = np.einsum("ok,ik,kf->oif", out_r, in_r, q)
    if residual is not None:
        H = H + np.asarray(residual)[:, :, None]
    return H * static_factor(freq_hz, quantity)


def residual_flexibility(
    K: sp.spmatrix,
    T: sp.spmatrix,
    C: sp.spmatrix | np.ndarray,
    B: sp.spmatrix | np.ndarray,
    shapes: np.ndarray,
    omega: np.ndarray,
) -> np.ndarray:
    """Residual flexibility (n_out, n_in): ``C (K^-1 - sum_r phi_r phi_r^T / w_r^2) B`` over
    the kept modes (mass-normalised g-set shapes (n_g, k), omega (k,) rad/s, all > 0).

    K : (n_a, n_a) reduced stiffness; T : (n_g, n_a).

    Raises
    ------
    ValueError
        If a kept mode is a rigid-body mode or K is singular (a free model: its static
        flexibility does not exist without inertia relief, which is not implemented).
    """
    omega = np.asarray(omega, float)
    if (omega <= 0).any() or (omega < 1e-6 * omega.max()).any():
        raise ValueError("residual flexibility needs a restrained model: a kept mode is rigid")
    T = sp.csr_matrix(T)
    Ba = np.asarray((T.T @ sp.csr_matrix(B)).todense())
    try:
        xa = spla.splu(sp.csc_matrix(K)).solve(Ba)
    except RuntimeError as e:
        raise ValueError(f"residual flexibility needs a nonsingular K ({e})") from None
    static = np.asarray(sp.csr_matrix(C) @ (T @ xa))
    out_r = np.asarray(C @ shapes)
    in_r = np.asarray(B.T @ shapes)
    return static - (out_r / omega**2) @ in_r.T


def direct_frf(
    K: sp.spmatrix,
    M: sp.spmatrix,
    T: sp.spmatrix,
    C: sp.spmatrix | np.ndarray,
    B: sp.spmatrix | np.ndarray,
    freq_hz: np.ndarray,
    damping: Rayleigh,
    quantity: str = "receptance",
) -> np.ndarray:
    """FRFs (n_out, n_in, n_freq) by solving ``(K + i w (alpha M + beta K) - w^2 M) u = f`` on
    the independent set at every frequency (one sparse LU each).

    K, M : (n_a, n_a) reduced matrices; T : (n_g, n_a) with u_g = T u_a; C, B as for
    :func:`modal_frf`.
    """
    if quantity not in QUANTITIES:
        raise ValueError(f"quantity must be one of {', '.join(QUANTITIES)}, not {quantity!r}")
    K, M, T = sp.csc_matrix(K), sp.csc_matrix(M), sp.csr_matrix(T)
    Ca = np.asarray((sp.csr_matrix(C) @ T).todense())  # (n_out, n_a)
    Ba = np.asarray((T.T @ sp.csr_matrix(B)).todense())  # (n_a, n_in)
    w = 2.0 * np.pi * np.asarray(freq_hz, float)
    H = np.empty((Ca.shape[0], Ba.shape[1], len(w)), complex)
    for f, wf in enumerate(w):
        A = (K * (1.0 + 1j * wf * damping.beta) + M * (1j * wf * damping.alpha - wf * wf)).tocsc()
        H[:, :, f] = Ca @ spla.splu(A).solve(Ba.astype(complex))
    return H * static_factor(freq_hz, quantity)
