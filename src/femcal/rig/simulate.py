"""Time simulation of a rig plant (:class:`~femcal.rig.plant.RigPlant`) driven by sampled
actuator displacements.

Each mode's dynamic remainder ``xi'' + 2 zeta w xi' + w^2 xi = pi(t)`` (the plant's
mode-acceleration form, ``pi = -(beta . s'' + 2 zeta w beta . s') / w^2``) is, in the
eigenvector coordinates of its two states, the complex first-order equation ``eta' = mu eta
+ pi / (2 i w_d)`` with ``mu = -zeta w + i w_d`` and ``w_d = w sqrt(1 - zeta^2)``; then
``xi = 2 Re eta`` and ``xi' = 2 Re(mu eta)``. It is discretised exactly for an input that
is linear between samples (first-order hold, Franklin, Powell and Workman, Digital Control
of Dynamic Systems, 3rd ed., sec. 6.3.2): with ``E = exp(mu T)``, ``c0 + c1 = (E - 1) / mu``
and ``c1 = (E - 1 - mu T) / (mu^2 T)``,

    eta[k+1] = E eta[k] + g (c0 pi[k] + c1 pi[k+1]),

run as a one-pole filter (:func:`scipy.signal.lfilter`) on ``w = eta - g c1 pi``, mode by
mode, over blocks of samples, so that the state carries from block to block and only one
block of modal inputs and coordinates is held at a time: hours of drive need the drives and
the outputs in memory, not the modes' histories.

A sampled drive stands for a band-limited one, which the straight lines between samples
only approximate: their gain at frequency ``f`` falls by ``sinc^2(f T)`` (1.1 % at 30 Hz
sampled at 512 Hz). The modal input is therefore first passed through the three-tap
filter ``(-1, 14, -1) / 12``, whose gain ``(7 - cos(2 pi f T)) / 6`` undoes that fall to
within ``(2 pi f T)^4 / 90`` (2e-4 at 30 Hz, 512 Hz), so that a sampled sine meets the
plant's frequency response at its frequency (:meth:`RigPlant.frf`). The drives' rates and
accelerations are sixth-order central differences (errors ``(2 pi f T)^6 / 140`` and
``/ 560``). ``periodic=True`` takes the record as one period of a periodic drive: the
differences wrap around and every mode starts in its steady state. Otherwise every mode
starts at rest, and the drive is continued past its ends by odd reflection (which keeps
its slope) for the differences.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.signal as ss

from ..errors import TimeDataError
from ..parallel.progress import Step
from .plant import RigPlant

#: Samples per block of modal coordinates.
BLOCK = 16384


def _hold_coefficients(mu: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """(c0, c1) of the first-order hold for poles mu (k,), series near mu T = 0."""
    x = mu * dt
    small = np.abs(x) < 1e-3
    xs = np.where(small, 1.0, x)
    ex = np.expm1(xs)
    i0 = np.where(small, dt * (1 + x / 2 + x**2 / 6 + x**3 / 24), ex / xs * dt)
    i1 = np.where(small, dt * (0.5 + x / 6 + x**2 / 24 + x**3 / 120),
                  (ex - xs) / xs**2 * dt)  # fmt: skip
    return i0 - i1, i1


#: Sixth-order central differences over offsets -3..3: first and second derivative.
_D1 = np.array([-1, 9, -45, 0, 45, -9, 1]) / 60
_D2 = np.array([2, -27, 270, -490, 270, -27, 2]) / 180


def derivatives(s: np.ndarray, dt: float, periodic: bool) -> tuple[np.ndarray, np.ndarray]:
    """(s', s'') of s (n_in, n) by sixth-order central differences, wrapped at the ends of
    a periodic drive, else over the drive continued by odd reflection."""
    n = s.shape[1]
    if n < 4:
        return np.zeros_like(s), np.zeros_like(s)
    if periodic:
        padded = np.concatenate([s[:, -3:], s, s[:, :3]], axis=1) if n >= 3 else s
    else:
        padded = np.pad(s, ((0, 0), (3, 3)), mode="reflect", reflect_type="odd")
    d1 = sum(c * padded[:, j : j + n] for j, c in enumerate(_D1) if c) / dt
    d2 = sum(c * padded[:, j : j + n] for j, c in enumerate(_D2)) / dt**2
    return d1, d2


def simulate(plant: RigPlant, drive: np.ndarray, dt: float, *, periodic: bool = False,
             progress: Callable[[str], None] | None = None) -> np.ndarray:  # fmt: skip
    """The plant's outputs (n_out, n) for drives ``drive`` (n_in, n) sampled at ``dt`` (s),
    from rest (or, with ``periodic``, in the steady state of the drive repeated).

    Raises
    ------
    TimeDataError
        For a drive of another channel count, a step that is not positive, or samples
        that are not finite.
    """
    s = np.atleast_2d(np.asarray(drive, float))
    n_in = plant.beta.shape[1]
    if s.shape[0] != n_in:
        raise TimeDataError(f"a drive of {s.shape[0]} channels for a rig of {n_in} actuators "
                            f"({', '.join(plant.inputs)})")  # fmt: skip
    if not (np.isfinite(dt) and dt > 0):
        raise TimeDataError(f"time step {dt}: expected a positive number of seconds")
    if not np.isfinite(s).all():
        raise TimeDataError("the drive holds NaN or infinite samples")
    n = s.shape[1]
    w, z = plant.omega, plant.zeta
    wd = w * np.sqrt(1 - z**2)
    mu = -z * w + 1j * wd
    lam = np.exp(mu * dt)
    g = 1.0 / (2j * wd)
    c0, c1 = _hold_coefficients(mu, dt)
    gamma, feed = g * (lam * c1 + c0), g * c1
    s1, s2 = derivatives(s, dt, periodic)
    k = plant.n_modes
    rate = (2 * z * w)[:, None]

    def modal_input(start: int, stop: int) -> tuple[np.ndarray, np.ndarray]:
        """(raw, held) modal inputs (k, stop - start) of the dynamic remainders: small
        beside the outputs, made block by block (with one sample either side for the
        compensating filter) so that only a block of them is held at a time."""
        idx = np.arange(start - 1, stop + 1)
        idx = idx % n if periodic else np.clip(idx, 0, n - 1)
        p = -(plant.beta @ s2[:, idx] + rate * (plant.beta @ s1[:, idx])) / (w**2)[:, None]
        return p[:, 1:-1], (14 * p[:, 1:-1] - p[:, :-2] - p[:, 2:]) / 12

    state = np.zeros(k, complex)
    if periodic and n:  # each mode's state after a period from rest, then the steady one
        for start in range(0, n, BLOCK):
            _, held = modal_input(start, min(n, start + BLOCK))
            for r in range(k):
                _, zf = ss.lfilter([0, gamma[r]], [1, -lam[r]], held[r], zi=[state[r]])
                state[r] = zf[0]
        state /= 1 - lam**n
    y = plant.D0 @ s + plant.D2 @ s2
    for start in range(0, n, BLOCK):
        stop = min(n, start + BLOCK)
        raw, p = modal_input(start, stop)
        eta = np.empty(p.shape, complex)
        for r in range(k):
            eta[r], zf = ss.lfilter([0, gamma[r]], [1, -lam[r]], p[r], zi=[state[r]])
            state[r] = zf[0]
        eta += feed[:, None] * p
        q = 2 * eta.real
        qd = 2 * (mu[:, None] * eta).real
        qdd = raw - rate * qd - (w**2)[:, None] * q
        y[:, start:stop] += plant.Yd @ q + plant.Ya @ qdd
        if progress is not None:
            progress(Step(f"simulated {stop} of {n} samples", task="simulating", done=stop,
                          total=n))  # fmt: skip
    return y


def periodic_response(plant: RigPlant, drive: np.ndarray, dt: float) -> np.ndarray:
    """The steady-state outputs (n_out, n) of a drive (n_in, n) that repeats every n
    samples, computed harmonic by harmonic with the plant's frequency response: exact for
    the band-limited periodic signal the samples define (each harmonic below the Nyquist
    frequency; an even record's Nyquist line is taken as a cosine).
    """
    s = np.atleast_2d(np.asarray(drive, float))
    n = s.shape[1]
    S = np.fft.rfft(s, axis=1)
    f = np.fft.rfftfreq(n, dt)
    H = plant.frf(f)  # (n_out, n_in, n_f)
    Y = np.einsum("oif,if->of", H, S)
    if n % 2 == 0:
        Y[:, -1] = Y[:, -1].real  # the Nyquist line is a cosine: its real part survives
    return np.fft.irfft(Y, n, axis=1)
