"""Drive iteration, as RPC Pro does it on a physical rig: find the actuator drives that make
the control channels follow a target.

1. The system FRF ``H`` (n_control, n_drives) from the drives to the control channels: from
   a model (:meth:`~femcal.rig.plant.RigPlant.frf`), or measured by playing noise drives on
   the plant and estimating H1 (:func:`measured_frf`).
2. The target as iterated: the record is taken as one period of a looped drive when its
   ends join (:func:`ends_join`); a record whose ends do not join (a slice of a road
   measurement) is faded in and out over a taper, so that the drive starts and ends at rest
   and the wrap-around makes no step that only a huge low-frequency drive could follow.
3. The regularised inverse at each line of the record's spectrum (:mod:`femcal.rig.inverse`):
   the target's noise floor, the drive power its lines show, each control channel's weight;
   zero outside the drive band.
4. The first drive is the inverse times the target. Each correction then takes a
   Gauss-Newton step on each line's objective (the weighted error plus the drive penalty,
   :func:`femcal.rig.inverse.objective`)::

       D <- D + g A^-1 (H^H W (T - R) - diag(pen) D),

   so that the corrections keep the regularisation (a plain ``D + g H^+ (T - R)`` would
   converge to the unregularised drive and amplify the noise again). Each line's
   response depends on its own drive only (the drive loops, the plant is linear), so the
   step is taken line by line from the best drive found so far, and the gain ``g`` is kept
   line by line: it starts at ``gain`` and halves at a line whose objective did not fall
   in the last step (there the inverted FRF is far from the plant's), which goes back to
   its best. The drive written is, at each line, the best one played.
   A rig with more actuators than rigid-body motions has drive combinations that only
   deform the frame (:mod:`femcal.rig.kinematics`; a 7-post rig's warp): they are driven
   where the control channels see them and held where they do not, or, with
   ``warp="minimal"``, held at their least everywhere.
5. With ``update_frf`` the FRF is updated after each step from the drive and response pairs
   (:mod:`femcal.rig.update`), as RPC Pro updates its system model.
6. Convergence is judged in the drive band (:mod:`femcal.rig.quality`): outside it the rig
   is not driven and the error is the target's noise floor; each control channel's last
   state is explained (:func:`explain`).

The plant that plays the drives may be another model than the one whose FRF is inverted: the
model stands in for the physical rig, as the physical rig stands in for the road. Each
drive loops (:func:`~femcal.rig.simulate.simulate` plays it periodically), so the spectra are
exact and the responses steady.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.signal as ss

from ..errors import TimeDataError
from ..testdata import signal
from . import inverse
from .inverse import NoiseFloor, UnseenBand
from .kinematics import redundant_drives
from .plant import RigPlant
from .quality import BandErrors, band_errors
from .simulate import simulate
from .update import broyden_update

#: How many times the record's largest run of prediction errors the wrap-around's must be
#: for a record's ends not to join (:func:`ends_join`).
JOIN_RATIO = 2.0
#: Most samples the predictor of :func:`ends_join` is fitted on.
JOIN_FIT = 65536
#: Relative fall of the in-band error in the last step below which a channel has stalled.
STALL = 0.05


@dataclass(frozen=True)
class IterationSettings:
    """How the drives are iterated.

    Attributes
    ----------
    iterations : corrections after the first drive.
    gain : of each correction at first, in (0, 1]; halved line by line where the objective
        grows.
    band : (low, high) Hz: the drive band; the drive is zero outside it.
    noise_floor : the target's noise as a fraction of each channel's RMS (white); None:
        measured on the target above the drive band (:func:`femcal.rig.inverse.noise_floor`).
    effort : drive-effort penalty relative to the best-seen direction (0: none).
    roll_off_hz : the drive rolls off below this frequency (0: no roll-off).
    update_frf : update the FRF from each step's drive and response.
    taper_s : fade-in and fade-out of a target whose ends do not join (s); None: one period
        of the band's low edge, at most a tenth of the record, and only when the ends do not
        join; 0: never (the target is taken as one period).
    warp : "free": the redundant actuators' combinations (:mod:`femcal.rig.kinematics`,
        the warp) are driven as the control channels ask where they see them, held where
        they do not; "minimal": held at their least everywhere (the minimal-warp drive).
    """

    iterations: int = 8
    gain: float = 0.5
    band: tuple[float, float] = (0.5, 40.0)
    noise_floor: float | None = None
    effort: float = 0.0
    roll_off_hz: float = 0.0
    update_frf: bool = True
    taper_s: float | None = None
    warp: str = "free"

    def __post_init__(self) -> None:
        """Check every setting (ValueError naming it)."""
        checks = (
            ("iterations", isinstance(self.iterations, int) and self.iterations >= 0,
             "a whole number, 0 or more"),
            ("gain", np.isfinite(self.gain) and 0 < self.gain <= 1, "in (0, 1]"),
            ("band", len(self.band) == 2 and 0 <= self.band[0] < self.band[1],
             "0 <= F1 < F2 in Hz"),
            ("noise_floor", self.noise_floor is None
             or (np.isfinite(self.noise_floor) and 0 < self.noise_floor < 1),
             "a fraction in (0, 1) of each channel's RMS, or measured (None)"),
            ("effort", np.isfinite(self.effort) and self.effort >= 0, "0 or more"),
            ("roll_off_hz", np.isfinite(self.roll_off_hz) and self.roll_off_hz >= 0,
             "0 Hz (none) or more"),
            ("taper_s", self.taper_s is None
             or (np.isfinite(self.taper_s) and self.taper_s >= 0),
             "0 s (none) or more, or None (when the ends do not join)"),
            ("warp", self.warp in ("free", "minimal"), "free or minimal"),
        )  # fmt: skip
        for name, ok, expected in checks:
            if not ok:
                raise ValueError(f"drive iteration: {name} = {getattr(self, name)!r}: expected "
                                 f"{expected}")  # fmt: skip


def ends_join(target: np.ndarray, order: int = 16, across: int = 8) -> tuple[bool, float]:
    """(whether the record's ends join, the statistic). Each channel is fitted with a linear
    predictor of ``order`` past samples (least squares over the record, at most
    :data:`JOIN_FIT` samples of it). The squared prediction errors of the ``across``
    samples after the wrap-around (the record taken as periodic), each over the fit's
    residual variance and summed over the channels, are compared with the same sum over
    every run of ``across`` samples in the record: for one period of a looped signal the
    wrap-around is one more such run; a slice of a longer record makes a jump there that no
    predictor of a band-limited signal foresees. The statistic is the wrap-around's sum over
    the largest of the record's; the ends join when it is at most :data:`JOIN_RATIO`."""
    n = target.shape[1]
    if n < 4 * (order + across):
        return True, 0.0
    m = min(n, JOIN_FIT)
    inside = np.zeros(m - order - across + 1)
    wrap = 0.0
    for x in target:
        scale = np.std(x)
        if not scale > 0:
            continue
        x = (x - np.mean(x)) / scale
        rows = np.lib.stride_tricks.sliding_window_view(x[:m], order + 1)
        coef, *_ = np.linalg.lstsq(rows[:, :order], rows[:, order], rcond=None)
        resid = rows[:, order] - rows[:, :order] @ coef
        var = max(float(np.mean(resid**2)), 1e-30)
        runs = np.convolve(resid**2, np.ones(across), mode="valid") / var
        inside += runs[: len(inside)]
        win = np.lib.stride_tricks.sliding_window_view(
            np.concatenate([x[n - order :], x[:across]]), order + 1)
        wrap += float(np.sum((win[:, order] - win[:, :order] @ coef) ** 2) / var)
    top = float(inside.max()) if inside.size else 0.0
    stat = wrap / top if top > 0 else 0.0
    return stat <= JOIN_RATIO, stat


def taper_window(n: int, m: int) -> np.ndarray:
    """(n,) ones with half-cosine ramps of m samples at both ends (a Tukey window)."""
    w = np.ones(n)
    m = min(m, n // 2)
    if m > 0:
        ramp = 0.5 - 0.5 * np.cos(np.pi * (np.arange(m) + 0.5) / m)
        w[:m] = ramp
        w[n - m :] = ramp[::-1]
    return w


@dataclass(frozen=True)
class Prepared:
    """A target and an FRF made ready for the regularised inverse.

    Attributes
    ----------
    target : (n_control, n) the target as iterated (faded in and out when tapered).
    taper_s : the taper applied (0: none); ends_statistic : :func:`ends_join`'s statistic.
    frequency_hz : (n_lines,) the drive band's lines; lines : (n // 2 + 1,) their mask.
    T : (n_control, n_lines) the target's spectrum there.
    noise : its noise floor; weight : (n_control,) ``w_c / nu_c``; channel_weight : w_c.
    prior : (n_drives, n_lines) the drive power the target shows; pen : the penalty.
    Hf : (n_lines, n_control, n_drives) the FRF on the lines.
    redundant : (n_drives, k) the rig's redundant drive combinations (k = 0: none known).
    held : (n_lines, k, n_drives) the factor of the penalty holding them
        (``warp="minimal"``), or None.
    """

    target: np.ndarray
    taper_s: float
    ends_statistic: float
    frequency_hz: np.ndarray
    lines: np.ndarray
    T: np.ndarray
    noise: NoiseFloor
    weight: np.ndarray
    channel_weight: np.ndarray
    prior: np.ndarray
    pen: np.ndarray
    Hf: np.ndarray
    redundant: np.ndarray
    held: np.ndarray | None


def prepare(H: np.ndarray, target: np.ndarray, dt: float, settings: IterationSettings,
            weights: Sequence[float] | None = None,
            redundant: np.ndarray | None = None) -> Prepared:  # fmt: skip
    """The target (tapered when its ends do not join, as ``settings.taper_s`` says), its
    noise floor and drive prior, and the penalty, for the FRF ``H`` (n_control, n_drives,
    n // 2 + 1); ``redundant`` (n_drives, k): the rig's redundant drive combinations.

    Raises
    ------
    TimeDataError
        For weights that are not one positive number per control channel, or a minimal
        warp asked for without the redundant combinations.
    """
    s = settings
    n = target.shape[1]
    joined, stat = ends_join(target)
    taper = 0.0
    if s.taper_s is None:
        if not joined:
            taper = min(1.0 / max(s.band[0], 1e-3), 0.1 * n * dt)
    else:
        taper = float(s.taper_s)
    if taper > 0:  # about each channel's mean, so that an offset makes no ramps
        mean = target.mean(axis=1, keepdims=True)
        target = mean + (target - mean) * taper_window(n, round(taper / dt))
    w = np.ones(len(target)) if weights is None else np.asarray(weights, float)
    if w.shape != (len(target),) or not (np.isfinite(w).all() and (w > 0).all()):
        raise TimeDataError(f"channel weights {list(np.atleast_1d(w))}: expected one positive "
                            f"number per control channel ({len(target)})")  # fmt: skip
    f = np.fft.rfftfreq(n, dt)
    if s.band[1] >= 0.5 / dt:
        raise TimeDataError(f"the drive band {s.band[0]:g}-{s.band[1]:g} Hz reaches the "
                            f"target's Nyquist frequency {0.5 / dt:g} Hz; expected a band "
                            "below it")  # fmt: skip
    lines = (f >= s.band[0]) & (f <= s.band[1]) & (f > 0)
    if lines.sum() < 2:
        raise TimeDataError(f"the drive band {s.band[0]:g}-{s.band[1]:g} Hz holds "
                            f"{int(lines.sum())} line(s) of the record's spectrum (one every "
                            f"{f[1] if len(f) > 1 else 0:g} Hz up to {f[-1]:g} Hz); expected a "
                            "wider band or a longer record")  # fmt: skip
    T_all = np.fft.rfft(target, axis=1)
    size = np.std(target, axis=1)  # about the mean: an offset is no signal to reproduce
    noise = inverse.noise_floor(T_all, f, s.band, n, size, s.noise_floor)
    Hf = np.ascontiguousarray(np.moveaxis(H[:, :, lines], 2, 0))
    T = T_all[:, lines]
    fl = f[lines]
    noise = inverse.bounded_floor(noise, Hf, T)
    weight = w / noise.variance
    prior = inverse.drive_prior(Hf, T, weight, fl)
    pen = inverse.penalty(Hf, weight, prior, fl, effort=s.effort, roll_off_hz=s.roll_off_hz)
    red = np.zeros((H.shape[1], 0)) if redundant is None else np.asarray(redundant, float)
    held = None
    if s.warp == "minimal":
        if red.shape[1] == 0:
            raise TimeDataError("a minimal warp needs the rig's redundant actuator "
                                "combinations (the actuators' positions and directions); "
                                "this rig has none, or they are not known")  # fmt: skip
        held = inverse.held_factor(Hf, weight, red)
    return Prepared(target, taper, stat, fl, lines, T, noise, weight, w, prior, pen, Hf, red,
                    held)  # fmt: skip


@dataclass(frozen=True)
class Iteration:
    """The outcome of a drive iteration.

    Attributes
    ----------
    drive : (n_drives, n) the last drive (the model's length unit).
    response : (n_out, n) every output of the plant to it.
    control : (n_control,) indices of the control channels among the plant's outputs.
    rms_error : (iterations + 1, n_control) in the drive band, the RMS of target - response
        over the target's, per control channel, after the first drive and each correction.
    drives : (iterations + 1, n_drives) RMS of each drive after each step.
    out_of_band : (iterations + 1, n_control) outside the band, RMS of target - response
        over the target's whole RMS.
    drive_psd : (iterations + 1, n_drives, n_psd) each step's drive PSD (Welch, Hann);
        psd_hz : (n_psd,) its frequencies.
    target : (n_control, n) the target as iterated (tapered when it was).
    taper_s : the taper applied (0: none).
    noise : the target's noise floor; weights : (n_control,) the channels' weights.
    unseen : bands where drive directions are not seen above the noise (held).
    frf_updates : (iterations,) lines of the FRF updated after each step.
    halved : (n_lines,) lines of the band where the gain was halved at least once;
        frequency_hz : (n_lines,) the band's lines.
    status : (n_control,) each control channel's last state, in words (:func:`explain`).
    redundant : (n_drives, k) the rig's redundant drive combinations (the warp);
        redundant_unseen : for each, the bands (low, high Hz) where the control channels do
        not see it above the noise.
    first_drive : (n_drives, n) the first drive (the inverse times the target).
    """

    drive: np.ndarray
    response: np.ndarray
    control: tuple[int, ...]
    rms_error: np.ndarray
    drives: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    out_of_band: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    drive_psd: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 0)))
    psd_hz: np.ndarray = field(default_factory=lambda: np.zeros(0))
    target: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    taper_s: float = 0.0
    noise: NoiseFloor | None = None
    weights: np.ndarray = field(default_factory=lambda: np.zeros(0))
    unseen: tuple[UnseenBand, ...] = ()
    frf_updates: tuple[int, ...] = ()
    halved: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    frequency_hz: np.ndarray = field(default_factory=lambda: np.zeros(0))
    status: tuple[str, ...] = ()
    redundant: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    redundant_unseen: tuple[tuple[tuple[float, float], ...], ...] = ()
    first_drive: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))


def redundant_unseen(p: Prepared, Hf: np.ndarray) -> tuple[tuple[tuple[float, float], ...],
                                                           ...]:  # fmt: skip
    """For each redundant drive combination, the bands where the control channels do not
    see it above the noise (:func:`femcal.rig.inverse.direction_seen` below one)."""
    out = []
    f = p.frequency_hz
    for k in range(p.redundant.shape[1]):
        seen = inverse.direction_seen(Hf, p.weight, p.pen, p.redundant[:, k])
        out.append(tuple((float(f[a]), float(f[b - 1])) for a, b in inverse.runs(seen < 1)))
    return tuple(out)


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
    lines = (f_m >= band[0]) & (f_m <= band[1]) & (f_m > 0)
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
    if target.size and not np.any(target - target.mean(axis=1, keepdims=True)):
        raise TimeDataError("the target is constant on every control channel: nothing for a "
                            "drive to reproduce; expected a target that moves on at least "
                            "one")  # fmt: skip
    return target


def _on_lines(x: np.ndarray, p: Prepared) -> np.ndarray:
    """The spectrum of a record (rows, n) on the band's lines (rows, n_lines)."""
    return np.fft.rfft(x, axis=1)[:, p.lines]


def _to_time(D: np.ndarray, p: Prepared, n: int) -> np.ndarray:
    """The drive (n_drives, n) of a spectrum on the band's lines (zero elsewhere)."""
    full = np.zeros((D.shape[0], n // 2 + 1), complex)
    full[:, p.lines] = D
    return np.fft.irfft(full, n, axis=1)


def _solver(p: Prepared, Hf: np.ndarray) -> inverse.LineSolver:
    return inverse.LineSolver(Hf, p.weight, p.pen, p.held)


def _update(p: Prepared, Hf: np.ndarray, pairs: list[tuple[np.ndarray, np.ndarray]]
            ) -> tuple[np.ndarray, int]:  # fmt: skip
    """The FRF after Broyden's update with the last of ``pairs`` (drive, response on the
    lines) against the one before it (or the rig at rest), and the lines updated."""
    D, R = pairs[-1]
    if len(pairs) > 1:
        D, R = D - pairs[-2][0], R - pairs[-2][1]
    Hf, ok = broyden_update(Hf, D, R, p.weight)
    return Hf, int(ok.sum())


def _psd(x: np.ndarray, dt: float, segment_s: float = 4.0) -> tuple[np.ndarray, np.ndarray]:
    """Welch PSDs (rows, n_f) of each row of x, Hann segments of ``segment_s``."""
    m = min(x.shape[1], max(8, round(segment_s / dt)))
    f, P = ss.welch(x, fs=1.0 / dt, nperseg=m, axis=1)
    return f, P


class _Best:
    """At each line, the drive with the lowest objective so far and its error."""

    def __init__(self, D: np.ndarray) -> None:
        self.D = D.copy()
        self.E: np.ndarray | None = None
        self.J = np.full(D.shape[1], np.inf)

    def keep(self, D: np.ndarray, E: np.ndarray, J: np.ndarray) -> np.ndarray:
        """Take the lines where ``J`` is lower; returns the mask of the others."""
        better = J < self.J
        if self.E is None:
            self.E = E.copy()
        self.D[:, better] = D[:, better]
        self.E[:, better] = E[:, better]
        self.J[better] = J[better]
        return ~better


def iterate_drive(plant: RigPlant, H: np.ndarray, target: np.ndarray, control: Sequence[int],
                  dt: float, settings: IterationSettings | None = None, *,
                  weights: Sequence[float] | None = None,
                  progress: Callable[[str], None] | None = None) -> Iteration:  # fmt: skip
    """Iterate drives on ``plant`` so that its outputs ``control`` follow ``target``
    (n_control, n) sampled at ``dt``, inverting ``H`` (n_control, n_drives, n // 2 + 1; see
    :func:`frf_on_lines`, :func:`measured_frf`) as the module docstring says; ``weights``
    (n_control,) weigh the control channels (default 1 each).

    Raises
    ------
    TimeDataError
        For a target of another channel count than the control channels, non-finite
        samples, an FRF not on the target's lines, or weights that are not one positive
        number per control channel.
    """
    s = settings or IterationSettings()
    target = _check(H, target, len(control), plant.beta.shape[1])
    n = target.shape[1]
    red = redundant_drives(plant) if plant.actuators else None
    p = prepare(H, target, dt, s, weights, red)
    Hf = p.Hf
    solver = _solver(p, Hf)
    D = solver.step(p.T, np.zeros((Hf.shape[2], len(p.frequency_hz)), complex))
    gain = np.full(len(p.frequency_hz), s.gain)
    halved = np.zeros(len(p.frequency_hz), bool)
    best = _Best(D)
    errors, outside, drives, psds, updates = [], [], [], [], []
    pairs: list[tuple[np.ndarray, np.ndarray]] = []
    control = list(control)

    def play(D: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Play a drive spectrum; record its errors as step ``k`` (replacing the last
        row when ``k`` is already recorded)."""
        drive = _to_time(D, p, n)
        response = simulate(plant, drive, dt, periodic=True)
        err: BandErrors = band_errors(p.target, response[control], dt, s.band)
        row = (err.in_band, err.out_of_band, np.sqrt(np.mean(drive**2, axis=1)),
               _psd(drive, dt)[1])  # fmt: skip
        for history, value in zip((errors, outside, drives, psds), row, strict=True):
            if k < len(history):
                history[k] = value
            else:
                history.append(value)
        if progress is not None and np.isfinite(err.in_band).any():
            e = err.in_band[np.isfinite(err.in_band)]
            progress(f"iteration {k}: in-band RMS error {100 * e.max():.2f} % at worst, "
                     f"{100 * np.median(e):.2f} % median")  # fmt: skip
        return drive, response

    for k in range(s.iterations + 1):
        drive, response = play(D, k)
        if k == 0:
            first = drive
        R = _on_lines(response[control], p)
        E = p.T - R
        worse = best.keep(D, E, inverse.objective(p.weight, p.pen, E, D, p.held))
        if k == s.iterations:
            break
        if k > 0:  # a line whose objective did not fall: back to its best, half the gain
            gain = np.where(worse, gain / 2, gain)
            halved |= worse
        if s.update_frf:
            pairs.append((D.copy(), R))
            Hf, changed = _update(p, Hf, pairs)
            updates.append(changed)
            if changed:
                solver = _solver(p, Hf)
        D = best.D + gain * solver.step(best.E, best.D)
    if not np.array_equal(best.D, D):  # some lines' best came earlier: write that drive
        drive, response = play(best.D, s.iterations)
    unseen = inverse.unseen_directions(Hf, p.weight, p.pen, p.frequency_hz)
    held = inverse.unseen_count(Hf, p.weight, p.pen) > 0
    result = Iteration(drive, response, tuple(control), np.array(errors), np.array(drives),
                       np.array(outside), np.array(psds), _psd(drive[:1], dt)[0], p.target,
                       p.taper_s,
                       p.noise, p.channel_weight, tuple(unseen), tuple(updates), halved,
                       p.frequency_hz)  # fmt: skip
    status = explain(result, p, held)
    return Iteration(**{**result.__dict__, "status": status, "redundant": p.redundant,
                        "redundant_unseen": redundant_unseen(p, Hf), "first_drive": first})


def explain(result: Iteration, p: Prepared, held: np.ndarray) -> tuple[str, ...]:
    """Each control channel's last state in words: converged (to the noise floor, or to
    round-off), still falling, or stalled and why: most of its remaining error at lines
    where the drive is held (not seen above the noise), or where the gain was halved (the
    FRF far from the plant's), or neither (the FRF differs from the plant's everywhere)."""
    errors = result.rms_error
    last = errors[-1]
    E = p.T - _on_lines(result.response[list(result.control)], p)
    band_power = np.sum(np.abs(p.T) ** 2, axis=1)
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        floor = np.where(band_power > 0, np.sqrt(p.noise.variance * len(p.frequency_hz)
                                                 / np.where(band_power > 0, band_power, 1.0)),
                         np.nan)  # fmt: skip
    out = []
    for c in range(len(last)):
        e = last[c]
        share = np.abs(E[c]) ** 2
        total = share.sum()
        if not np.isfinite(e):
            rms = np.sqrt(np.mean(result.response[result.control[c]] ** 2))
            out.append(f"held at zero: its target has no power in the band; the response's "
                       f"RMS is {rms:.3g}")  # fmt: skip
            continue

        def part(mask: np.ndarray, share: np.ndarray = share, total: float = total) -> float:
            return float(share[mask].sum() / total) if total > 0 else 0.0

        def where(mask: np.ndarray) -> str:
            f = p.frequency_hz[mask]
            return f"{f.min():.3g}-{f.max():.3g} Hz" if f.size else "-"

        if e <= 1.5 * floor[c] or e < 1e-4:
            out.append(f"converged: {100 * e:.3g} % in band, within the target's noise there "
                       f"({100 * floor[c]:.2g} %)" if e > 1e-4 else
                       f"converged: {100 * e:.2g} % in band")  # fmt: skip
            continue
        fall = 1 - e / errors[-2, c] if len(errors) > 1 and errors[-2, c] > 0 else 0.0
        if fall > STALL:
            out.append(f"still falling: {100 * errors[-2, c]:.3g} -> {100 * e:.3g} % in band "
                       "in the last step; more iterations would lower it")  # fmt: skip
            continue
        h, g = part(held), part(result.halved & ~held)
        if h >= 0.5:
            out.append(f"stalled at {100 * e:.3g} % in band: {100 * h:.0f} % of the error lies "
                       f"where the drive is held ({where(held)}): the control channels do not "
                       "see the drive there above the target's noise")  # fmt: skip
        elif g >= 0.5:
            out.append(f"stalled at {100 * e:.3g} % in band: {100 * g:.0f} % of the error lies "
                       f"where the gain was halved ({where(result.halved & ~held)}): the FRF "
                       "inverted is far from the plant's there; a measured FRF or more "
                       "iterations with the FRF update would help")  # fmt: skip
        elif p.held is not None:
            out.append(f"stalled at {100 * e:.3g} % in band: the warp is held at its least "
                       "everywhere (--warp minimal) where the target asks for some of it")
        else:
            out.append(f"stalled at {100 * e:.3g} % in band: the FRF inverted differs from the "
                       "plant's across the band; a measured FRF or the FRF update would "
                       "help")  # fmt: skip
    return tuple(out)


@dataclass(frozen=True)
class Correction:
    """One step of the iteration for a physical rig.

    Attributes
    ----------
    drive : (n_drives, n) the next drive.
    prepared : the target, noise floor and inverse it used.
    unseen : bands where drive directions are not seen above the noise (held).
    frf_updates : lines of the FRF updated from each drive and response pair given.
    error : BandErrors of the last response given (None for the first drive).
    redundant_unseen : as :attr:`Iteration.redundant_unseen`.
    """

    drive: np.ndarray
    prepared: Prepared
    unseen: tuple[UnseenBand, ...]
    frf_updates: tuple[int, ...]
    error: BandErrors | None
    redundant_unseen: tuple[tuple[tuple[float, float], ...], ...] = ()


def correct_drive(H: np.ndarray, target: np.ndarray, dt: float,
                  settings: IterationSettings | None = None, *,
                  drives: Sequence[np.ndarray] = (), responses: Sequence[np.ndarray] = (),
                  weights: Sequence[float] | None = None,
                  redundant: np.ndarray | None = None) -> Correction:  # fmt: skip
    """One step of the iteration for a rig femcal does not play (the drive/response
    exchange of a physical rig): the first drive when no drive was played, else the next
    one from ``drives`` (each (n_drives, n), played in order) whose control channels
    measured ``responses`` (each as the target): at each line a step from the pair with the
    lowest objective (at half the gain where the last pair did not lower it), the FRF
    updated with every pair in order when ``settings.update_frf``; ``redundant`` (n_drives,
    k) the rig's redundant drive combinations (:func:`femcal.rig.kinematics.
    redundant_drives`).

    Raises
    ------
    TimeDataError
        As :func:`iterate_drive`, or drives and responses of other shapes or counts.
    """
    s = settings or IterationSettings()
    target = _check(H, target, H.shape[0], H.shape[1])
    n = target.shape[1]
    if len(drives) != len(responses):
        raise TimeDataError(f"{len(drives)} drives and {len(responses)} responses; expected a "
                            "response measured for each drive played")  # fmt: skip
    for k, (d, r) in enumerate(zip(drives, responses, strict=True)):
        if np.shape(d) != (H.shape[1], n) or np.shape(r) != target.shape:
            raise TimeDataError(f"drive {k + 1}: shape {np.shape(d)}, its response "
                                f"{np.shape(r)}; expected ({H.shape[1]}, {n}) and "
                                f"{target.shape}: the drive played and the control channels "
                                "measured, as long as the target")  # fmt: skip
    p = prepare(H, target, dt, s, weights, redundant)
    Hf = p.Hf
    pairs: list[tuple[np.ndarray, np.ndarray]] = []
    updates = []
    for d, r in zip(drives, responses, strict=True):
        pairs.append((_on_lines(np.asarray(d, float), p), _on_lines(np.asarray(r, float), p)))
        if s.update_frf:
            Hf, changed = _update(p, Hf, pairs)
            updates.append(changed)
    solver = _solver(p, Hf)
    if not pairs:
        D = solver.step(p.T, np.zeros((H.shape[1], len(p.frequency_hz)), complex))
        error = None
    else:
        best = _Best(pairs[0][0])
        for D_k, R_k in pairs:
            E_k = p.T - R_k
            worse = best.keep(D_k, E_k, inverse.objective(p.weight, p.pen, E_k, D_k, p.held))
        # from the best pair at each line; half the gain where the last did not improve it
        gain = np.where(worse & (len(pairs) > 1), s.gain / 2, s.gain)
        D = best.D + gain * solver.step(best.E, best.D)
        error = band_errors(p.target, np.asarray(responses[-1], float), dt, s.band)
    unseen = inverse.unseen_directions(Hf, p.weight, p.pen, p.frequency_hz)
    return Correction(_to_time(D, p, n), p, tuple(unseen), tuple(updates), error,
                      redundant_unseen(p, Hf))
