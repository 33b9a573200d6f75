"""From time histories to FRF data, as the study processed its rig test: pick the input and
output channels by name, average the repeated cycles of a periodic drive, remove each
channel's trend, band-pass both sides with the same zero-phase FIR, estimate the FRFs by
Welch averaging (H1, H2 or Hv) with their coherences, and keep the band as femcal FRF data
(:class:`~femcal.testdata.data.FRFData`, with the multiple coherence) that identification
and calibration take; the channels may be resampled to another rate first.

Channel labels: a channel's name is its label unless position files say where it is. A
sensors or actuators CSV (:mod:`femcal.testdata.points`) maps ``LABEL:+Z`` (a sensor and a
direction, as ``femcal synth-rig-test`` and RPC files name them) to ``GRID:+Z``, and an
actuator's ``LABEL:displacement`` and ``LABEL:force`` to its grid and stroke direction
(``17559:-X``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import TimeDataError
from . import signal
from .data import FRFData
from .points import point_label, read_points
from .signal import ESTIMATORS, FRFEstimate, Spectra
from .timedata import TimeData

#: What an output unit says the FRF is (the unit's length part is free).
_QUANTITY_OF_UNIT = (("/s^2", "accelerance"), ("/s2", "accelerance"), ("/s", "mobility"))
_ACTUATOR_SUFFIXES = ("displacement", "force")
_AXES = ("X", "Y", "Z", "RX", "RY", "RZ")


@dataclass(frozen=True)
class FRFSettings:
    """How FRFs are estimated from time histories.

    Attributes
    ----------
    period_s : the drive's period; the record is averaged over its whole cycles first
        (None: no averaging).
    segment_s : Welch segment length (s); its inverse is the frequency resolution.
    overlap : of the segments, a fraction in [0, 1).
    band : (low, high) Hz: the zero-phase FIR band-pass applied to every channel and the
        band kept in the FRF data; None keeps everything above 0 Hz unfiltered.
    order : of the band-pass FIR (the study: 20).
    estimator : "H1", "H2" or "Hv".
    detrend : remove each channel's straight line first.
    rate_hz : resample the channels to this rate first (anti-alias filtered; the ratio to
        the file's rate a fraction of whole numbers up to 1000); None keeps the file's.
    """

    period_s: float | None = None
    segment_s: float = 8.0
    overlap: float = 0.5
    band: tuple[float, float] | None = None
    order: int = 20
    estimator: str = "H1"
    detrend: bool = True
    rate_hz: float | None = None

    def __post_init__(self) -> None:
        """Check the settings (TimeDataError naming the one that is wrong)."""
        if self.period_s is not None and not (np.isfinite(self.period_s) and self.period_s > 0):
            raise TimeDataError(f"period {self.period_s!r} s: expected a positive duration")
        if not (np.isfinite(self.segment_s) and self.segment_s > 0):
            raise TimeDataError(f"segment {self.segment_s!r} s: expected a positive duration")
        if not 0 <= self.overlap < 1:
            raise TimeDataError(f"overlap {self.overlap!r}: expected a fraction in [0, 1)")
        if self.band is not None and not (len(self.band) == 2
                                          and 0 < self.band[0] < self.band[1]):  # fmt: skip
            raise TimeDataError(f"band {self.band!r}: expected 0 < F1 < F2 in Hz")
        if self.rate_hz is not None and not (np.isfinite(self.rate_hz) and self.rate_hz > 0):
            raise TimeDataError(f"rate {self.rate_hz!r} Hz: expected a positive rate")
        if not (isinstance(self.order, int) and self.order >= 2):
            raise TimeDataError(f"band-pass order {self.order!r}: expected 2 or more")
        if self.estimator.lower() not in {e.lower() for e in ESTIMATORS}:
            raise TimeDataError(f"estimator {self.estimator!r}: expected one of "
                                f"{', '.join(ESTIMATORS)}")  # fmt: skip


@dataclass(frozen=True)
class RigFRF:
    """FRFs estimated from time histories, and what they came from.

    Attributes
    ----------
    frf : the band's FRFs as femcal FRF data (labels per :func:`channel_labels`, the
        multiple coherence of each output).
    estimate : every line's FRFs and coherences (n_out, n_in, n_f).
    spectra : the averaged spectral matrices (input PSDs, their singular values).
    x, y : (n_in, n), (n_out, n) the processed time histories the spectra came from.
    cycles : cycles averaged (1 when none).
    """

    frf: FRFData
    estimate: FRFEstimate
    spectra: Spectra
    x: np.ndarray
    y: np.ndarray
    cycles: int


def channel_labels(names: Sequence[str], points: Sequence[str | Path] = ()) -> list[str]:
    """The FRF label of each channel name: ``GRID:AXIS`` where ``points`` files say where
    the channel is (see the module docstring), else the name itself when no file is given.

    Raises
    ------
    TimeDataError
        For a name the files do not place (when files are given), listing the labels they
        hold.
    """
    if not points:
        return list(names)
    where: dict[str, tuple[int, int]] = {}  # label -> (grid, direction) of one-way points
    axes: dict[str, int] = {}  # sensor label -> grid
    for path in points:
        for label, grid, code in read_points(path):
            axes[label] = grid
            where.setdefault(label, (grid, code))
    out = []
    for name in names:
        label, _, what = name.rpartition(":")
        if label in axes and what in _ACTUATOR_SUFFIXES:
            grid, code = where[label]
            out.append(point_label(grid, code))
        elif label in axes and what[:1] in ("+", "-") and what[1:].upper() in _AXES:
            out.append(f"{axes[label]}:{what.upper()}")
        else:
            known = ", ".join(sorted(axes)[:12]) + (" ..." if len(axes) > 12 else "")
            raise TimeDataError(f"channel {name!r}: the position files place no such channel; "
                                f"expected LABEL:+X|+Y|+Z (a sensor) or LABEL:displacement|"
                                f"force (an actuator) with a label of theirs ({known})")
    return out


def _common_unit(data: TimeData, channels: Sequence[int], what: str) -> str:
    units = {data.units[c] for c in channels}
    if len(units) > 1:
        listed = ", ".join(f"{data.names[c]} [{data.units[c]}]" for c in channels)
        raise TimeDataError(f"the {what} channels have different units ({listed}); expected "
                            f"one unit for all {what}s of an FRF set")  # fmt: skip
    return units.pop()


def _quantity(output_unit: str) -> str:
    """receptance, mobility or accelerance as the output unit says (``mm/s^2``, ``g`` ->
    accelerance; ``m/s`` -> mobility; a length or anything else -> receptance)."""
    u = output_unit.replace(" ", "").replace("²", "^2")
    if u.lower() == "g":
        return "accelerance"
    for suffix, quantity in _QUANTITY_OF_UNIT:
        if u.endswith(suffix):
            return quantity
    return "receptance"


def estimate_frfs(data: TimeData, inputs: Sequence[str], outputs: Sequence[str],
                  settings: FRFSettings | None = None, *,
                  points: Sequence[str | Path] = ()) -> RigFRF:  # fmt: skip
    """The FRFs of channels ``outputs`` on channels ``inputs`` (by name) of ``data``, as
    :class:`FRFSettings` says, labelled by :func:`channel_labels`.

    Raises
    ------
    TimeDataError
        For an unknown channel name (listing those there are), a channel given twice,
        inputs or outputs of mixed units, a period that is not a whole number of samples or
        leaves no whole cycle, a segment longer than the (averaged) record, a band beyond
        the Nyquist frequency, fewer averaged segments than inputs, or no line in the band.
    """
    s = settings or FRFSettings()
    if not inputs or not outputs:
        raise TimeDataError("expected at least one input and one output channel")
    given = list(inputs) + list(outputs)
    twice = sorted({n for n in given if given.count(n) > 1})
    if twice:
        raise TimeDataError(f"channel(s) {', '.join(map(repr, twice))} given more than once; "
                            "expected each input and output once")  # fmt: skip
    ins = [data.channel(n) for n in inputs]
    outs = [data.channel(n) for n in outputs]
    in_unit, out_unit = _common_unit(data, ins, "input"), _common_unit(data, outs, "output")
    out_labels = channel_labels(outputs, points)
    in_labels = channel_labels(inputs, points)
    x, y, dt = data.values[ins], data.values[outs], data.dt
    if s.rate_hz is not None:
        x, new_dt = signal.resample(x, dt, 1.0 / s.rate_hz)
        y, _ = signal.resample(y, dt, 1.0 / s.rate_hz)
        dt = new_dt
    cycles = 1
    if s.period_s is not None:
        period = s.period_s / dt
        if abs(period - round(period)) > 1e-6 * period:
            raise TimeDataError(f"period {s.period_s:g} s is {period:.6g} samples of "
                                f"{dt:g} s; expected a whole number of samples")  # fmt: skip
        n_period = round(period)
        cycles = x.shape[1] // n_period
        x, y = signal.average_cycles(x, n_period), signal.average_cycles(y, n_period)
    if s.detrend:
        x, y = signal.detrend(x), signal.detrend(y)
    if s.band is not None:
        x = signal.bandpass(x, dt, *s.band, order=s.order)
        y = signal.bandpass(y, dt, *s.band, order=s.order)
    segment = round(s.segment_s / dt)
    if segment > x.shape[1]:
        raise TimeDataError(f"segment {s.segment_s:g} s ({segment} samples) is longer than "
                            f"the {'averaged cycle' if cycles > 1 else 'record'} "
                            f"({x.shape[1]} samples)")  # fmt: skip
    full = s.estimator.upper() == "H2" and len(ins) > 1
    spectra = signal.cross_spectra(x, y, dt, segment, s.overlap, full_outputs=full)
    if len(ins) > 1 and spectra.segments < len(ins):
        # with fewer averages than inputs the input cross-spectral matrix is singular at
        # every line: no estimator can separate the inputs
        raise TimeDataError(f"{len(ins)} inputs need at least {len(ins)} averaged segments to "
                            f"be told apart; {s.segment_s:g} s segments of the "
                            f"{'averaged cycle' if cycles > 1 else 'record'} "
                            f"({x.shape[1] * dt:g} s) give {spectra.segments}: expected "
                            "shorter segments (--segment) or a longer record")  # fmt: skip
    est = signal.frf_from_spectra(spectra, s.estimator)
    f = est.frequency_hz
    lo, hi = s.band if s.band is not None else (0.0, np.inf)
    lines = (f > 0) & (f >= lo) & (f <= hi) & np.isfinite(est.H).all(axis=(0, 1))
    if not lines.any():
        raise TimeDataError(f"no frequency line with excitation in {lo:g}-{hi:g} Hz at a "
                            f"resolution of {f[1]:g} Hz")  # fmt: skip
    coherence = np.nan_to_num(est.multiple_coherence[:, lines], nan=0.0)
    frf = FRFData.from_labels(f[lines], est.H[:, :, lines], out_labels, in_labels,
                              _quantity(out_unit), f"{out_unit}/{in_unit}")  # fmt: skip
    frf = FRFData(frf.frequency_hz, frf.H, frf.outputs, frf.inputs, frf.quantity, frf.units,
                  coherence)  # fmt: skip
    return RigFRF(frf, est, spectra, x, y, cycles)
