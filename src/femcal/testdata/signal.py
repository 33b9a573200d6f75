"""Time-history processing as the rig test was processed, and spectra and FRF estimates:
averaging the repeated cycles of a periodic drive, removing the trend, a zero-phase FIR
band-pass (the study: 0.5-30 Hz, order 20), then Welch's averaged, windowed, overlapping
segments (Bendat and Piersol, Random Data, 4th ed., ch. 11) and the MIMO H1 estimator with
ordinary and multiple coherence (ch. 7 and 9).

With inputs x (n_in channels) and outputs y (n_out channels), the one-sided cross-spectral
matrices at each frequency are G_xx (n_in x n_in), G_yx (n_out x n_in) and the output
autospectra G_yy; H1 = G_yx G_xx^-1 is the least-squares FRF, unbiased by output noise. The
multiple coherence of an output, G_yx G_xx^-1 G_xy / G_yy, is the share of its power that
the inputs explain together; the ordinary coherence |G_yx|^2 / (G_xx G_yy) of one input and
one output is that share for one input alone (meaningful when the inputs are uncorrelated).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.signal as ss

from ..errors import TimeDataError


@dataclass(frozen=True)
class Spectra:
    """Averaged one-sided cross-spectral matrices.

    Attributes
    ----------
    frequency_hz : (n_f,) from 0 to the Nyquist frequency.
    Gxx : (n_f, n_in, n_in) input cross-spectra; Gyx : (n_f, n_out, n_in) output-input
        cross-spectra; Gyy : (n_f, n_out) output autospectra (units^2/Hz).
    segments : how many segments were averaged.
    """

    frequency_hz: np.ndarray
    Gxx: np.ndarray
    Gyx: np.ndarray
    Gyy: np.ndarray
    segments: int


@dataclass(frozen=True)
class FRFEstimate:
    """H1 FRFs with their coherences.

    Attributes
    ----------
    frequency_hz : (n_f,).
    H : (n_out, n_in, n_f) complex FRFs (output units per input unit).
    multiple_coherence : (n_out, n_f) in [0, 1].
    coherence : (n_out, n_in, n_f) ordinary coherence in [0, 1].
    segments : segments averaged.
    """

    frequency_hz: np.ndarray
    H: np.ndarray
    multiple_coherence: np.ndarray
    coherence: np.ndarray
    segments: int


def average_cycles(values: np.ndarray, period: int) -> np.ndarray:
    """The mean cycle (channels, period) of ``values`` (channels, n) that repeat a periodic
    drive every ``period`` samples: the noise falls by the square root of the cycles.

    Raises
    ------
    TimeDataError
        For a period below 2 samples or one that does not divide the record into whole
        cycles (trim the record to whole cycles first: a partial cycle is not dropped
        silently).
    """
    values = np.atleast_2d(values)
    n = values.shape[1]
    if period < 2 or n % period:
        raise TimeDataError(f"{n} samples are not whole cycles of {period}: expected a "
                            f"period of 2 or more samples that divides the record "
                            f"({n // max(period, 1)} cycles and {n % max(period, 1)} samples "
                            "over)")  # fmt: skip
    return values.reshape(values.shape[0], n // period, period).mean(axis=1)


def detrend(values: np.ndarray) -> np.ndarray:
    """``values`` (channels, n) less each channel's least-squares straight line."""
    return ss.detrend(np.atleast_2d(values), axis=1, type="linear")


def bandpass(values: np.ndarray, dt: float, f_lo: float, f_hi: float,
             order: int = 20) -> np.ndarray:  # fmt: skip
    """Zero-phase FIR band-pass of ``values`` (channels, n): a Hamming-window FIR of
    ``order`` (taps order + 1) run forwards and backwards (filtfilt), so its gain is the
    square of the FIR's and its phase zero.

    Raises
    ------
    TimeDataError
        For a band not inside (0, Nyquist), or a record too short for the filter.
    """
    nyq = 0.5 / dt
    if not 0 < f_lo < f_hi < nyq:
        raise TimeDataError(f"band {f_lo:g}-{f_hi:g} Hz: expected 0 < f_lo < f_hi below the "
                            f"Nyquist frequency {nyq:g} Hz")  # fmt: skip
    values = np.atleast_2d(values)
    taps = ss.firwin(order + 1, [f_lo, f_hi], pass_zero=False, fs=1.0 / dt)
    if values.shape[1] <= 3 * len(taps):
        raise TimeDataError(f"{values.shape[1]} samples: a band-pass of order {order} needs "
                            f"more than {3 * len(taps)}")  # fmt: skip
    return ss.filtfilt(taps, [1.0], values, axis=1)


def _segments(v: np.ndarray, length: int, step: int) -> np.ndarray:
    """(channels, n_seg, length) views of v (channels, n) without copying."""
    n = v.shape[1]
    n_seg = 1 + (n - length) // step
    s0, s1 = v.strides
    return np.lib.stride_tricks.as_strided(v, (v.shape[0], n_seg, length),
                                           (s0, step * s1, s1), writeable=False)  # fmt: skip


def cross_spectra(x: np.ndarray, y: np.ndarray, dt: float, segment: int,
                  overlap: float = 0.5) -> Spectra:  # fmt: skip
    """Welch's estimate with a Hann window: segments of ``segment`` samples overlapping by
    ``overlap``, each windowed and transformed, the products averaged and scaled to
    one-sided densities (2 / (fs sum w^2), the DC and Nyquist lines once).

    Raises
    ------
    TimeDataError
        For inputs and outputs of other lengths, a segment longer than the data or shorter
        than 8 samples, an overlap outside [0, 1), or non-finite samples.
    """
    x, y = np.atleast_2d(np.asarray(x, float)), np.atleast_2d(np.asarray(y, float))
    if x.shape[1] != y.shape[1]:
        raise TimeDataError(f"inputs of {x.shape[1]} samples, outputs of {y.shape[1]}; "
                            "expected the same")  # fmt: skip
    if not 8 <= segment <= x.shape[1]:
        raise TimeDataError(f"segment of {segment} samples: expected 8 to the {x.shape[1]} "
                            "samples there are")  # fmt: skip
    if not 0 <= overlap < 1:
        raise TimeDataError(f"overlap {overlap}: expected a fraction in [0, 1)")
    if not (np.isfinite(x).all() and np.isfinite(y).all()):
        raise TimeDataError("the time histories hold NaN or infinite samples")
    step = max(1, round(segment * (1 - overlap)))
    w = np.hanning(segment + 1)[:-1]  # periodic Hann
    X = np.fft.rfft(_segments(x, segment, step) * w, axis=-1)  # (n_in, n_seg, n_f)
    Y = np.fft.rfft(_segments(y, segment, step) * w, axis=-1)
    n_seg = X.shape[1]
    scale = np.full(X.shape[-1], 2.0 / ((1.0 / dt) * (w**2).sum() * n_seg))
    scale[0] /= 2
    if segment % 2 == 0:
        scale[-1] /= 2
    Gxx = np.einsum("isf,jsf->fij", X, X.conj()) * scale[:, None, None]
    Gyx = np.einsum("osf,jsf->foj", Y, X.conj()) * scale[:, None, None]
    Gyy = np.einsum("osf,osf->fo", Y, Y.conj()).real * scale[:, None]
    f = np.fft.rfftfreq(segment, dt)
    return Spectra(f, Gxx, Gyx, Gyy, n_seg)


def h1(x: np.ndarray, y: np.ndarray, dt: float, segment: int,
       overlap: float = 0.5) -> FRFEstimate:  # fmt: skip
    """The H1 FRFs of outputs ``y`` (n_out, n) on inputs ``x`` (n_in, n) sampled at ``dt``,
    with multiple and ordinary coherence (see the module docstring). Lines where the inputs'
    spectral matrix is singular (no excitation there) give NaN.

    Raises
    ------
    TimeDataError
        As :func:`cross_spectra`.
    """
    s = cross_spectra(x, y, dt, segment, overlap)
    n_in = s.Gxx.shape[1]
    # solve Gxx^T H^T = Gyx^T line by line; rcond-checked so empty lines give NaN
    cond = np.linalg.cond(s.Gxx)
    good = np.isfinite(cond) & (cond < 1e12)
    H = np.full((s.Gyx.shape[1], n_in, len(s.frequency_hz)), np.nan + 0j)
    Ht = np.linalg.solve(np.swapaxes(s.Gxx[good], 1, 2), np.swapaxes(s.Gyx[good], 1, 2))
    H[:, :, good] = np.transpose(Ht, (2, 1, 0))  # (n_f, n_in, n_out) -> (n_out, n_in, n_f)
    explained = np.einsum("oif,foi->of", H, np.conj(s.Gyx)).real
    with np.errstate(invalid="ignore", divide="ignore"):
        multiple = np.clip(explained / s.Gyy.T, 0.0, 1.0)
        gxx = np.einsum("fii->fi", s.Gxx).real
        ordinary = np.clip(np.abs(s.Gyx) ** 2 / (gxx[:, None, :] * s.Gyy[:, :, None]), 0, 1)
    return FRFEstimate(s.frequency_hz, H, multiple, np.transpose(ordinary, (1, 2, 0)),
                       s.segments)  # fmt: skip
