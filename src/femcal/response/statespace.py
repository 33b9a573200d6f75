"""Continuous-time state-space models: from normal modes, frequency response, poles, and
series and parallel connection.

A model is ``x' = A x + B u``, ``y = C x + D u`` with A (n, n), B (n, n_in), C (n_out, n),
D (n_out, n_in), real or complex. From modes (mass-normalised shapes phi_r, circular
frequencies w_r, damping ratios zeta_r) the states are the modal coordinates and their rates,
mode by mode: ``x = [q_1, q_1', q_2, q_2', ...]`` with ``q_r'' + 2 zeta_r w_r q_r' + w_r^2 q_r =
phi_r^T f``. Displacement outputs read the q, velocity outputs the q', and acceleration
outputs ``q_r'' = phi_r^T f - 2 zeta_r w_r q_r' - w_r^2 q_r``, which needs the feedthrough D.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .frf import Rayleigh, modal_damping

OUTPUTS = ("displacement", "velocity", "acceleration")


@dataclass(frozen=True)
class StateSpace:
    """``x' = A x + B u``, ``y = C x + D u`` (continuous time)."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray

    def __post_init__(self) -> None:
        n = self.A.shape[0]
        ok = (self.A.shape == (n, n) and self.B.shape[0] == n and self.C.shape[1] == n
              and self.D.shape == (self.C.shape[0], self.B.shape[1]))  # fmt: skip
        if not ok:
            raise ValueError(
                f"inconsistent shapes: A {self.A.shape}, B {self.B.shape}, C {self.C.shape}, "
                f"D {self.D.shape}"
            )

    @property
    def n_states(self) -> int:
        return self.A.shape[0]

    def poles(self) -> np.ndarray:
        """Eigenvalues of A (n,), rad/s."""
        return np.linalg.eigvals(self.A)


def from_modes(
    shapes: np.ndarray,
    omega: np.ndarray,
    damping: float | np.ndarray | Rayleigh,
    C: sp.spmatrix | np.ndarray,
    B: sp.spmatrix | np.ndarray,
    output: str = "displacement",
) -> StateSpace:
    """Real modal state-space model (2k states) of k modes.

    shapes (n_g, k) mass-normalised; omega (k,) rad/s; damping as for
    :func:`femcal.response.frf.modal_frf`; C (n_out, n_g) sensors; B (n_g, n_in) loads; output
    displacement, velocity or acceleration (the latter with feedthrough D).
    """
    if output not in OUTPUTS:
        raise ValueError(f"output must be one of {', '.join(OUTPUTS)}, not {output!r}")
    omega = np.asarray(omega, float)
    zeta = modal_damping(omega, damping)
    k = len(omega)
    Co = np.asarray(C @ shapes)  # (n_out, k)
    Bi = np.asarray(B.T @ shapes).T  # (k, n_in)
    A = np.zeros((2 * k, 2 * k))
    r = np.arange(k)
    A[2 * r, 2 * r + 1] = 1.0
    A[2 * r + 1, 2 * r] = -(omega**2)
    A[2 * r + 1, 2 * r + 1] = -2.0 * zeta * omega
    Bs = np.zeros((2 * k, Bi.shape[1]))
    Bs[2 * r + 1] = Bi
    Cs = np.zeros((Co.shape[0], 2 * k))
    D = np.zeros((Co.shape[0], Bi.shape[1]))
    if output == "displacement":
        Cs[:, 2 * r] = Co
    elif output == "velocity":
        Cs[:, 2 * r + 1] = Co
    else:
        Cs[:, 2 * r] = -Co * omega**2
        Cs[:, 2 * r + 1] = -Co * 2.0 * zeta * omega
        D = Co @ Bi
    return StateSpace(A, Bs, Cs, D)


def frequency_response(ss: StateSpace, freq_hz: np.ndarray) -> np.ndarray:
    """``C (i w I - A)^-1 B + D`` as (n_out, n_in, n_freq) at freq_hz (n_freq,), Hz.

    Through A's eigen-decomposition (one modal sum for all frequencies) when A is well
    diagonalisable, else one linear solve per frequency."""
    w = 2.0 * np.pi * np.asarray(freq_hz, float)
    if ss.n_states:
        lam, V = np.linalg.eig(ss.A)
        if np.linalg.cond(V) < 1e8:
            q = 1.0 / (1j * w[None, :] - lam[:, None])  # (n, n_freq)
            return (np.einsum("pn,nk,nm->pmk", ss.C @ V, q, np.linalg.solve(V, ss.B),
                              optimize=True) + ss.D[:, :, None])  # fmt: skip
    eye = np.eye(ss.n_states)
    H = np.empty((ss.C.shape[0], ss.B.shape[1], len(w)), complex)
    for f, wf in enumerate(w):
        H[:, :, f] = ss.C @ np.linalg.solve(1j * wf * eye - ss.A, ss.B) + ss.D
    return H


def modal_form(ss: StateSpace) -> StateSpace:
    """The same system with a diagonal (complex) A: ``A = V diag(p) V^-1``, B -> V^-1 B,
    C -> C V. Needs a diagonalisable A."""
    p, V = np.linalg.eig(ss.A)
    return StateSpace(np.diag(p), np.linalg.solve(V, ss.B), ss.C @ V, ss.D.astype(complex))


def poles_to_modal(poles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Natural frequency (Hz) and damping ratio of each pole: ``w_n = |p|``,
    ``zeta = -Re(p) / |p|``."""
    p = np.asarray(poles, complex)
    wn = np.abs(p)
    zeta = np.where(wn > 0, -p.real / np.where(wn > 0, wn, 1.0), 0.0)
    return wn / (2.0 * np.pi), zeta


def modal_to_poles(freq_hz: np.ndarray, zeta: np.ndarray) -> np.ndarray:
    """The pole with positive imaginary part of each mode:
    ``p = -zeta w_n + i w_n sqrt(1 - zeta^2)``."""
    wn = 2.0 * np.pi * np.asarray(freq_hz, float)
    z = np.asarray(zeta, float)
    return -z * wn + 1j * wn * np.sqrt(1.0 - z**2)


def series(first: StateSpace, second: StateSpace) -> StateSpace:
    """``second`` driven by the outputs of ``first``: H = H_second H_first."""
    n1, n2 = first.n_states, second.n_states
    if second.B.shape[1] != first.C.shape[0]:
        raise ValueError(f"the second system takes {second.B.shape[1]} inputs, the first "
                         f"gives {first.C.shape[0]} outputs")  # fmt: skip
    A = np.block([[first.A, np.zeros((n1, n2))], [second.B @ first.C, second.A]])
    B = np.vstack([first.B, second.B @ first.D])
    C = np.hstack([second.D @ first.C, second.C])
    return StateSpace(A, B, C, second.D @ first.D)


def parallel(a: StateSpace, b: StateSpace) -> StateSpace:
    """Both driven by the same inputs, outputs summed: H = H_a + H_b."""
    if a.B.shape[1] != b.B.shape[1] or a.C.shape[0] != b.C.shape[0]:
        raise ValueError("parallel systems need the same inputs and outputs")
    na, nb = a.n_states, b.n_states
    A = np.block([[a.A, np.zeros((na, nb))], [np.zeros((nb, na)), b.A]])
    return StateSpace(A, np.vstack([a.B, b.B]), np.hstack([a.C, b.C]), a.D + b.D)
