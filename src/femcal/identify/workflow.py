"""Identification of measured FRFs over a band, with only the band given.

1. **Layout** (:mod:`femcal.identify.layout`): the FRFs are taken with the larger side
   (outputs, or inputs for a roving-hammer set as measured) as rows, so that an ``N x 1``
   set and its ``1 x N`` transpose are one problem and the shapes come out at the N points.
2. **Band**: edges within :attr:`Settings.edge_lines` lines outside the data are moved to
   the data's ends (with a warning); a 0 Hz line is left out.
3. **Channels** are scaled to unit RMS over the band (rows, then columns), so that no sensor
   dominates by its units or position; the scaling is undone at the end. Channels the
   others do not explain (:mod:`femcal.identify.channels`) may be broken, or the only
   sensors of some mode: the identification is run with and without them, and the model
   without them is kept unless the other channels fit clearly better with them.
4. **Peaks and parts** (:mod:`femcal.identify.indicators`): the CMIF's peaks that stand out
   of its noise; without given splits, the band is split at the CMIF's lowest points so that
   each part holds at most :attr:`Settings.part_modes` peaks.
5. **Poles of each part** from a stabilisation diagram of the chosen estimator, the
   poly-reference least-squares complex frequency-domain method (:mod:`femcal.identify.plscf`,
   "PolyMAX") or the frequency-domain subspace method (:mod:`femcal.identify.subspace`),
   over orders chosen from the part's peaks; the physical poles are the columns that stay
   stable over the orders (:mod:`femcal.identify.stabilization`). With a given order, the
   physical-looking poles of that order.
6. **Residues** of the joined poles over the whole band by least squares for the fixed poles
   (LSFD, :mod:`femcal.identify.lsq`), with residual poles standing for the modes outside the
   band: one at ``gamma`` times the upper edge (1.43), one far away at ``beta`` times it
   (100), and one at the lower edge divided by gamma; B and (C, D) alternate until the fit
   stops improving.
7. **Checks**: a CMIF peak with no mode near it is identified again in a narrow band around
   it; one still without a mode, and a poor fit, are reported as warnings in the result
   (:attr:`IdentifiedModel.warnings`), never passed over. Each mode's MPC, MPD and
   complexity and each channel's fit error and FRF correlation
   (:mod:`femcal.identify.quality`) are kept with the model.

Coherence, where the data carry it, weights the fits by ``sqrt(coh / (1 - coh))``, the
inverse of an H1 estimate's relative scatter (capped), so that frequencies where the
measurement is poor count less: pLSCF's per roving channel and frequency, the residues' per
frequency (the mean over the channels); the subspace diagram is not weighted.
"""

from __future__ import annotations

import itertools
import warnings
from collections.abc import Callable, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass, field, replace

import numpy as np

from ..errors import FemcalWarning
from ..parallel.cluster import result_of
from ..response.statespace import StateSpace, frequency_response, poles_to_modal
from ..testdata.data import Channel, FRFData, FRFError
from . import plscf, subspace
from .channels import consistency_error, outliers
from .indicators import Peaks, cmif, find_cmif_peaks, noisy_regions, partition
from .layout import Layout
from .lsq import FixedPoleModel, Resolvent, fit_c, fit_fixed_poles, response
from .quality import complexity, frf_correlation, mpc, mpd
from .stabilization import Criteria, Stabilization, physical, stable_columns

#: Highest subspace model order of a part (and at most half its frequencies).
MAX_ORDER = 200
#: Largest band edge (Hz), largest ratio of the band's edges, and largest magnitude of a
#: nonzero FRF value (smallest: its inverse) that identification takes: bounds no
#: structural test comes near, inside which the scaling, the bilinear map about the band's
#: geometric centre and the powers of the frequency stay far from overflow and round-off.
MAX_HZ, MAX_SPAN, MAX_ABS = 1e9, 1e12, 1e100
#: The estimators ``Settings.method`` names.
METHODS = ("plscf", "subspace")
#: Largest weight a coherence gives (a coherence of 0.9999 and above).
MAX_COHERENCE_WEIGHT = 100.0


@dataclass(frozen=True)
class Settings:
    """Identification options.

    method : the estimator, ``"plscf"`` (default) or ``"subspace"``.
    gamma, beta : residual poles at gamma and beta times a band's upper edge.
    lower_residual : also a residual pole at the lower edge / gamma.
    residual_damping : damping ratio of the residual poles.
    feedthrough : estimate D. stable : reflect unstable subspace poles.
    zeta_max : poles damped more than this are not physical modes.
    max_order : highest order of the stabilisation diagrams; None: chosen per part from its
        peaks (the subspace method's number of states, pLSCF's polynomial order).
    part_modes : without given splits, the most CMIF peaks a part holds.
    tol_frequency, tol_damping, tol_mac, min_share : the stability and selection criteria
        (:class:`femcal.identify.stabilization.Criteria`).
    max_iter, tol : of the alternating least squares.
    suspect_factor, suspect_floor : a channel is suspect when its fit error exceeds both
        ``suspect_factor`` times the median channel's and ``suspect_floor``.
    exclude_suspects : identify again without the suspect channels (their C and D are
        still estimated, so their fit error is reported), so that a broken sensor does not
        spoil the poles.
    frequency_weighting : weight each frequency of the least-squares fits by 1 / (RMS of
        |H| over the channels there), so the fit is close to a relative one: the low
        levels between and below resonances (which a log-FRF calibration metric weighs as
        much as the peaks) are fitted as well as the peaks.
    edge_lines : band edges at most this many lines outside the data are moved onto the
        data's ends (with a warning); farther out they are refused.
    poor_fit : a median fit error above this is reported as a poor fit.
    min_contribution, min_contribution_complex : a pole whose resonance peak stays below
        this share of the FRFs' level at its frequency (the second, for a shape whose MPC
        is under 0.5: noise fitted) is left out: it is not a mode the data show
        (:func:`mode_contributions`). A weak real mode beside a strong one (a tenth of its
        neighbour's level) keeps a normal shape, and stays.
    """

    method: str = "plscf"
    gamma: float = 1.43
    beta: float = 100.0
    lower_residual: bool = True
    residual_damping: float = 0.05
    feedthrough: bool = True
    stable: bool = True
    zeta_max: float = Criteria.zeta_max
    max_order: int | None = None
    part_modes: int = 6
    tol_frequency: float = Criteria.tol_frequency
    tol_damping: float = Criteria.tol_damping
    tol_mac: float = Criteria.tol_mac
    min_share: float = Criteria.min_share
    max_iter: int = 20
    tol: float = 1e-4
    suspect_factor: float = 4.0
    suspect_floor: float = 0.1
    exclude_suspects: bool = True
    frequency_weighting: bool = True
    edge_lines: int = 2
    poor_fit: float = 0.25
    min_contribution: float = 0.02
    min_contribution_complex: float = 0.3

    def __post_init__(self) -> None:
        """Refuse settings that make no sense (ValueError naming the setting and what is
        expected): the residual poles must lie outside the band (gamma > 1) and apart
        (beta > gamma), damping ratios between 0 and 1, orders and counts positive."""
        if self.method not in METHODS:
            raise ValueError(f"identification setting method = {self.method!r}: expected one "
                             f"of {', '.join(METHODS)}")  # fmt: skip
        checks = [
            (self.gamma > 1, "gamma", self.gamma, "a number above 1 (the residual poles sit "
             "at gamma times the upper band edge and the lower edge / gamma, outside the "
             "band)"),
            (self.beta > self.gamma, "beta", self.beta, f"a number above gamma = {self.gamma} "
             "(the far residual pole sits at beta times the upper band edge)"),
            (0 < self.residual_damping < 1, "residual_damping", self.residual_damping,
             "a damping ratio between 0 and 1"),
            (0 < self.zeta_max <= 1, "zeta_max", self.zeta_max, "a damping ratio in (0, 1]"),
            (self.max_order is None or 2 <= self.max_order <= MAX_ORDER, "max_order",
             self.max_order if self.max_order is not None else 0,
             f"a whole number from 2 to {MAX_ORDER}, or None (automatic)"),
            (self.part_modes >= 1, "part_modes", self.part_modes, "at least 1"),
            (0 < self.tol_frequency < 1, "tol_frequency", self.tol_frequency,
             "a fraction in (0, 1)"),
            (self.tol_damping > 0, "tol_damping", self.tol_damping, "a positive fraction"),
            (0 <= self.tol_mac <= 1, "tol_mac", self.tol_mac, "a MAC in [0, 1]"),
            (0 < self.min_share <= 1, "min_share", self.min_share, "a share in (0, 1]"),
            (self.max_iter >= 1, "max_iter", self.max_iter, "at least 1"),
            (self.tol > 0, "tol", self.tol, "a positive number"),
            (self.suspect_factor > 0, "suspect_factor", self.suspect_factor, "a positive number"),
            (self.suspect_floor >= 0, "suspect_floor", self.suspect_floor, "0 or more"),
            (self.edge_lines >= 0, "edge_lines", self.edge_lines, "0 or more"),
            (self.poor_fit > 0, "poor_fit", self.poor_fit, "a positive number"),
        ]
        if self.method == "plscf" and self.max_order is not None:
            checks.append((self.max_order <= plscf.MAX_ORDER, "max_order", self.max_order,
                           f"at most {plscf.MAX_ORDER} for plscf (its polynomial order; the "
                           "model has that times the references poles)"))
        for ok, name, value, expected in checks:
            if not (ok and np.isfinite(value)):
                raise ValueError(f"identification setting {name} = {value!r}: expected "
                                 f"{expected}")  # fmt: skip

    @property
    def criteria(self) -> Criteria:
        return Criteria(tol_frequency=self.tol_frequency, tol_damping=self.tol_damping,
                        tol_mac=self.tol_mac, min_share=self.min_share,
                        zeta_max=self.zeta_max)  # fmt: skip


@dataclass(frozen=True)
class Part:
    """One part of the band: its limits (Hz), the order used (the diagram's highest with an
    automatic choice), whether it was chosen automatically, its physical poles, and its
    stabilisation diagram (if computed)."""

    band: tuple[float, float]
    order: int
    automatic: bool
    poles: np.ndarray
    diagram: Stabilization | None = None


@dataclass(frozen=True)
class IdentifiedModel:
    """An identified model of FRF data.

    Attributes
    ----------
    system : real state-space model, H(s) = C (sI - A)^-1 B + D in the data's units and
        layout (outputs x inputs).
    residual_states : (n,) True for the states of residual poles.
    poles : (k,) physical poles (Im > 0), ascending frequency, rad/s.
    frequency_hz, damping_ratio : (k,).
    shapes : (r, k) complex mode shapes at the roving channels (:attr:`shape_channels`:
        the outputs, or the inputs of a set with more inputs than outputs, by
        reciprocity), largest component 1.
    participation : (q, k) complex modal participation of the references (the other side),
        scaled with the shapes' normalisation so that ``shape participation^T`` is the
        residue of the roving x reference FRFs.
    outputs, inputs, quantity, units : as the data's.
    band : (f_lo, f_hi) Hz.
    fit_error : (r,) per roving channel, ``||H - H_model|| / ||H||`` over the band, each
        reference's FRFs scaled to unit RMS first.
    suspect : (r,) roving channels whose fit is poor, or that the other channels do not
        explain (see :class:`Settings` and :mod:`femcal.identify.channels`).
    consistency : (r,) leave-one-out consistency error of each roving channel.
    parts : the parts identified.
    history : cost of the whole-band fit after each alternating step (scaled data).
    layout : which side the shapes are on (None in models written before it was kept:
        the outputs).
    method : the estimator that found the poles.
    mpc, mpd, complexity : (k,) per mode (:mod:`femcal.identify.quality`).
    frf_correlation : (r,) per roving channel, the measured and synthesised FRFs' MAC.
    peaks_hz : the CMIF peaks in the band.
    warnings : what the identification could not do well (a peak without a mode, a poor
        fit), in words.
    """

    system: StateSpace
    residual_states: np.ndarray
    poles: np.ndarray
    frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    shapes: np.ndarray
    participation: np.ndarray
    outputs: tuple[Channel, ...]
    inputs: tuple[Channel, ...]
    quantity: str
    units: str
    band: tuple[float, float]
    fit_error: np.ndarray
    suspect: np.ndarray
    parts: list[Part] = field(default_factory=list)
    history: list[float] = field(default_factory=list)
    consistency: np.ndarray | None = None
    layout: Layout | None = None
    method: str = ""
    mpc: np.ndarray | None = None
    mpd: np.ndarray | None = None
    complexity: np.ndarray | None = None
    frf_correlation: np.ndarray | None = None
    peaks_hz: np.ndarray | None = None
    warnings: tuple[str, ...] = ()

    @property
    def shape_channels(self) -> tuple[Channel, ...]:
        """The channels the shapes, fit errors and suspect flags are given at."""
        return self.layout.roving if self.layout is not None else self.outputs

    @property
    def reference_channels(self) -> tuple[Channel, ...]:
        """The channels the participation is given at."""
        return self.layout.references if self.layout is not None else self.inputs

    def frf(self, freq_hz: np.ndarray) -> FRFData:
        """The model's FRFs at freq_hz as a data set (same labels, quantity and units)."""
        H = frequency_response(self.system, freq_hz)
        return FRFData(np.asarray(freq_hz, float), H, self.outputs, self.inputs,
                       self.quantity, self.units)  # fmt: skip


def residual_pole(freq_hz: float, zeta: float) -> complex:
    w = 2.0 * np.pi * freq_hz
    return complex(-zeta * w, w * np.sqrt(1.0 - zeta**2))


def _residual_poles(band: tuple[float, float], s: Settings) -> np.ndarray:
    hz = [s.gamma * band[1], s.beta * band[1]]
    if s.lower_residual:
        hz.insert(0, band[0] / s.gamma)
    return np.array([residual_pole(h, s.residual_damping) for h in hz])


def _scales(H: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Output and input scales: RMS of each output over inputs and frequencies, then of each
    input over the scaled outputs; 1 where a channel is all zero."""
    so = np.sqrt(np.mean(np.abs(H) ** 2, axis=(1, 2)))
    so = np.where(so > 0, so, 1.0)
    si = np.sqrt(np.mean(np.abs(H / so[:, None, None]) ** 2, axis=(0, 2)))
    si = np.where(si > 0, si, 1.0)
    return so, si


def check_band_data(data: FRFData, band: tuple[float, float]) -> None:
    """Refuse FRFs that cannot be identified over ``band``: a band edge above
    :data:`MAX_HZ` or edges further apart than :data:`MAX_SPAN` times, a value that is not
    finite or whose magnitude lies outside 1 / :data:`MAX_ABS` to :data:`MAX_ABS` (other
    than 0), an output or input that is zero throughout (a dead or unconnected channel: its
    fit and scaling are undefined), or an output whose FRFs have no imaginary part (real
    values: magnitudes without phase, or an undamped model).

    Raises
    ------
    FRFError
        Naming the channels, the band, and (for a bad value) the output, input and
        frequency.
    """
    f = np.asarray(data.frequency_hz)
    sel = (f >= band[0]) & (f <= band[1])
    H = np.asarray(data.H)[:, :, sel]
    span = f"in the band {band[0]:g}-{band[1]:g} Hz"
    if band[1] > MAX_HZ:
        raise FRFError(f"band {band[0]:g}-{band[1]:g} Hz: expected an upper edge of at most "
                       f"{MAX_HZ:g} Hz (structural FRFs; above it the powers of the "
                       "frequency that the fits use overflow)")  # fmt: skip
    if band[1] > MAX_SPAN * band[0]:
        raise FRFError(f"band {band[0]:g}-{band[1]:g} Hz: expected an upper edge at most "
                       f"{MAX_SPAN:g} times the lower (the subspace method maps the band about "
                       "its geometric centre; wider, the round-off swamps the modes)")
    size = np.abs(H)
    bad = ~np.isfinite(H) | (size > MAX_ABS) | ((size < 1 / MAX_ABS) & (size > 0))
    if bad.any():
        o, i, k = (int(x) for x in np.argwhere(bad)[0])
        n = int(bad.sum())
        raise FRFError(f"output {data.outputs[o].label} / input {data.inputs[i].label} at "
                       f"{f[sel][k]:g} Hz: H is {complex(H[o, i, k])} ({n} such value"
                       f"{'s' if n > 1 else ''} {span}); expected finite complex values of "
                       f"magnitude {1 / MAX_ABS:g} to {MAX_ABS:g} (or 0): beyond that no FRF "
                       "is physical in any unit, and the channel scaling overflows")  # fmt: skip

    def named(kind: str, channels: tuple[Channel, ...], which: np.ndarray) -> str:
        """``output 4:3 is`` or ``outputs 4:3, 5:3 are`` (the first ten, then how many more;
        ``(every output)`` when all are)."""
        labels = [channels[k].label for k in np.flatnonzero(which)]
        more = f" and {len(labels) - 10} more" if len(labels) > 10 else ""
        every = f" (every {kind})" if which.all() and len(labels) > 1 else ""
        if len(labels) == 1:
            return f"{kind} {labels[0]} is"
        return f"{kind}s {', '.join(labels[:10])}{more}{every} are"

    zero_out = ~np.any(H != 0, axis=(1, 2))
    if zero_out.any():
        raise FRFError(f"{named('output', data.outputs, zero_out)} zero at every input and "
                       f"frequency {span}: a dead or unconnected sensor? expected measured "
                       "FRFs; remove the channel or fix the data")  # fmt: skip
    zero_in = ~np.any(H != 0, axis=(0, 2))
    if zero_in.any():
        raise FRFError(f"{named('input', data.inputs, zero_in)} zero at every output and "
                       f"frequency {span}: expected measured FRFs; remove the input or fix "
                       "the data")  # fmt: skip
    real = ~np.any(H.imag != 0, axis=(1, 2))
    if real.any():
        raise FRFError(f"{named('output', data.outputs, real)} real (no imaginary part) "
                       f"{span}: identification needs complex FRFs (magnitude and phase), "
                       "not magnitudes or real parts alone")  # fmt: skip


def fit_band(frequency_hz: np.ndarray, band: tuple[float, float],
             edge_lines: int = 2) -> tuple[float, float]:  # fmt: skip
    """The band, with an edge that lies at most ``edge_lines`` lines outside the data moved
    onto the data's end (a :class:`~femcal.errors.FemcalWarning` says so): universal files
    store the frequency step in single precision, so an axis meant to end at 1000 Hz may end
    at 999.9974.

    Raises
    ------
    ValueError
        For a band that is not 0 <= f_lo < f_hi, finite.
    FRFError
        For an edge farther outside the data.
    """
    f = np.asarray(frequency_hz, float)
    lo, hi = float(band[0]), float(band[1])
    if not (lo < hi) or lo < 0 or not np.isfinite(hi):
        raise ValueError(f"band {lo:g}-{hi:g} Hz: expected 0 <= f_lo < f_hi, finite")
    step = float(np.median(np.diff(f))) if len(f) > 1 else 0.0
    slack = edge_lines * step
    if lo < f[0] * (1 - 1e-12) and lo >= f[0] - slack:
        warnings.warn(FemcalWarning(f"band edge {lo:g} Hz lies {f[0] - lo:.3g} Hz below the "
                                    f"data's first line ({f[0]:.6g} Hz): identified from "
                                    f"{f[0]:.6g} Hz"), stacklevel=3)  # fmt: skip
        lo = float(f[0])
    if hi > f[-1] * (1 + 1e-12) and hi <= f[-1] + slack:
        warnings.warn(FemcalWarning(f"band edge {hi:g} Hz lies {hi - f[-1]:.3g} Hz above the "
                                    f"data's last line ({f[-1]:.6g} Hz): identified up to "
                                    f"{f[-1]:.6g} Hz"), stacklevel=3)  # fmt: skip
        hi = float(f[-1])
    if lo < f[0] * (1 - 1e-12) or hi > f[-1] * (1 + 1e-12):
        raise FRFError(f"band {lo:g}-{hi:g} Hz lies outside the data ({f[0]:.6g}-"
                       f"{f[-1]:.6g} Hz, {len(f)} lines every {step:.4g} Hz)")  # fmt: skip
    return lo, hi


#: A CMIF peak at most this share of the edge's frequency outside the band is a mode the
#: edge cuts (:func:`edge_modes`).
EDGE_REACH = 0.05
#: The CMIF rising by this factor over the last :data:`EDGE_REACH` of a band that ends with
#: the data: a mode lies just above the data.
EDGE_RISE = 1.5


def edge_modes(data: FRFData, band: tuple[float, float]
               ) -> tuple[tuple[float, float], list[str]]:  # fmt: skip
    """The band moved out past the modes its edges cut, and what was done, in words.

    A mode just outside the band (a CMIF peak within :data:`EDGE_REACH` of an edge) reaches
    into it with its flank, which the residual poles stand for poorly: the fit suffers at
    the channels that see that mode most, which then look suspect, and a band a little
    different gives other numbers. Such an edge is moved out to the CMIF's valley beyond the
    peak, so the mode is fitted with the others. A band that ends with the data where the
    CMIF still rises (by :data:`EDGE_RISE` over its last :data:`EDGE_REACH` share) has
    a mode just above the data, which cannot be fitted: that is said, with the valley to end
    the band in instead."""
    f_all = np.asarray(data.frequency_hz, float)
    lo, hi = band
    span = (f_all >= lo * (1 - 2 * EDGE_REACH)) & (f_all <= hi * (1 + 2 * EDGE_REACH)) \
        & (f_all > 0)
    if span.sum() < 64:
        return band, []
    f = f_all[span]
    H = Layout.of(data.outputs, data.inputs).canonical(np.asarray(data.H)[:, :, span])
    so, si = _scales(H)
    S0 = cmif(H / so[:, None, None] / si[None, :, None])[0]
    peaks = find_cmif_peaks(f, S0[None, :]).frequency_hz
    notes = []
    new_lo, new_hi = lo, hi
    above = [p for p in peaks if hi < p <= hi * (1 + EDGE_REACH)]
    if above:
        beyond = f > max(above)
        if beyond.any():
            new_hi = float(f[beyond][np.argmin(S0[beyond])])
            notes.append(f"a mode at {max(above):.2f} Hz lies just above the band's top "
                         f"({hi:g} Hz): the band is widened to {new_hi:g} Hz, the CMIF's "
                         "valley beyond it, so that it is fitted rather than left to the "
                         "residual terms")  # fmt: skip
    below = [p for p in peaks if lo * (1 - EDGE_REACH) <= p < lo]
    if below:
        before = f < min(below)
        if before.any():
            new_lo = float(f[before][np.argmin(S0[before])])
            notes.append(f"a mode at {min(below):.2f} Hz lies just below the band's bottom "
                         f"({lo:g} Hz): the band is widened to {new_lo:g} Hz, the CMIF's "
                         "valley below it")  # fmt: skip
    step = float(np.median(np.diff(f)))
    top = (f >= hi * (1 - EDGE_REACH)) & (f <= hi + 0.5 * step)
    if not above and hi >= f_all[-1] - 0.5 * step and top.sum() > 8:
        k = np.argmin(S0[top])
        if S0[top][-1] > EDGE_RISE * S0[top][k] and f[top][k] < f[top][-1]:
            near = (f >= hi * (1 - 2 * EDGE_REACH)) & (f <= hi)  # where to end instead
            valley = float(f[near][np.argmin(S0[near])])
            notes.append(f"the CMIF rises {S0[top][-1] / S0[top][k]:.2g} times over the band's "
                         f"last {100 * EDGE_REACH:g} %, to the data's end ({hi:g} Hz): a mode "
                         "lies just above the data, where it cannot be fitted, and the "
                         "channels that see it most fit worse; end the band in the valley at "
                         f"{valley:.4g} Hz")  # fmt: skip
    return (new_lo, new_hi), notes


def coherence_weights(coherence: np.ndarray | None) -> np.ndarray | None:
    """Per channel and frequency weights ``sqrt(coh / (1 - coh))`` (capped at
    :data:`MAX_COHERENCE_WEIGHT`), normalised to a median of 1 over the lines with a
    weight; None without a coherence (or with one that is 0 throughout, with a warning)."""
    if coherence is None:
        return None
    c = np.clip(np.asarray(coherence, float), 0.0, 1.0)
    cap = MAX_COHERENCE_WEIGHT**2 / (1 + MAX_COHERENCE_WEIGHT**2)
    c = np.minimum(c, cap)
    w = np.sqrt(c / (1.0 - c))
    positive = w[w > 0]
    if positive.size == 0:
        warnings.warn(FemcalWarning("the coherence is 0 at every line of the band: it is not "
                                    "used as a weight"), stacklevel=3)  # fmt: skip
        return None
    return w / np.median(positive)


def _dedupe(found: list[tuple[complex, tuple[float, float]]], s: Settings) -> np.ndarray:
    """Poles found in several parts kept once: the one farthest (relatively) from its part's
    edges; poles of different parts within the stability tolerances of each other count as
    one (poles of one part are its diagram's distinct columns: close modes stay)."""
    def margin(item):
        pole, (lo, hi) = item
        f = abs(pole) / (2 * np.pi)
        return min(f / lo - 1.0, 1.0 - f / hi)

    kept: list[tuple[complex, tuple[float, float]]] = []
    for item in sorted(found, key=margin, reverse=True):
        f, z = poles_to_modal(np.array([item[0]]))
        same = False
        for other in kept:
            if other[1] == item[1]:  # one part's columns are distinct modes already
                continue
            fo, zo = poles_to_modal(np.array([other[0]]))
            if (abs(f[0] / fo[0] - 1) < 0.5 * s.tol_frequency
                    and abs(z[0] - zo[0]) < s.tol_damping * max(z[0], zo[0])):  # fmt: skip
                same = True
                break
        if not same:
            kept.append(item)
    poles = np.array([k[0] for k in kept], complex)
    return poles[np.argsort(np.abs(poles))]


@dataclass(frozen=True)
class _Prepared:
    """The data as identification sees them: canonical layout, the band's frequencies,
    scaled FRFs and their scales, weights, the CMIF and its peaks."""

    layout: Layout
    f: np.ndarray
    Hs: np.ndarray
    so: np.ndarray
    si: np.ndarray
    weights: np.ndarray | None
    S: np.ndarray
    peaks: Peaks


def identify(data: FRFData, band: tuple[float, float], *,
             splits: Sequence[float] | None = None,
             orders: int | Sequence[int | None] | None = None,
             settings: Settings | None = None,
             progress: Callable[[str], None] | None = None,
             pool: Executor | None = None) -> IdentifiedModel:  # fmt: skip
    """Identify a continuous-time model of ``data`` over ``band`` (see the module docstring).

    Parameters
    ----------
    data : FRFs (p outputs, m inputs, K frequencies), in any layout.
    band : (f_lo, f_hi) Hz.
    splits : frequencies inside the band where it is split into parts; None: chosen from
        the CMIF (:mod:`femcal.identify.indicators`); ``()``: one part.
    orders : the model order of every part (one number), of each part (a list; None for
        automatic), or None: automatic for all (stabilisation diagrams).
    progress : called with a line of text per step.
    pool : an executor (e.g. a Dask cluster's, :mod:`femcal.parallel.cluster`) on which the
        parts are identified side by side; None: one after another here. A worker's BLAS
        may round differently from this process's: the poles agree to the last digits.

    Raises
    ------
    FRFError
        For data that cannot be identified over the band (:func:`check_band_data`), a band
        outside the data, a part with fewer than 4 frequencies, or an order a part's
        frequencies cannot support.
    ValueError
        For a band that is not 0 <= f_lo < f_hi, splits outside the band, or an order list
        of the wrong length.
    """
    s = settings or Settings()
    say = progress or (lambda _msg: None)
    lo, hi = fit_band(data.frequency_hz, band, s.edge_lines)
    if lo == 0:  # a band from 0 Hz starts at the first line above it (DC is left out)
        above = np.asarray(data.frequency_hz)[np.asarray(data.frequency_hz) > 0]
        if len(above) == 0 or above[0] > hi:
            raise FRFError(f"band 0-{hi:g} Hz holds no frequency above 0 Hz")
        lo = float(above[0])
        say(f"the band starts at {lo:g} Hz, the first line above 0 Hz (the DC line is not "
            "used)")  # fmt: skip
    check_band_data(data, (lo, hi))  # before any use of the data
    (lo, hi), edge_notes = edge_modes(data, (lo, hi))
    for note in edge_notes:
        say(note)
    prep = _prepare(data, (lo, hi), s)
    lo = max(lo, float(prep.f[0]))
    if splits is None:
        edges = [lo, *partition(prep.f, prep.S[0], prep.peaks.frequency_hz, (lo, hi),
                                s.part_modes), hi]  # fmt: skip
    else:
        edges = [lo, *(float(x) for x in splits), hi]
        if any(not (lo < x < hi) for x in edges[1:-1]):
            raise ValueError(f"splits {list(splits)} must lie inside the band {lo:g}-{hi:g} Hz")
        if any(b <= a for a, b in itertools.pairwise(edges)):
            raise ValueError(f"splits {list(splits)}: expected increasing frequencies, each "
                             "once")  # fmt: skip
    n_parts = len(edges) - 1
    if orders is None or isinstance(orders, int):
        part_orders: list[int | None] = [orders] * n_parts
    else:
        part_orders = list(orders)
        if len(part_orders) != n_parts:
            raise ValueError(f"{len(part_orders)} orders for {n_parts} parts")
    say(f"{prep.layout.describe()}")
    for a, b in noisy_regions(prep.f, prep.S):
        say(f"{a:.4g}-{b:.4g} Hz: the CMIF scatters like noise from line to line (a noise "
            "floor?): a peak there counts only if it stands far out of it")  # fmt: skip
    say(f"{len(prep.peaks.frequency_hz)} peaks in the CMIF"
        + (": " + ", ".join(f"{x:.4g}" for x in prep.peaks.frequency_hz[:30]) + " Hz"
           if len(prep.peaks.frequency_hz) else "")
        + (f"; parts split at {', '.join(f'{x:.4g}' for x in edges[1:-1])} Hz"
           if splits is None and n_parts > 1 else ""))  # fmt: skip
    consistency = consistency_error(prep.Hs)
    odd = outliers(consistency, s.suspect_factor, s.suspect_floor)
    use = np.ones(len(odd), bool)
    result = _identify_pass(data, prep, edges, part_orders, use, s, say, pool)
    roving = prep.layout.roving
    if odd.any() and (~odd).sum() >= 2:
        # a channel the others do not explain is either broken, or the one sensor that sees
        # some mode: identify without such channels too, and keep the model that fits the
        # other channels better
        bad = [roving[i].label for i in np.flatnonzero(odd)]
        say(f"channels {', '.join(bad)} are not consistent with the others (leave-one-out "
            "error " + ", ".join(f"{e:.2f}" for e in consistency[odd])
            + "): identifying without them as well")  # fmt: skip
        screened = _identify_pass(data, prep, edges, part_orders, ~odd, s, say, pool)
        # the model without them is kept unless the others fit clearly better with them:
        # poles that only the odd channels carry are what a channel from another
        # measurement, or a mode only one sensor sees, would bring, and the odd channels'
        # own fit error then tells which
        if np.median(screened.fit_error[~odd]) <= 1.02 * np.median(result.fit_error[~odd]):
            say("the model without them fits the other channels as well: kept")
            result, use = screened, ~odd
        else:
            say("the model of all channels fits the others better: kept")
    result = replace(result, consistency=consistency)
    if s.exclude_suspects and (result.suspect & use).any() and (~result.suspect).sum() >= 2:
        bad = [roving[i].label for i in np.flatnonzero(result.suspect)]
        say(f"suspect channels {', '.join(bad)}: identified again without them")
        again = _identify_pass(data, prep, edges, part_orders, ~result.suspect, s, say, pool)
        if np.median(again.fit_error[~result.suspect]) <= np.median(
                result.fit_error[~result.suspect]):  # fmt: skip
            result = replace(again, consistency=consistency,
                             suspect=again.suspect | result.suspect)  # fmt: skip
        else:
            say("the other channels fit better with them: the first model kept")
    return _with_warnings(result, prep, s, edge_notes)


def _prepare(data: FRFData, band: tuple[float, float], s: Settings) -> _Prepared:
    """The band's data in the canonical layout, scaled, with weights and CMIF peaks."""
    lo, hi = band
    check_band_data(data, (lo, hi))
    f_all = np.asarray(data.frequency_hz, float)
    sel = (f_all >= lo) & (f_all <= hi) & (f_all > 0)
    f = f_all[sel]
    if len(f) < 4:
        raise FRFError(f"band {lo:g}-{hi:g} Hz holds {len(f)} frequencies above 0 Hz; "
                       "expected at least 4")  # fmt: skip
    layout = Layout.of(data.outputs, data.inputs)
    H = layout.canonical(np.asarray(data.H)[:, :, sel])
    so, si = _scales(H)
    Hs = H / so[:, None, None] / si[None, :, None]
    weights = None
    if data.coherence is not None:
        coh = np.asarray(data.coherence, float)[..., sel]
        w = coherence_weights(coh if coh.ndim == 2 else layout.canonical(coh))
        if w is not None and w.ndim == 3:  # per FRF: per canonical row, over the references
            weights = np.mean(w, axis=1)
        elif w is not None:  # a multiple coherence of the outputs
            weights = w if not layout.transposed else np.broadcast_to(
                np.mean(w, axis=0), (Hs.shape[0], len(f))).copy()  # fmt: skip
    m = Hs.shape[1]
    if m > 1 and s.method == "plscf":
        sv = np.linalg.svd(np.moveaxis(Hs, 1, 0).reshape(m, -1), compute_uv=False)
        if sv[-1] < 1e-6 * sv[0]:
            warnings.warn(FemcalWarning(
                f"the {m} references ({', '.join(c.label for c in layout.references)}) are "
                "linearly dependent (one is a combination of the others to 1e-6: the same "
                "point measured twice?): pLSCF's fraction cannot separate them; give them once "
                "or use the subspace method"), stacklevel=3)  # fmt: skip
    S = cmif(Hs)
    peaks = find_cmif_peaks(f, S)
    return _Prepared(layout, f, Hs, so, si, weights, S, peaks)


def _orders(s: Settings, n_peaks: int, m: int, K: int) -> range:
    """The orders of a part's stabilisation diagram: up to ``s.max_order`` or, by default,
    from the part's number of peaks; at most what its K frequencies support."""
    if s.method == "plscf":
        if s.max_order is not None:
            return range(1, min(s.max_order, _order_limit(s, K)) + 1)
        return plscf.orders_for(n_peaks, m, K)
    top = s.max_order if s.max_order is not None else max(24, 4 * n_peaks + 16)
    return range(2, min(top, _order_limit(s, K)) + 1, 2)


def _identify_part(f: np.ndarray, H: np.ndarray, weights: np.ndarray | None, a: float,
                   b: float, n: int | None, n_peaks: int, s: Settings
                   ) -> tuple[int, np.ndarray, Stabilization | None]:  # fmt: skip
    """One part's physical poles: its order (``n``, or the highest of the automatic
    stabilisation diagram, which is returned too) and poles, from its frequencies ``f`` (K,),
    FRFs ``H`` (p, m, K) and weights (p, K) in [a, b] Hz. The estimator sees the part scaled
    on its own (its poles do not depend on it)."""
    po, pi = _scales(H)
    Hp = H / po[:, None, None] / pi[None, :, None]
    resolution = float(np.median(np.diff(f))) if len(f) > 1 else 1.0
    p, m, K = Hp.shape
    if n is None:
        order_list = _orders(s, n_peaks, m, K)
        if len(order_list) < 4:
            raise FRFError(f"part {a:g}-{b:g} Hz: {K} frequencies and {p} channel(s) allow "
                           f"{len(order_list)} {s.method} order(s) (up to "
                           f"{order_list[-1]}); a stabilisation diagram needs 4 at least: "
                           "expected more frequencies in the band (or give --order)")
        if s.method == "plscf":
            raw = plscf.diagram_poles(f, Hp, order_list, weights=weights)
            sv = None
        else:
            raw, sv = subspace.diagram_poles(f, Hp, order_list, stable=s.stable)
        if not raw:
            raise FRFError(f"part {a:g}-{b:g} Hz: {K} frequencies and {p} channel(s) support "
                           "no model; expected more frequencies in the part")  # fmt: skip
        diagram = stable_columns(raw, (a, b), s.method, resolution, s.criteria, sv)
        return raw[-1][0], diagram.modes, diagram
    if s.method == "plscf":
        ne = plscf.normal_equations(f, Hp, int(n), weights=weights)
        est = plscf.estimate(ne, int(n))
        lam = est.poles
    else:
        basis = subspace.subspace_basis(f, Hp, subspace.default_block_rows(int(n), p))
        A, _ = subspace.model_of_order(basis, int(n), stable=s.stable)
        lam = np.linalg.eigvals(A)
    return int(n), lam[physical(lam, (a, b), s.zeta_max)], None


def _order_limit(s: Settings, K: int) -> int:
    """The highest order K frequencies support: pLSCF's polynomial order (K - 1) / 2, the
    subspace method's K / 2 states, within each method's cap."""
    if s.method == "plscf":
        return min(plscf.MAX_ORDER, max(1, (K - 1) // 2))
    return min(MAX_ORDER, K // 2)


def _identify_pass(data: FRFData, prep: _Prepared, edges: list[float],
                   part_orders: list[int | None], use: np.ndarray, s: Settings,
                   say: Callable[[str], None],
                   pool: Executor | None = None) -> IdentifiedModel:  # fmt: skip
    """One identification: poles and B from the roving channels in ``use`` (r,), C and D of
    every channel for those; the parts' poles on ``pool`` when given."""
    f, Hs = prep.f, prep.Hs
    Hu = Hs[use]
    wu = None if prep.weights is None else prep.weights[use]
    bands = list(zip(edges[:-1], edges[1:], part_orders, strict=True))
    masks = [(f >= a) & (f <= b) for a, b, _ in bands]
    for (a, b, n), ps in zip(bands, masks, strict=True):
        if ps.sum() < 4:
            raise FRFError(f"part {a:g}-{b:g} Hz holds {ps.sum()} frequencies; expected at "
                           "least 4")  # fmt: skip
        if n is not None:
            limit = _order_limit(s, int(ps.sum()))
            if not 1 <= int(n) <= limit:
                raise FRFError(f"order {int(n)} is outside 1..{limit} for part {a:g}-{b:g} "
                               f"Hz ({ps.sum()} frequencies)")  # fmt: skip
    pk = prep.peaks.frequency_hz
    args = [(f[ps], Hu[:, :, ps], None if wu is None else wu[:, ps], a, b, n,
             int(np.sum((pk >= a) & (pk <= b))), s)
            for (a, b, n), ps in zip(bands, masks, strict=True)]  # fmt: skip
    if pool is not None and len(bands) > 1:  # the parts are independent: side by side
        jobs = [pool.submit(_identify_part, *x) for x in args]
        done = (result_of(job, f"the identification of part {a:g}-{b:g} Hz")
                for job, (a, b, _) in zip(jobs, bands, strict=True))  # fmt: skip
    else:
        done = (_identify_part(*x) for x in args)
    parts: list[Part] = []
    found: list[tuple[complex, tuple[float, float]]] = []
    for (a, b, n), (n_use, lam, diagram) in zip(bands, done, strict=True):
        fr, z = poles_to_modal(lam)
        what = (f"orders up to {n_use}, {s.method}" if n is None
                else f"order {n_use}, {s.method}")  # fmt: skip
        say(f"part {a:g}-{b:g} Hz ({what}): "
            + (", ".join(f"{x:.2f} Hz ({100 * y:.2f} %)" for x, y in zip(fr, z, strict=True))
               or "no physical pole"))  # fmt: skip
        parts.append(Part((a, b), n_use, n is None, lam, diagram))
        found += [(complex(x), (a, b)) for x in lam]
    poles = _dedupe(found, s)
    lo, hi = edges[0], edges[-1]
    poles, extra = _add_missed_peaks(prep, poles, use, (lo, hi), s, say)
    parts += extra
    model, history, w = _fit(f, Hu, poles, (lo, hi), s, wu)
    weak = _weak_modes(model, f, Hu, prep.so[use], s)
    if weak.any():
        fr, z = poles_to_modal(poles[weak])
        say("left out as too weak to be a mode of the data (a peak below "
            f"{s.min_contribution:g} of the FRFs' level there, or below "
            f"{s.min_contribution_complex:g} with an MPC under 0.5): "
            + ", ".join(f"{x:.4g} Hz ({100 * y:.3g} %)" for x, y in zip(fr, z, strict=True)))
        poles = poles[~weak]
        model, history, w = _fit(f, Hu, poles, (lo, hi), s, wu)
    if not use.all():  # C and D of every channel for the B of the channels used
        sk = 2j * np.pi * f
        C, D = fit_c(Resolvent(model.A, sk), model.B, Hs, s.feedthrough, w)
        model = replace(model, C=C, D=D)
    say(f"whole band {lo:g}-{hi:g} Hz: {len(poles)} poles, B, C, D refined in "
        f"{len(history) - 1} alternating steps (cost {history[0]:.4g} -> {history[-1]:.4g})")
    return _result(data, prep, model, (lo, hi), parts, history, s)


def mode_contributions(model: FixedPoleModel, f: np.ndarray, H: np.ndarray,
                       scales: np.ndarray | None = None
                       ) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Per physical pole of a fitted model: its resonance peak ``||R|| / |Re(lambda)|``
    (R the residue matrix over the channels) over the measured level ``||H||`` at the
    nearest lines (the largest of three), and the MPC of its shape. A mode of the data
    rises to about the data's level at its frequency (1 when it dominates there); a pole
    the fit uses for noise or for a band edge stays far below. ``scales`` (p,) undo the
    channels' scaling for the MPC, which is a property of the shape in physical units."""
    k = len(model.poles)
    c = 0.5 * (model.C[:, 0: 2 * k: 2] - 1j * model.C[:, 1: 2 * k: 2])  # (p, k)
    b = model.B[0: 2 * k: 2] + 1j * model.B[1: 2 * k: 2]  # (k, m)
    peak = (np.linalg.norm(c, axis=0) * np.linalg.norm(b, axis=1)
            / np.maximum(np.abs(model.poles.real), np.finfo(float).tiny))  # fmt: skip
    level = np.linalg.norm(H, axis=(0, 1))
    at = np.searchsorted(f, np.abs(model.poles) / (2 * np.pi)).clip(1, len(f) - 2)
    near = np.max([level[at - 1], level[at], level[at + 1]], axis=0)
    shapes = c if scales is None else c * np.asarray(scales)[:, None]
    big = np.abs(shapes).max(axis=0)
    shapes = shapes / np.where(big > 0, big, 1.0)  # (the MPC squares them twice)
    return peak / np.where(near > 0, near, 1.0), mpc(shapes)


def _weak_modes(model: FixedPoleModel, f: np.ndarray, H: np.ndarray, scales: np.ndarray,
                s: Settings) -> np.ndarray:  # fmt: skip
    """(k,) poles too weak to be modes of the data (see :func:`mode_contributions`)."""
    if len(model.poles) == 0:
        return np.zeros(0, bool)
    ratio, shape_mpc = mode_contributions(model, f, H, scales)
    return (ratio < s.min_contribution) | ((ratio < s.min_contribution_complex)
                                           & (shape_mpc < 0.5))  # fmt: skip


def _frequency_weights(H: np.ndarray, weights: np.ndarray | None,
                       s: Settings) -> np.ndarray | None:  # fmt: skip
    """The least squares' weight of each frequency (K,): 1 / (RMS of |H| over the channels
    there) with :attr:`Settings.frequency_weighting`, times the channels' mean coherence
    weight where there is one."""
    w = None
    if s.frequency_weighting:
        level = np.sqrt(np.mean(np.abs(H) ** 2, axis=(0, 1)))
        floor = level[level > 0].min() if (level > 0).any() else 1.0
        w = 1.0 / np.where(level > 0, level, floor)
    if weights is not None:
        cw = np.mean(weights, axis=0)
        w = cw if w is None else w * cw
    return w


def _fit(f: np.ndarray, H: np.ndarray, poles: np.ndarray, band: tuple[float, float],
         s: Settings, weights: np.ndarray | None
         ) -> tuple[FixedPoleModel, list[float], np.ndarray | None]:  # fmt: skip
    """The fixed-pole model of ``poles`` and the band's residual poles fitted to H (the
    channels used), with its cost history and the frequency weights used."""
    w = _frequency_weights(H, weights, s)
    model, history = fit_fixed_poles(2j * np.pi * f, H, poles, _residual_poles(band, s),
                                     feedthrough=s.feedthrough, max_iter=s.max_iter,
                                     tol=s.tol, weights=w)  # fmt: skip
    return model, history, w


def _near(f_peak: float, poles: np.ndarray, resolution: float) -> bool:
    """Whether a pole lies near a peak: within three lines, a half-power bandwidth of its
    own, or half a percent."""
    if len(poles) == 0:
        return False
    fr, z = poles_to_modal(poles)
    reach = np.maximum.reduce([np.full(len(fr), 3 * resolution), 2 * z * fr,
                               np.full(len(fr), 0.005 * f_peak)])  # fmt: skip
    return bool(np.any(np.abs(fr - f_peak) <= reach))


def _add_missed_peaks(prep: _Prepared, poles: np.ndarray, use: np.ndarray,
                      band: tuple[float, float], s: Settings, say: Callable[[str], None]
                      ) -> tuple[np.ndarray, list[Part]]:  # fmt: skip
    """Each CMIF peak with no pole near it identified again in a narrow band around it (a
    tenth of its frequency, at least 40 lines, each side); the poles found there near the
    peak join the others."""
    f = prep.f
    resolution = float(np.median(np.diff(f)))
    extra: list[Part] = []
    added: list[complex] = []
    for fp in prep.peaks.frequency_hz:
        if _near(fp, poles, resolution) or _near(fp, np.array(added, complex), resolution):
            continue
        half = max(0.1 * fp, 40 * resolution)
        a, b = max(band[0], fp - half), min(band[1], fp + half)
        sel = (f >= a) & (f <= b)
        if sel.sum() < 8:
            continue
        n_peaks = int(np.sum((prep.peaks.frequency_hz >= a) & (prep.peaks.frequency_hz <= b)))
        wu = None if prep.weights is None else prep.weights[use][:, sel]
        try:
            _, lam, diagram = _identify_part(f[sel], prep.Hs[use][:, :, sel], wu, a, b, None,
                                             n_peaks, s)  # fmt: skip
        except (FRFError, np.linalg.LinAlgError):
            continue
        near = [x for x in lam if _near(fp, np.array([x]), resolution)
                and not _near(poles_to_modal(np.array([x]))[0][0], poles, resolution)]
        if near:
            best = min(near, key=lambda x: abs(abs(x) / (2 * np.pi) - fp))
            added.append(complex(best))
            fr, z = poles_to_modal(np.array([best]))
            say(f"peak at {fp:.4g} Hz had no pole: {fr[0]:.4g} Hz ({100 * z[0]:.3f} %) found "
                f"in {a:.4g}-{b:.4g} Hz")  # fmt: skip
            extra.append(Part((a, b), diagram.max_order if diagram else 0, True,
                              np.array([best]), diagram))  # fmt: skip
    if not added:
        return poles, extra
    allp = np.concatenate([poles, np.array(added, complex)])
    return allp[np.argsort(np.abs(allp))], extra


def _result(data: FRFData, prep: _Prepared, model: FixedPoleModel, band: tuple[float, float],
            parts: list[Part], history: list[float], s: Settings) -> IdentifiedModel:  # fmt: skip
    """The identified model in the data's layout and units, its modes and quality."""
    so, si, f, Hs, layout = prep.so, prep.si, prep.f, prep.Hs, prep.layout
    A, Bc, Cc, Dc = (model.A, model.B * si[None, :], model.C * so[:, None],
                     model.D * so[:, None] * si[None, :])  # fmt: skip
    canonical = StateSpace(A, Bc, Cc, Dc)
    system = (StateSpace(A.T, Cc.T, Bc.T, Dc.T) if layout.transposed else canonical)
    Hm = response(model, 2j * np.pi * f)
    err = np.sqrt(np.sum(np.abs(Hm - Hs) ** 2, axis=(1, 2)) / np.sum(np.abs(Hs) ** 2, axis=(1, 2)))
    suspect = outliers(err, s.suspect_factor, s.suspect_floor)
    k = len(model.poles)
    lam, V = np.linalg.eig(A[: 2 * k, : 2 * k])  # the physical states come first
    W = np.linalg.inv(V)
    up = np.flatnonzero(lam.imag > 0)
    up = up[np.argsort(lam[up].imag)]
    lam = lam[up]
    shapes = Cc[:, : 2 * k] @ V[:, up]
    part = W[up] @ Bc[: 2 * k]  # (k, m)
    big = np.argmax(np.abs(shapes), axis=0)
    norm = shapes[big, np.arange(len(up))]
    shapes = shapes / norm
    part = (part * norm[:, None]).T
    fr, z = poles_to_modal(lam)
    return IdentifiedModel(system, model.residual.copy(), lam, fr, z, shapes, part,
                           data.outputs, data.inputs, data.quantity, data.units, band, err,
                           suspect, parts, history, layout=layout, method=s.method,
                           mpc=mpc(shapes), mpd=mpd(shapes), complexity=complexity(shapes),
                           frf_correlation=frf_correlation(Hs, Hm),
                           peaks_hz=prep.peaks.frequency_hz)  # fmt: skip


def _with_warnings(model: IdentifiedModel, prep: _Prepared, s: Settings,
                   edge_notes: Sequence[str] = ()) -> IdentifiedModel:  # fmt: skip
    """The model with what it could not do said in words: CMIF peaks without a mode near
    them, a median fit error above :attr:`Settings.poor_fit`, no mode at all; and what
    :func:`edge_modes` did or found at the band's edges."""
    said: list[str] = list(edge_notes)
    resolution = float(np.median(np.diff(prep.f)))
    lost = [fp for fp in prep.peaks.frequency_hz if not _near(fp, model.poles, resolution)]
    if lost:
        said.append(f"{len(lost)} peak(s) of the CMIF have no identified mode: "
                    + ", ".join(f"{x:.4g}" for x in lost) + " Hz (weak, noise, or a mode "
                    "the estimator could not stabilise: look at the stabilisation diagram)")
    med = float(np.median(model.fit_error))
    if med > s.poor_fit:
        said.append(f"poor fit: median fit error {med:.3f} over the channels (above "
                    f"{s.poor_fit:g}); the model misses part of the data: try the other "
                    "method, more parts, a higher --max-order, or a narrower band")
    if len(model.poles) == 0:
        said.append("no mode identified in the band")
    for text in said:
        warnings.warn(FemcalWarning(f"identification {model.band[0]:g}-{model.band[1]:g} "
                                    f"Hz: {text}"), stacklevel=3)  # fmt: skip
    return replace(model, warnings=tuple(said))


def equalize_damping(model: IdentifiedModel, zeta0: float) -> IdentifiedModel:
    """The model with every physical pole's damping set to zeta0 and its imaginary part (the
    damped natural frequency) kept, residues unchanged: the test side of the damping
    equalisation.

    The residual poles are left as they are: they are not modes but stand, together with
    the feedthrough, for the modes outside the band, and their residues are fitted jointly
    with D (the far pole's contribution in the band is almost a constant), so changing
    their damping would undo that fit.
    """
    if not 0 <= zeta0 < 1:
        raise ValueError(f"zeta0 = {zeta0}: expected 0 <= zeta0 < 1")
    sysm = model.system
    phys = ~np.asarray(model.residual_states, bool)
    A = sysm.A.copy()
    if np.abs(A[np.ix_(phys, ~phys)]).max(initial=0) > 0 or np.abs(
            A[np.ix_(~phys, phys)]).max(initial=0) > 0:  # fmt: skip
        raise ValueError("equalize_damping needs the physical and residual states uncoupled")
    lam, V = np.linalg.eig(A[np.ix_(phys, phys)])
    cplx = np.abs(lam.imag) > 0
    new = lam.copy()
    new[cplx] = lam[cplx].imag * (-zeta0 / np.sqrt(1.0 - zeta0**2) * np.sign(lam[cplx].imag)
                                  + 1j)  # fmt: skip
    A[np.ix_(phys, phys)] = (V @ np.diag(new) @ np.linalg.inv(V)).real
    system = StateSpace(A, sysm.B, sysm.C, sysm.D)
    poles = model.poles.imag * (-zeta0 / np.sqrt(1.0 - zeta0**2) + 1j)
    fr, z = poles_to_modal(poles)
    return replace(model, system=system, poles=poles, frequency_hz=fr, damping_ratio=z)
