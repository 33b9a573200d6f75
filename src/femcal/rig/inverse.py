"""The regularised inverse of a rig's FRF, line by line: which drive makes the control
channels follow a target, and which drive directions they cannot see.

At each line ``f`` of a record's spectrum the drive ``D`` (n_drives,) that makes the
control channels' spectrum ``H D`` follow the target's ``T`` is the most probable one of
the linear Gaussian model (Tikhonov regularisation in its statistical form: Kaipio and
Somersalo, Statistical and Computational Inverse Problems, Springer 2005, sec. 3.3; over
frequency, Wiener deconvolution)::

    T = H D + N,     N ~ CN(0, diag(nu_c / w_c)),     D ~ CN(0, diag(p_j)),

    D = A^-1 H^H W T,     A = H^H W H + diag(1 / p_j),     W = diag(w_c / nu_c).

- ``nu_c`` is the target's noise floor per line (:func:`noise_floor`): measured where the
  drive makes no response, above its band, or given as a fraction of each channel's RMS.
- ``p_j`` is how much drive the data show at the line (:func:`drive_prior`, empirical
  Bayes): where the drive's effect on the control channels stands clear of the noise,
  ``p_j`` is its power and the inverse the plain one; where it does not (accelerations fall
  as ``w^2`` at low frequency, and one combination of seven actuators on six rigid-body
  motions, the warp, may barely move the control channels), ``p_j`` is small and that
  direction of the drive is held near zero instead of being amplified out of the noise.
- ``w_c`` weighs the control channels (mixed control: accelerations, LVDTs and load cells
  in one iteration); each channel's noise floor already puts it in its own units.
- ``effort`` adds ``effort^2`` times the largest eigenvalue of ``H^H W H`` to ``1 / p_j`` (a
  drive-effort penalty relative to the best-seen direction), and ``roll_off_hz`` adds
  ``(f_r / f)^4`` times it: below ``f_r`` the drive rolls off as behind a fourth-order
  high-pass (at ``f_r`` the best-seen direction keeps half its drive).

The directions the control channels cannot see at a line are those of the whitened FRF
``W^1/2 H diag(p)^1/2`` whose singular value is below one: the inverse keeps less than half
of their drive (:func:`unseen_directions`).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import pairwise

import numpy as np

#: Relative noise floor taken when the target has no lines to measure it on.
DEFAULT_FLOOR = 1e-4
#: Half-width of the band, relative to the frequency, over which the drive prior is taken.
PRIOR_BAND = 0.2
#: Fewest lines either side of a frequency in the band of its drive prior.
MIN_BAND_LINES = 8
#: Standard errors by which the drive's power must stand above the noise's to count.
PRIOR_SIGNIFICANCE = 3.0
#: Fewest lines above the drive band that measure a noise floor.
MIN_FLOOR_LINES = 32


@dataclass(frozen=True)
class NoiseFloor:
    """The target's noise per line of its spectrum.

    Attributes
    ----------
    variance : (n_control,) expected ``|N_c|^2`` of one line of ``numpy.fft.rfft`` of the
        record (white noise of RMS ``s`` over ``n`` samples: ``n s^2``).
    fraction : (n_control,) the noise's RMS over the whole record as a fraction of the
        channel's RMS.
    source : how it was found (the band it was measured in, or the fraction given).
    measured : True when measured on the target, False when given or assumed.
    """

    variance: np.ndarray
    fraction: np.ndarray
    source: str
    measured: bool


def noise_floor(T: np.ndarray, f: np.ndarray, band: tuple[float, float], n: int,
                size: np.ndarray, fraction: float | None = None) -> NoiseFloor:  # fmt: skip
    """The noise floor of a target's spectrum ``T`` (n_control, n_f) at ``f`` (n_f,) Hz, of a
    record of ``n`` samples whose channels' RMS are ``size`` (n_control,).

    With ``fraction`` given: white noise of that fraction of each channel's RMS. Else
    measured on the lines above the drive band (from the larger of 1.1 times its top and two
    lines above it, to 0.8 of the Nyquist frequency, below the anti-alias filter): the
    lower quartile of ``|T|^2`` over -ln(3/4) (a complex Gaussian line's ``|T|^2`` is
    exponential, its quantile q is -ln(1 - q) times its mean; the lower quartile keeps
    resonances and content above the band out as long as they fill less than three
    quarters of those lines). With fewer than :data:`MIN_FLOOR_LINES` there,
    :data:`DEFAULT_FLOOR` of each channel's RMS.
    """
    size = np.where(size > 0, size, 1.0)
    if fraction is None:
        step = f[1] - f[0] if len(f) > 1 else 1.0
        lo = max(1.1 * band[1], band[1] + 2 * step)
        lines = (f > lo) & (f < 0.8 * f[-1])
        if lines.sum() >= MIN_FLOOR_LINES:
            var = np.quantile(np.abs(T[:, lines]) ** 2, 0.25, axis=1) / -np.log(0.75)
            var = np.maximum(var, (1e-12 * size) ** 2 * n)
            frac = np.sqrt(var / n) / size
            return NoiseFloor(var, frac, f"measured on the target at {lo:.3g}-"
                              f"{0.8 * f[-1]:.3g} Hz, above the drive band", True)  # fmt: skip
        fraction = DEFAULT_FLOOR
        source = (f"not measurable (fewer than {MIN_FLOOR_LINES} lines above the drive band): "
                  f"taken as {fraction:g} of each channel's RMS")  # fmt: skip
    else:
        source = f"given: {fraction:g} of each channel's RMS, white"
    frac = np.full(len(size), float(fraction))
    return NoiseFloor(n * (frac * size) ** 2, frac, source, False)


def _band_statistic(x: np.ndarray, f: np.ndarray,
                    how: str) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """(each row of x (rows, n_f) as its median (``how="median"``) or mean over the band of
    +/- :data:`PRIOR_BAND` of each frequency, at least :data:`MIN_BAND_LINES` lines either
    side; the lines in each band (n_f,)), taken at 24 centres an octave and interpolated to
    ``f`` (ascending, > 0, evenly spaced)."""
    if len(f) < 2:
        return x.copy(), np.ones(len(f))
    step = f[1] - f[0]
    centres = np.geomspace(f[0], f[-1], max(2, int(24 * np.log2(f[-1] / f[0])) + 2))
    half = np.maximum(PRIOR_BAND * centres, MIN_BAND_LINES * step)
    lo = np.searchsorted(f, centres - half - 1e-9 * step)
    hi = np.maximum(np.searchsorted(f, centres + half + 1e-9 * step, side="right"), lo + 1)
    reduce = np.median if how == "median" else np.mean
    vals = np.stack([reduce(x[:, a:b], axis=1) for a, b in zip(lo, hi, strict=True)], axis=1)
    return (np.stack([np.interp(f, centres, v) for v in vals]),
            np.interp(f, centres, (hi - lo).astype(float)))  # fmt: skip


def drive_prior(Hf: np.ndarray, T: np.ndarray, weight: np.ndarray,
                f: np.ndarray) -> np.ndarray:  # fmt: skip
    """The drive's power per line p (n_drives, n_lines) that the target shows through the
    FRF ``Hf`` (n_lines, n_control, n_drives) at lines ``f`` (n_lines,) with ``T``
    (n_control, n_lines) and ``W = weight`` (n_control,): the least-squares drive's power,
    as a band's median over ln 2 (+/- 20 % of the frequency, at least 8 lines either
    side), less the band's mean noise-propagated variance
    ``[(H^H W H)^-1]_jj`` times ``1 + 3 / sqrt(lines in the band)``; floored at 1e-6 of its
    largest."""
    G = np.einsum("foi,o,foj->fij", Hf.conj(), weight, Hf)
    scale = np.real(np.trace(G, axis1=1, axis2=2))[:, None, None]
    eye = np.eye(G.shape[1])
    Ginv = np.linalg.inv(G + 1e-12 * np.where(scale > 0, scale, 1.0) * eye)
    ls = np.einsum("fij,fkj,k,kf->if", Ginv, Hf.conj(), weight, T)
    var = np.real(np.einsum("fii->if", Ginv))
    signal, lines = _band_statistic(np.abs(ls) ** 2, f, "median")
    signal = signal / np.log(2)
    noise = _band_statistic(var, f, "mean")[0] * (1 + PRIOR_SIGNIFICANCE / np.sqrt(lines))
    p = signal - noise
    top = np.max(signal, axis=1, keepdims=True)
    return np.maximum(p, 1e-6 * np.where(top > 0, top, 1.0))


def penalty(Hf: np.ndarray, weight: np.ndarray, prior: np.ndarray, f: np.ndarray, *,
            effort: float = 0.0, roll_off_hz: float = 0.0) -> np.ndarray:  # fmt: skip
    """The drive penalty per line (n_drives, n_lines): ``1 / p`` plus ``effort^2 + (f_r /
    f)^4`` times the largest eigenvalue of ``H^H W H`` (see the module docstring)."""
    pen = 1.0 / prior
    extra = np.zeros(len(f))
    if effort > 0:
        extra += effort**2
    if roll_off_hz > 0:
        extra += (roll_off_hz / f) ** 4
    if extra.any():
        G = np.einsum("foi,o,foj->fij", Hf.conj(), weight, Hf)
        pen = pen + extra * np.linalg.eigvalsh(G)[:, -1]
    return pen


def held_penalty(Hf: np.ndarray, weight: np.ndarray, directions: np.ndarray,
                 strength: float = 1e4) -> np.ndarray:  # fmt: skip
    """A penalty (n_lines, n_drives, n_drives) that holds drive ``directions`` (n_drives, k,
    orthonormal) near zero: ``strength`` times the largest eigenvalue of ``H^H W H`` on
    their projector, so that a drive along them costs that many times more than along the
    best-seen direction."""
    G = np.einsum("foi,o,foj->fij", Hf.conj(), weight, Hf)
    top = np.linalg.eigvalsh(G)[:, -1]
    P = directions @ directions.conj().T
    return strength * top[:, None, None] * P[None]


def solver(Hf: np.ndarray, weight: np.ndarray, pen: np.ndarray,
           coupled: np.ndarray | None = None) -> np.ndarray:  # fmt: skip
    """``A^-1 = (H^H W H + diag(pen) + coupled)^-1`` per line (n_lines, n_drives,
    n_drives); ``coupled`` (n_lines, n_drives, n_drives) a penalty across drives, or
    None."""
    A = np.einsum("foi,o,foj->fij", Hf.conj(), weight, Hf)
    idx = np.arange(A.shape[1])
    A[:, idx, idx] += pen.T
    if coupled is not None:
        A += coupled
    return np.linalg.inv(A)


def gradient(Hf: np.ndarray, weight: np.ndarray, pen: np.ndarray, E: np.ndarray,
             D: np.ndarray, coupled: np.ndarray | None = None) -> np.ndarray:  # fmt: skip
    """``H^H W E - (diag(pen) + coupled) D`` (n_drives, n_lines): the descent direction of
    the line's objective at drive ``D`` with response error ``E = T - response``."""
    g = np.einsum("foi,o,of->if", Hf.conj(), weight, E) - pen * D
    if coupled is not None:
        g -= np.einsum("fij,jf->if", coupled, D)
    return g


def objective(weight: np.ndarray, pen: np.ndarray, E: np.ndarray, D: np.ndarray,
              coupled: np.ndarray | None = None) -> np.ndarray:  # fmt: skip
    """The line's objective ``sum_c W_c |E_c|^2 + D^H (diag(pen) + coupled) D``
    (n_lines,)."""
    out = weight @ np.abs(E) ** 2 + np.sum(pen * np.abs(D) ** 2, axis=0)
    if coupled is not None:
        out += np.real(np.einsum("if,fij,jf->f", D.conj(), coupled, D))
    return out


@dataclass(frozen=True)
class UnseenBand:
    """Lines over which some drive directions are not seen above the target's noise.

    Attributes
    ----------
    low_hz, high_hz : the band.
    directions : the most directions unseen at one of its lines (of n_drives).
    pattern : (n_drives,) the weakest direction at the band's middle line, in drive units,
        the largest entry +1 (real parts after turning the largest entry real).
    """

    low_hz: float
    high_hz: float
    directions: int
    pattern: np.ndarray


def _whitened(Hf: np.ndarray, weight: np.ndarray, pen: np.ndarray) -> np.ndarray:
    """``W^1/2 H diag(1/pen)^1/2`` per line (n_lines, n_control, n_drives)."""
    return np.sqrt(weight)[None, :, None] * Hf / np.sqrt(pen).T[:, None, :]


def unseen_count(Hf: np.ndarray, weight: np.ndarray, pen: np.ndarray) -> np.ndarray:
    """How many drive directions (n_lines,) each line's whitened FRF has singular values
    below one for (more control channels than drives or not: the missing ones count)."""
    s = np.linalg.svd(_whitened(Hf, weight, pen), compute_uv=False)
    return (s < 1.0).sum(axis=1) + max(0, Hf.shape[2] - s.shape[1])


def runs(mask: np.ndarray, min_lines: int = 3) -> list[tuple[int, int]]:
    """The runs [a, b) of a line mask (n_lines,) at least ``min_lines`` long, gaps of up to
    two lines closed."""
    mask = mask.copy()
    idx = np.flatnonzero(mask)
    for a, b in pairwise(idx):
        if 1 < b - a <= 3:
            mask[a:b] = True
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(int), [0]])))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)
            if b - a >= min_lines]  # fmt: skip


def unseen_directions(Hf: np.ndarray, weight: np.ndarray, pen: np.ndarray, f: np.ndarray, *,
                      min_lines: int = 3) -> list[UnseenBand]:  # fmt: skip
    """The bands (runs of at least ``min_lines`` lines, gaps of up to two lines closed)
    where the whitened FRF ``W^1/2 H diag(1/pen)^1/2`` has singular values below one: the
    drive directions the inverse keeps less than half of."""
    if len(f) == 0:
        return []
    count = unseen_count(Hf, weight, pen)
    out = []
    for a, b in runs(count > 0, min_lines):
        mid = (a + b - 1) // 2
        v = np.linalg.svd(_whitened(Hf[mid : mid + 1], weight, pen[:, mid : mid + 1])[0])[2]
        v = v[-1].conj() / np.sqrt(pen[:, mid])
        k = int(np.argmax(np.abs(v)))
        v = (v * np.exp(-1j * np.angle(v[k]))).real
        v = v / v[k] if v[k] != 0 else v
        out.append(UnseenBand(float(f[a]), float(f[b - 1]), int(count[a:b].max()), v))
    return out


def direction_seen(Hf: np.ndarray, weight: np.ndarray, pen: np.ndarray,
                   direction: np.ndarray) -> np.ndarray:  # fmt: skip
    """How well the control channels see one drive direction (n_drives,) at each line
    (n_lines,): ``|W^1/2 H w|^2 / (w^H diag(pen) w)``, its signal over noise; below one the
    inverse keeps less than half of a drive along it."""
    w = np.asarray(direction, complex)
    gain = np.einsum("foi,i->fo", Hf, w)
    return (np.abs(gain) ** 2 @ weight) / np.real(np.abs(w) ** 2 @ pen)


def describe_pattern(pattern: np.ndarray, names: tuple[str, ...] | list[str]) -> str:
    """A direction of the drives as text: ``+1.00 V_front_left -0.98 V_rear_left ...``, the
    entries of at least 0.2 of the largest."""
    keep = [j for j in np.argsort(-np.abs(pattern).round(6), kind="stable")
            if abs(pattern[j]) >= 0.2 * np.abs(pattern).max()]
    return " ".join(f"{pattern[j]:+.2f} {names[j]}" for j in keep)
