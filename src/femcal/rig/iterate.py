"""Drive iteration, as RPC Pro does it on a physical rig: find the actuator drives that make
the control channels follow a target.

1. The system FRF ``H`` (n_control, n_drives) from the drives to the control channels: from
   a model (:meth:`~femcal.rig.plant.RigPlant.frf`), or measured by playing noise drives on
   the plant and estimating H1 (:func:`measured_frf`).
2. Its regularised inverse at each line, with each control channel scaled by its target's
   RMS first (so that channels in N and in mm/s^2 weigh alike): the SVD ``H = U S V^H``,
   singular values below ``rcond`` times the largest left out, ``H^+ = V S^-1 U^H`` (Golub
   and Van Loan, Matrix Computations, 4th ed., sec. 5.5.4); zero outside the drive band.
3. The first drive ``d_0 = H^+ t`` of the target ``t``, line by line over the whole record's
   spectrum, then ``d_{k+1} = d_k + g H^+ (t - r_k)`` with ``r_k`` the plant's response to
   ``d_k``; the RMS error of each control channel relative to its target's RMS is recorded at
   every iteration.
4. The gain ``g`` is kept line by line: it starts at ``gain`` and halves at a line whose
   error grew in the last step. Where the inverted FRF is far from the plant's (a resonance
   the model puts elsewhere, so the phase is wrong by more than 90 degrees) the plain
   correction diverges at those lines; the halved gain stops it there while the other
   lines converge at the full gain.

The plant that plays the drives may be another model than the one whose FRF is inverted: the
model stands in for the physical rig, as the physical rig stands in for the road. The record
is taken as one period of a periodic target (the drive loops), so the spectra are exact and
the responses steady; :func:`~femcal.rig.simulate.simulate` plays it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from ..errors import TimeDataError
from ..testdata import signal
from .plant import RigPlant
from .simulate import simulate


@dataclass(frozen=True)
class IterationSettings:
    """How the drives are iterated.

    Attributes
    ----------
    iterations : corrections after the first drive.
    gain : of each correction at first, in (0, 1]; halved line by line where the error
        grows.
    rcond : singular values of the FRF below ``rcond`` times the largest are left out of the
        inverse.
    band : (low, high) Hz: the drive band; the inverse is zero outside it.
    """

    iterations: int = 8
    gain: float = 0.5
    rcond: float = 1e-3
    band: tuple[float, float] = (0.5, 40.0)

    def __post_init__(self) -> None:
        """Check every setting (ValueError naming it)."""
        checks = (
            ("iterations", isinstance(self.iterations, int) and self.iterations >= 0,
             "a whole number, 0 or more"),
            ("gain", np.isfinite(self.gain) and 0 < self.gain <= 1, "in (0, 1]"),
            ("rcond", np.isfinite(self.rcond) and 0 <= self.rcond < 1, "in [0, 1)"),
            ("band", len(self.band) == 2 and 0 <= self.band[0] < self.band[1],
             "0 <= F1 < F2 in Hz"),
        )  # fmt: skip
        for name, ok, expected in checks:
            if not ok:
                raise ValueError(f"drive iteration: {name} = {getattr(self, name)!r}: expected "
                                 f"{expected}")  # fmt: skip


@dataclass(frozen=True)
class Iteration:
    """The outcome of a drive iteration.

    Attributes
    ----------
    drive : (n_drives, n) the last drive (the model's length unit).
    response : (n_out, n) every output of the plant to it.
    control : (n_control,) indices of the control channels among the plant's outputs.
    rms_error : (iterations + 1, n_control) RMS of target - response over RMS of target,
        per control channel, after the first drive and after each correction.
    drives : (iterations + 1, n_drives) RMS of each drive after each step.
    """

    drive: np.ndarray
    response: np.ndarray
    control: tuple[int, ...]
    rms_error: np.ndarray
    drives: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))


def regularised_inverse(H: np.ndarray, rcond: float) -> np.ndarray:
    """H^+ (n_in, n_out, n_f) of H (n_out, n_in, n_f) by truncated SVD at each line."""
    Hf = np.moveaxis(H, 2, 0)  # (n_f, n_out, n_in)
    U, s, Vh = np.linalg.svd(Hf, full_matrices=False)
    top = s[:, :1]
    with np.errstate(divide="ignore", invalid="ignore"):
        inv_s = np.where((s > rcond * top) & (s > 0), 1.0 / s, 0.0)
    Hinv = np.einsum("fji,fj,fkj->fik", Vh.conj(), inv_s, U.conj())  # V S^-1 U^H
    return np.moveaxis(Hinv, 0, 2)


def frf_on_lines(plant: RigPlant, control: Sequence[int], n: int, dt: float,
                 band: tuple[float, float]) -> np.ndarray:  # fmt: skip
    """The model FRF (n_control, n_drives, n // 2 + 1) from the drives to the control
    channels at the record's lines, zero outside ``band``."""
    f = np.fft.rfftfreq(n, dt)
    H = np.zeros((len(control), plant.beta.shape[1], len(f)), complex)
    lines = (f >= band[0]) & (f <= band[1]) & (f > 0)
    H[:, :, lines] = plant.frf(f[lines])[list(control)]
    return H


def measured_frf(plant: RigPlant, control: Sequence[int], n: int, dt: float,
                 band: tuple[float, float], *, seconds: float = 240.0, segment_s: float = 8.0,
                 rms: float = 0.2, seed: int = 0) -> np.ndarray:  # fmt: skip
    """The FRF (n_control, n_drives, n // 2 + 1) as the rig measures it: independent random
    noise drives (band-limited, ``rms`` each) played on ``plant`` for ``seconds``, H1 by
    Welch over segments of ``segment_s``, interpolated (real and imaginary parts) to the
    record's lines; zero outside ``band``."""
    rng = np.random.default_rng(seed)
    m = round(seconds / dt)
    n_in = plant.beta.shape[1]
    f_m = np.fft.rfftfreq(m, dt)
    S = np.zeros((n_in, len(f_m)), complex)
    lines = (f_m >= band[0]) & (f_m <= band[1])
    S[:, lines] = (rng.standard_normal((n_in, int(lines.sum())))
                   + 1j * rng.standard_normal((n_in, int(lines.sum()))))  # fmt: skip
    noise = np.fft.irfft(S, m, axis=1)
    noise *= rms / np.sqrt(np.mean(noise**2, axis=1, keepdims=True))
    response = simulate(plant, noise, dt, periodic=True)[list(control)]
    est = signal.frf(noise, response, dt, round(segment_s / dt))
    good = np.isfinite(est.H).all(axis=(0, 1))
    return frf_to_lines(est.frequency_hz[good], est.H[:, :, good], n, dt, band)


def frf_to_lines(frequency_hz: np.ndarray, H: np.ndarray, n: int, dt: float,
                 band: tuple[float, float]) -> np.ndarray:  # fmt: skip
    """An FRF known at ``frequency_hz`` (H: (n_out, n_in, n_f)) on the lines of a record of
    ``n`` samples every ``dt``, interpolated linearly in its real and imaginary parts (held
    within one step beyond its ends); zero outside ``band``.

    Raises
    ------
    TimeDataError
        For a band the FRF does not cover.
    """
    f = np.fft.rfftfreq(n, dt)
    keep = (f >= band[0]) & (f <= band[1]) & (f > 0)
    step = float(np.median(np.diff(frequency_hz))) if len(frequency_hz) > 1 else 0.0
    lo, hi = frequency_hz[0] - step - 1e-9, frequency_hz[-1] + step + 1e-9
    if keep.any() and (f[keep][0] < lo or f[keep][-1] > hi):
        raise TimeDataError(f"an FRF over {frequency_hz[0]:g}-{frequency_hz[-1]:g} Hz for a "
                            f"drive band of {band[0]:g}-{band[1]:g} Hz; expected one that "
                            "covers the band")  # fmt: skip
    out = np.zeros((H.shape[0], H.shape[1], len(f)), complex)
    for o in range(H.shape[0]):
        for i in range(H.shape[1]):
            out[o, i, keep] = (np.interp(f[keep], frequency_hz, H[o, i].real)
                               + 1j * np.interp(f[keep], frequency_hz, H[o, i].imag))  # fmt: skip
    return out


def _check(H: np.ndarray, target: np.ndarray, n_control: int, n_drives: int) -> np.ndarray:
    """The target as a float array, once it fits the control channels and the FRF."""
    target = np.atleast_2d(np.asarray(target, float))
    n = target.shape[1]
    if target.shape[0] != n_control:
        raise TimeDataError(f"a target of {target.shape[0]} channels for {n_control} "
                            "control channels; expected one target per control channel")
    if not np.isfinite(target).all():
        raise TimeDataError("the target holds NaN or infinite samples")
    if H.shape != (n_control, n_drives, n // 2 + 1):
        raise TimeDataError(f"an FRF of shape {H.shape}; expected (control channels, drives, "
                            f"lines) = ({n_control}, {n_drives}, {n // 2 + 1})")
    return target


def target_inverse(H: np.ndarray, target: np.ndarray, rcond: float) -> tuple[np.ndarray,
                                                                            np.ndarray]:
    """(H^+ (n_drives, n_control, n_f), the target's RMS per channel (n_control,)): the
    inverse with each control channel in units of its target's RMS, so that the SVD's
    threshold does not depend on the channels' units (a force in N beside an acceleration
    in mm/s^2)."""
    size = np.sqrt(np.mean(target**2, axis=1))
    size = np.where(size > 0, size, 1.0)
    return regularised_inverse(H / size[:, None, None], rcond) / size[None, :, None], size


def correct_drive(H: np.ndarray, target: np.ndarray, rcond: float,
                  drive: np.ndarray | None = None, response: np.ndarray | None = None,
                  gain: float = 1.0) -> np.ndarray:  # fmt: skip
    """One step of the iteration for a rig femcal does not play (the drive/response
    exchange of a physical rig): the first drive ``H^+ t`` when ``drive`` is None, else
    ``drive + gain H^+ (t - response)`` with ``response`` (n_control, n) the control
    channels measured when ``drive`` (n_drives, n) was played.

    Raises
    ------
    TimeDataError
        As :func:`iterate_drive`, or a drive or response of another shape.
    """
    target = _check(H, target, H.shape[0], H.shape[1])
    n = target.shape[1]
    Hinv, _ = target_inverse(H, target, rcond)
    if drive is None:
        return np.fft.irfft(np.einsum("iof,of->if", Hinv, np.fft.rfft(target, axis=1)), n,
                            axis=1)  # fmt: skip
    if response is None or drive.shape != (H.shape[1], n) or response.shape != target.shape:
        raise TimeDataError(f"a drive of shape {np.shape(drive)} and a response of shape "
                            f"{np.shape(response)}; expected ({H.shape[1]}, {n}) and "
                            f"{target.shape}: the drive played and the control channels "
                            "measured, as long as the target")  # fmt: skip
    E = np.fft.rfft(target - response, axis=1)
    return drive + gain * np.fft.irfft(np.einsum("iof,of->if", Hinv, E), n, axis=1)


def iterate_drive(plant: RigPlant, H: np.ndarray, target: np.ndarray, control: Sequence[int],
                  dt: float, settings: IterationSettings | None = None, *,
                  progress: Callable[[str], None] | None = None) -> Iteration:  # fmt: skip
    """Iterate drives on ``plant`` so that its outputs ``control`` follow ``target``
    (n_control, n) sampled at ``dt``, inverting ``H`` (n_control, n_drives, n // 2 + 1; see
    :func:`frf_on_lines`, :func:`measured_frf`) as the module docstring says.

    Raises
    ------
    TimeDataError
        For a target of another channel count than the control channels, non-finite
        samples, or an FRF not on the target's lines.
    """
    s = settings or IterationSettings()
    target = _check(H, target, len(control), plant.beta.shape[1])
    n = target.shape[1]
    Hinv, size = target_inverse(H, target, s.rcond)
    T = np.fft.rfft(target, axis=1)
    D = np.einsum("iof,of->if", Hinv, T)  # the drive's spectrum
    gain = np.full(T.shape[1], s.gain)
    before = None
    errors, drives = [], []
    for k in range(s.iterations + 1):
        drive = np.fft.irfft(D, n, axis=1)
        response = simulate(plant, drive, dt, periodic=True)
        error = target - response[list(control)]
        errors.append(np.sqrt(np.mean(error**2, axis=1)) / size)
        drives.append(np.sqrt(np.mean(drive**2, axis=1)))
        if progress is not None:
            progress(f"iteration {k}: RMS error {100 * errors[-1].max():.2f} % at worst, "
                     f"{100 * np.median(errors[-1]):.2f} % median")  # fmt: skip
        if k == s.iterations:
            break
        E = np.fft.rfft(error, axis=1)
        now = np.linalg.norm(E / size[:, None], axis=0)
        if before is not None:
            gain = np.where(now > before, gain / 2, gain)
        before = now
        D = D + gain * np.einsum("iof,of->if", Hinv, E)
    return Iteration(drive, response, tuple(control), np.array(errors), np.array(drives))
