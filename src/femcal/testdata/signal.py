"""Time-history processing as the rig test was processed, and spectra and FRF estimates:
averaging the repeated cycles of a periodic drive, removing the trend, a zero-phase FIR
band-pass (the study: 0.5-30 Hz, order 20), rational-ratio resampling, then Welch's averaged,
windowed, overlapping segments (Bendat and Piersol, Random Data, 4th ed., ch. 11) and the
MIMO H1, H2 and Hv estimators with ordinary and multiple coherence (ch. 6, 7 and 9).

With inputs x (n_in channels) and outputs y (n_out channels), the one-sided cross-spectral
matrices at each frequency are G_xx (n_in x n_in), G_yx (n_out x n_in), G_xy = G_yx^H and the
output autospectra G_yy (or, when asked for, the full output matrix, n_out x n_out).

- H1 = G_yx G_xx^-1 is the least-squares FRF: unbiased by noise on the outputs, biased low
  (towards zero) by noise on the measured inputs.
- H2 solves H G_xy = G_yy, the outputs taking the place of the inputs as the references:
  unbiased by noise on the measured inputs, biased high by noise on the outputs. With one
  input it is the classic G_yy / G_xy of each output on its own (Bendat and Piersol, ch. 6).
  With several inputs G_xy must be invertible, which needs as many outputs as inputs:
  H2 = G_yy G_xy^-1 with the full output matrix, Allemang and Brown's MIMO H2 (R. J. Allemang
  and D. L. Brown, Experimental modal analysis, ch. 21 of Harris' Shock and Vibration
  Handbook, 5th ed., 2002; Allemang, Vibrations: experimental modal analysis, UC-SDRL course
  notes, "Frequency response function estimation"). Other shapes have no unique H2 (a
  pseudo-inverse would weight the outputs by their units) and are refused.
- Hv is the total-least-squares FRF of each output (H. Vold, J. Crowley and G. T. Rocklin,
  New ways of estimating frequency response functions, Sound and Vibration 18(11), 1984;
  Allemang and Brown, as above): the row [H_o, -1] is the eigenvector of the smallest
  eigenvalue of the (n_in + 1)^2 matrix of x and y_o, so the noise is taken to be on inputs
  and output alike, in the units given. With one input |H1| <= |Hv| <= |H2|, all with the
  same phase.

The multiple coherence of an output, G_yx G_xx^-1 G_xy / G_yy, is the share of its power that
the inputs explain together; the ordinary coherence |G_yx|^2 / (G_xx G_yy) of one input and
one output is that share for one input alone (meaningful when the inputs are uncorrelated).
Both are properties of the data, the same whichever estimator is asked for. The singular
values of G_xx tell whether the drives were independent (principal or virtual inputs): a
smallest one far below the largest means inputs that move together, which no estimator can
separate.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

import numpy as np
import scipy.signal as ss

from ..errors import TimeDataError


@dataclass(frozen=True)
class Spectra:
    """Averaged one-sided cross-spectral matrices.

    Attributes
    ----------
    frequency_hz : (n_f,) from 0 to the Nyquist frequency.
    Gxx : (n_f, n_in, n_in) input cross-spectra, ``Gxx[f, i, j]`` the average of
        X_i conj(X_j); Gyx : (n_f, n_out, n_in) output-input cross-spectra, Y_o conj(X_j);
        Gyy : (n_f, n_out) output autospectra (real), all in units^2/Hz (products of the
        channels' units per Hz).
    segments : how many segments were averaged.
    Gyy_full : (n_f, n_out, n_out) output cross-spectra Y_o conj(Y_k), whose diagonal is
        ``Gyy``; only when asked for (``cross_spectra(..., full_outputs=True)``), else None,
        as it grows with the square of the outputs.
    """

    frequency_hz: np.ndarray
    Gxx: np.ndarray
    Gyx: np.ndarray
    Gyy: np.ndarray
    segments: int
    Gyy_full: np.ndarray | None = None


@dataclass(frozen=True)
class FRFEstimate:
    """FRFs (H1, H2 or Hv) with their coherences.

    Attributes
    ----------
    frequency_hz : (n_f,).
    H : (n_out, n_in, n_f) complex FRFs (output units per input unit); NaN at lines the
        estimator cannot solve (no excitation there).
    multiple_coherence : (n_out, n_f) in [0, 1].
    coherence : (n_out, n_in, n_f) ordinary coherence in [0, 1].
    segments : segments averaged.
    estimator : "H1", "H2" or "Hv", the one that gave ``H`` (the coherences do not depend
        on it).
    """

    frequency_hz: np.ndarray
    H: np.ndarray
    multiple_coherence: np.ndarray
    coherence: np.ndarray
    segments: int
    estimator: str = "H1"


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
                  overlap: float = 0.5, full_outputs: bool = False) -> Spectra:  # fmt: skip
    """Welch's estimate with a Hann window: segments of ``segment`` samples overlapping by
    ``overlap``, each windowed and transformed, the products averaged and scaled to
    one-sided densities (2 / (fs sum w^2), the DC and Nyquist lines once).

    ``x`` (n_in, n) and ``y`` (n_out, n) are sampled every ``dt`` s; ``full_outputs`` adds
    the output cross-spectral matrix ``Gyy_full`` (n_f, n_out, n_out) to the result.

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
    Gyy_full = None
    if full_outputs:
        Gyy_full = np.einsum("osf,ksf->fok", Y, Y.conj()) * scale[:, None, None]
    f = np.fft.rfftfreq(segment, dt)
    return Spectra(f, Gxx, Gyx, Gyy, n_seg, Gyy_full)


ESTIMATORS = ("H1", "H2", "Hv")
_COND_LIMIT = 1e12  # a spectral matrix this ill-conditioned at a line is taken as singular


def _regular(G: np.ndarray) -> np.ndarray:
    """(n_f,) True where the matrix of the stack ``G`` (n_f, n, n) is fit to solve with:
    condition number below 1e12 (lines with no excitation are not)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        cond = np.linalg.cond(G)
    return np.isfinite(cond) & (cond < _COND_LIMIT)


def _h1_frf(s: Spectra) -> np.ndarray:
    """H1 (n_out, n_in, n_f): H G_xx = G_yx line by line, NaN where G_xx is singular."""
    n_f, n_out, n_in = s.Gyx.shape
    good = _regular(s.Gxx)
    H = np.full((n_out, n_in, n_f), np.nan + 0j)
    Ht = np.linalg.solve(np.swapaxes(s.Gxx[good], 1, 2), np.swapaxes(s.Gyx[good], 1, 2))
    H[:, :, good] = np.transpose(Ht, (2, 1, 0))  # (n_f, n_in, n_out) -> (n_out, n_in, n_f)
    return H


def _h2_frf(s: Spectra) -> np.ndarray:
    """H2 (n_out, n_in, n_f): H G_xy = G_yy line by line (see the module docstring), NaN
    where G_xx or G_xy is singular. One input: each output on its own; several: as many
    outputs as inputs and ``s.Gyy_full``."""
    n_f, n_out, n_in = s.Gyx.shape
    Gxy = np.conj(np.swapaxes(s.Gyx, 1, 2))  # (n_f, n_in, n_out)
    good = _regular(s.Gxx)
    H = np.full((n_out, n_in, n_f), np.nan + 0j)
    if n_in == 1:
        gxy = Gxy[:, 0, :]  # (n_f, n_out)
        ok = good[:, None] & (gxy != 0)
        H[:, 0, :] = np.where(ok, s.Gyy / np.where(ok, gxy, 1.0), np.nan).T
        return H
    good &= _regular(Gxy)
    # H Gxy = Gyy_full  <=>  Gxy^T H^T = Gyy_full^T
    Ht = np.linalg.solve(np.swapaxes(Gxy[good], 1, 2), np.swapaxes(s.Gyy_full[good], 1, 2))
    H[:, :, good] = np.transpose(Ht, (2, 1, 0))
    return H


def _hv_frf(s: Spectra) -> np.ndarray:
    """Hv (n_out, n_in, n_f): per output o and line, u the eigenvector of the smallest
    eigenvalue of C = E[z z^H], z = [x; y_o]; then [H_o, -1] z = 0 at best gives
    [H_o, -1] = -u^H / conj(u_n). NaN where G_xx is singular."""
    n_f, n_out, n_in = s.Gyx.shape
    C = np.empty((n_f, n_out, n_in + 1, n_in + 1), complex)
    C[:, :, :n_in, :n_in] = s.Gxx[:, None]
    C[:, :, :n_in, n_in] = np.conj(s.Gyx)  # X_i conj(Y_o)
    C[:, :, n_in, :n_in] = s.Gyx  # Y_o conj(X_j)
    C[:, :, n_in, n_in] = s.Gyy
    good = _regular(s.Gxx)
    u = np.linalg.eigh(C[good])[1][..., 0]  # (g, n_out, n_in + 1), smallest eigenvalue
    with np.errstate(invalid="ignore", divide="ignore"):
        Hg = -np.conj(u[..., :n_in] / u[..., n_in:])  # (g, n_out, n_in)
    Hg[~np.isfinite(Hg)] = np.nan
    H = np.full((n_out, n_in, n_f), np.nan + 0j)
    H[:, :, good] = np.transpose(Hg, (1, 2, 0))
    return H


def _coherences(s: Spectra, H1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Multiple (n_out, n_f) and ordinary (n_out, n_in, n_f) coherence from the spectra and
    the H1 FRFs ``H1`` (n_out, n_in, n_f); NaN where H1 is."""
    explained = np.einsum("oif,foi->of", H1, np.conj(s.Gyx)).real  # G_yx G_xx^-1 G_xy
    with np.errstate(invalid="ignore", divide="ignore"):
        multiple = np.clip(explained / s.Gyy.T, 0.0, 1.0)
        gxx = np.einsum("fii->fi", s.Gxx).real
        ordinary = np.clip(np.abs(s.Gyx) ** 2 / (gxx[:, None, :] * s.Gyy[:, :, None]), 0, 1)
    return multiple, np.transpose(ordinary, (1, 2, 0))


def _estimator_name(estimator: object) -> str:
    """The canonical spelling (one of ESTIMATORS) of ``estimator``, in any case."""
    names = {e.lower(): e for e in ESTIMATORS}
    if not isinstance(estimator, str) or estimator.lower() not in names:
        raise TimeDataError(f"FRF estimator {estimator!r}: expected one of "
                            f"{', '.join(ESTIMATORS)} (in any case)")  # fmt: skip
    return names[estimator.lower()]


def _check_h2_shape(n_in: int, n_out: int) -> None:
    if n_in > 1 and n_out != n_in:
        raise TimeDataError(f"H2 of {n_in} inputs and {n_out} outputs: with several inputs H2 "
                            f"= G_yy G_xy^-1 needs as many outputs as inputs ({n_in}); use "
                            f"H1 or Hv, or H2 on {n_in} outputs at a time")  # fmt: skip


def frf_from_spectra(spectra: Spectra, estimator: str = "H1") -> FRFEstimate:
    """FRFs by ``estimator`` ("H1", "H2" or "Hv", in any case; see the module docstring)
    from spectra already averaged, with multiple and ordinary coherence (the same for every
    estimator). Lines where the inputs' spectral matrix is singular (no excitation there)
    give NaN.

    Raises
    ------
    TimeDataError
        For another estimator name; for H2 of several inputs, outputs of another number
        than the inputs or spectra without ``Gyy_full`` (``cross_spectra(...,
        full_outputs=True)``).
    """
    name = _estimator_name(estimator)
    n_out, n_in = spectra.Gyx.shape[1:]
    if name == "H2":
        _check_h2_shape(n_in, n_out)
        if n_in > 1 and spectra.Gyy_full is None:
            raise TimeDataError("H2 of several inputs needs the output cross-spectral matrix: "
                                "spectra without Gyy_full given, expected spectra from "
                                "cross_spectra(..., full_outputs=True)")  # fmt: skip
    H1 = _h1_frf(spectra)
    H = H1 if name == "H1" else _h2_frf(spectra) if name == "H2" else _hv_frf(spectra)
    multiple, ordinary = _coherences(spectra, H1)
    return FRFEstimate(spectra.frequency_hz, H, multiple, ordinary, spectra.segments, name)


def frf(x: np.ndarray, y: np.ndarray, dt: float, segment: int, overlap: float = 0.5,
        estimator: str = "H1") -> FRFEstimate:  # fmt: skip
    """The FRFs of outputs ``y`` (n_out, n) on inputs ``x`` (n_in, n) sampled every ``dt``
    s, by ``estimator``: "H1" (noise on the outputs), "H2" (noise on the measured inputs;
    one input, or as many outputs as inputs) or "Hv" (total least squares, noise on both),
    in any case, from Welch spectra of ``segment`` samples overlapping by ``overlap`` (see
    :func:`cross_spectra` and the module docstring). Multiple and ordinary coherence come
    with them, the same for every estimator.

    Returns
    -------
    FRFEstimate
        H (n_out, n_in, n_f) in output units per input unit, NaN at lines with no
        excitation; coherences (n_out, n_f) and (n_out, n_in, n_f).

    Raises
    ------
    TimeDataError
        For another estimator name, H2 of several inputs with outputs of another number,
        or as :func:`cross_spectra`.
    """
    name = _estimator_name(estimator)
    n_in, n_out = np.atleast_2d(np.asarray(x)).shape[0], np.atleast_2d(np.asarray(y)).shape[0]
    full = name == "H2" and n_in > 1
    if full:
        _check_h2_shape(n_in, n_out)
    return frf_from_spectra(cross_spectra(x, y, dt, segment, overlap, full_outputs=full), name)


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
    return frf(x, y, dt, segment, overlap, "H1")


def h2(x: np.ndarray, y: np.ndarray, dt: float, segment: int,
       overlap: float = 0.5) -> FRFEstimate:  # fmt: skip
    """The H2 FRFs (H G_xy = G_yy: unbiased by noise on the measured inputs, biased high by
    noise on the outputs) of outputs ``y`` (n_out, n) on inputs ``x`` (n_in, n) sampled at
    ``dt``, with multiple and ordinary coherence. One input: G_yy / G_xy of each output (any
    number of outputs). Several inputs: G_yy G_xy^-1 with the full output cross-spectral
    matrix (Allemang and Brown), which needs as many outputs as inputs. Lines where G_xx or
    G_xy is singular give NaN.

    Raises
    ------
    TimeDataError
        For several inputs and outputs of another number, or as :func:`cross_spectra`.
    """
    return frf(x, y, dt, segment, overlap, "H2")


def hv(x: np.ndarray, y: np.ndarray, dt: float, segment: int,
       overlap: float = 0.5) -> FRFEstimate:  # fmt: skip
    """The Hv (total least squares) FRFs of outputs ``y`` (n_out, n) on inputs ``x``
    (n_in, n) sampled at ``dt``, with multiple and ordinary coherence: for each output and
    line, the eigenvector of the smallest eigenvalue of the (n_in + 1)-square spectral matrix
    of the inputs and that output, scaled to -1 on the output (Vold et al. 1984). It weighs
    noise on the inputs and on the output alike, in the units given (so it is not unbiased
    by either, and depends on those units); with one input |H1| <= |Hv| <= |H2| at every
    line, with the same phase. Lines with no excitation give NaN.

    Raises
    ------
    TimeDataError
        As :func:`cross_spectra`.
    """
    return frf(x, y, dt, segment, overlap, "Hv")


def input_singular_values(spectra: Spectra) -> np.ndarray:
    """The singular values (n_f, n_in) of the input spectral matrix G_xx at each line, in
    descending order (units^2/Hz): the powers of the principal (virtual, uncorrelated)
    inputs. Independent drives of like power give values of like size; a smallest value
    far below the largest means drives that move together at that line, where no
    estimator can tell their FRFs apart."""
    return np.linalg.svd(spectra.Gxx, compute_uv=False)


def input_condition_number(spectra: Spectra) -> np.ndarray:
    """The condition number (n_f,) of G_xx at each line, the largest over the smallest of
    :func:`input_singular_values`: 1 for independent drives of equal power, infinite where
    the drives are linearly dependent, NaN at lines with no excitation at all."""
    sv = input_singular_values(spectra)
    with np.errstate(invalid="ignore", divide="ignore"):
        return sv[:, 0] / sv[:, -1]


_MAX_FACTOR = 1000


def resample(values: np.ndarray, dt: float, new_dt: float) -> tuple[np.ndarray, float]:
    """``values`` (channels, n) sampled every ``dt`` s resampled to every ``new_dt`` s by
    scipy.signal.resample_poly: up-sampling by p, an anti-alias low-pass FIR, down-sampling
    by q, with p / q = dt / new_dt. The FIR is a Kaiser-window (beta 8.6) sinc of 40 max(p, q)
    + 1 taps cut off at the lower of the two Nyquist frequencies: flat to 1e-4 up to 0.8 of
    it, below -85 dB from 1.2 of it, half the amplitude at it; its delay is compensated (no
    phase shift). The records are padded by their end lines, so the first and last twenty or
    so samples at the slower rate carry edge effects.

    Returns
    -------
    (new values (channels, ceil(n p / q)), the new step dt q / p in s)

    Raises
    ------
    TimeDataError
        For steps that are not positive and finite, a ratio dt / new_dt that is not p / q
        with p and q up to 1000 (within 1e-9 relative), or non-finite samples.
    """
    if not (np.isfinite(dt) and np.isfinite(new_dt) and dt > 0 and new_dt > 0):
        raise TimeDataError(f"resampling from a step of {dt!r} s to {new_dt!r} s: expected "
                            "positive, finite steps")  # fmt: skip
    ratio = dt / new_dt  # the new rate over the old
    frac = Fraction(ratio).limit_denominator(_MAX_FACTOR)
    up, down = frac.numerator, frac.denominator
    if not 1 <= up <= _MAX_FACTOR or abs(up / down - ratio) > 1e-9 * ratio:
        raise TimeDataError(f"resampling from a step of {dt:g} s to {new_dt:g} s, a rate ratio "
                            f"of {ratio:.12g}: expected a ratio p/q of whole numbers up to "
                            f"{_MAX_FACTOR} (within 1e-9)")  # fmt: skip
    values = np.atleast_2d(np.asarray(values, float))
    if not np.isfinite(values).all():
        raise TimeDataError("the time histories hold NaN or infinite samples")
    if up == down:
        return values.copy(), dt
    rate = max(up, down)
    taps = ss.firwin(40 * rate + 1, 1.0 / rate, window=("kaiser", 8.6))
    out = ss.resample_poly(values, up, down, axis=1, window=taps, padtype="line")
    return out, dt * down / up
