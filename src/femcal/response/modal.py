"""Modal factors: the frequency dependence of one mode's contribution to an FRF.

A mode of eigenvalue lam (rad^2/s^2) and damping ratio zeta contributes to the receptance
through ``1 / (lam - w^2 + 2 i zeta omega w)`` (omega its circular frequency); mobility and
accelerance multiply it by ``(i w)^a``, a = 1, 2. The modal FRFs
(:mod:`femcal.response.frf`) and the calibration's surrogate and exact derivatives use these.
"""

from __future__ import annotations

import numpy as np

#: FRF quantities: displacement, velocity or acceleration per force.
QUANTITIES = ("receptance", "mobility", "accelerance")
#: The power a of (i w) that turns a receptance into each quantity.
POWER = {"receptance": 0, "mobility": 1, "accelerance": 2}


def _parts(lam: np.ndarray, freq_hz: np.ndarray, zeta: float | np.ndarray,
           omega: np.ndarray | None) -> tuple[np.ndarray, ...]:  # fmt: skip
    """(w (n_f,), omega (k,), zeta as it broadcasts over (k, n_f), the denominators (k, n_f))."""
    w = 2 * np.pi * np.asarray(freq_hz, float)
    root = np.sqrt(np.maximum(lam, 0.0)) if omega is None else np.asarray(omega, float)
    z = np.asarray(zeta, float)
    z = z[:, None] if z.ndim else z
    return w, root, z, lam[:, None] - w[None, :] ** 2 + 2j * z * root[:, None] * w[None, :]


def modal_factors(lam: np.ndarray, freq_hz: np.ndarray, zeta: float | np.ndarray,
                  quantity: str = "receptance", *,
                  omega: np.ndarray | None = None) -> np.ndarray:  # fmt: skip
    """Modal factors q (k, n_f) = (i w)^a / (lam - w^2 + 2 i zeta omega w) of k modes at
    ``freq_hz`` (n_f,), Hz.

    lam : (k,) eigenvalues, rad^2/s^2. zeta : one damping ratio, or (k,) one per mode.
    omega : (k,) circular frequencies of the damping term; default sqrt(lam), 0 for lam < 0.
    """
    w, _, _, Dn = _parts(lam, freq_hz, zeta, omega)
    return (1j * w[None, :]) ** POWER[quantity] / Dn


def modal_factors_and_slopes(lam: np.ndarray, freq_hz: np.ndarray, zeta: float,
                             quantity: str) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """:func:`modal_factors` q (k, n_f) with omega = sqrt(lam), and their derivatives
    dq/dlam (k, n_f)."""
    w, root, z, Dn = _parts(lam, freq_hz, zeta, None)
    q = (1j * w[None, :]) ** POWER[quantity] / Dn
    safe = np.where(root > 0, root, 1.0)
    dD = 1.0 + np.where(root[:, None] > 0, 1j * z * w[None, :] / safe[:, None], 0.0)
    return q, -q * dD / Dn


def static_factor(freq_hz: np.ndarray, quantity: str) -> np.ndarray:
    """(i w)^a (n_f,): a static receptance as this quantity."""
    return (2j * np.pi * np.asarray(freq_hz, float)) ** POWER[quantity]
