"""What a test engineer checks of identified modes and of the model's fit.

- **MPC** (modal phase collinearity, Pappa, Elliott and Schenk, J. Guidance 16 (1993)): how
  close the shape's components lie to one line in the complex plane, 1 for a normal (real)
  mode, down to 0; ``((l1 - l2) / (l1 + l2))^2`` with l1 >= l2 the eigenvalues of the 2 x 2
  covariance of the real and imaginary parts.
- **MPD** (mean phase deviation, degrees): the components' phase scatter about that line,
  weighted by their size; 0 for a normal mode, 90 at most.
- **Complexity** (%): the size of the shape's part off that line, ``||Im(phi')|| /
  ||phi'||`` with phi' the shape turned onto the line.
- **FRF correlation** per channel (the FRAC of Heylen and Lammens, the MAC of the measured
  and synthesised FRFs over the band): ``|sum conj(H_x) H_m|^2 / (sum |H_x|^2 sum
  |H_m|^2)``, 1 when the model's FRF has the measured one's shape, whatever its scale.
"""

from __future__ import annotations

import numpy as np


def _principal(shapes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per mode (columns of ``shapes`` (n, k)): the 2 x 2 covariance eigenvalues (k, 2)
    descending and the rotation angle (k,) that turns the principal line onto the real
    axis."""
    a, b = shapes.real, shapes.imag
    sxx = np.sum(a * a, axis=0)
    syy = np.sum(b * b, axis=0)
    sxy = np.sum(a * b, axis=0)
    mean = 0.5 * (sxx + syy)
    rad = np.sqrt(0.25 * (sxx - syy) ** 2 + sxy**2)
    theta = 0.5 * np.arctan2(2 * sxy, sxx - syy)
    return np.stack([mean + rad, mean - rad], axis=1), theta


def mpc(shapes: np.ndarray) -> np.ndarray:
    """Modal phase collinearity (k,) of the shapes (n, k), in [0, 1]."""
    lam, _ = _principal(np.asarray(shapes, complex))
    total = lam.sum(axis=1)
    return np.where(total > 0, ((lam[:, 0] - lam[:, 1]) / np.where(total > 0, total, 1)) ** 2,
                    1.0)  # fmt: skip


def _turned(shapes: np.ndarray) -> np.ndarray:
    _, theta = _principal(shapes)
    return shapes * np.exp(-1j * theta)[None, :]


def mpd(shapes: np.ndarray) -> np.ndarray:
    """Mean phase deviation (k,) in degrees of the shapes (n, k) from their principal line
    in the complex plane, weighted by the components' magnitudes."""
    phi = _turned(np.asarray(shapes, complex))
    size = np.abs(phi)
    with np.errstate(invalid="ignore", divide="ignore"):
        dev = np.degrees(np.arcsin(np.clip(np.abs(phi.imag) / size, 0.0, 1.0)))
    dev = np.where(size > 0, dev, 0.0)
    total = size.sum(axis=0)
    return np.where(total > 0, (size * dev).sum(axis=0) / np.where(total > 0, total, 1), 0.0)


def complexity(shapes: np.ndarray) -> np.ndarray:
    """Complexity (k,) in percent: the norm of the shapes' (n, k) part off their principal
    line over their norm."""
    phi = _turned(np.asarray(shapes, complex))
    norm = np.linalg.norm(phi, axis=0)
    return 100.0 * np.linalg.norm(phi.imag, axis=0) / np.where(norm > 0, norm, 1.0)


def frf_correlation(measured: np.ndarray, fitted: np.ndarray) -> np.ndarray:
    """FRF correlation (p,) of each output channel: measured and fitted H (p, m, K)."""
    x = measured.reshape(measured.shape[0], -1)
    y = fitted.reshape(fitted.shape[0], -1)
    num = np.abs(np.sum(x.conj() * y, axis=1)) ** 2
    den = np.sum(np.abs(x) ** 2, axis=1) * np.sum(np.abs(y) ** 2, axis=1)
    return np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)
