"""The regularised inverse of a rig's FRF, line by line: which drive makes the control
channels follow a target, and which drive directions they cannot see.

At each line ``f`` of a record's spectrum the drive ``D`` (n_drives,) that makes the
control channels' spectrum ``H D`` follow the target's ``T`` is the most probable one of
the linear Gaussian model (Tikhonov regularisation in its statistical form: Kaipio and
Somersalo, Statistical and Computational Inverse Problems, Springer 2005, sec. 3.3; over
frequency, Wiener deconvolution)::

    T = H D + N,     N ~ CN(0, diag(nu_c / w_c)),     D ~ CN(0, p I),

    D = A^-1 H^H W T,     A = H^H W H + I / p,     W = diag(w_c / nu_c),

solved as the least squares ``min |W^1/2 (T - H D)|^2 + |D|^2 / p`` by QR
(:class:`LineSolver`), never through ``A`` itself, whose condition is the square of theirs.

- ``nu_c`` is the target's noise floor per line (:func:`noise_floor`): measured where the
  drive makes no response, above its band, or given as a fraction of each channel's RMS
  (bounded so that no channel's weight runs away from the others', :func:`bounded_floor`).
- ``p`` is how much drive the data show at the line and around it (:func:`drive_prior`,
  empirical Bayes). A drive direction whose effect on the control channels stands clear
  of the noise is inverted plainly; one whose effect does not (accelerations fall as
  ``w^2`` at low frequency, and one combination of seven actuators on six rigid-body
  motions, the warp, may barely move the control channels) is held near zero instead of
  being amplified out of the noise. The prior is the same for every drive, so that
  directions no channel sees are left at the least drive.
- ``w_c`` weighs the control channels (mixed control: accelerations, LVDTs and load cells
  in one iteration); each channel's noise floor already puts it in its own units.
- ``effort`` adds ``effort^2`` times the largest eigenvalue of ``H^H W H`` to ``1 / p`` (a
  drive-effort penalty relative to the best-seen direction), and ``roll_off_hz`` adds
  ``(f_r / f)^4`` times it: below ``f_r`` the drive rolls off as behind a fourth-order
  high-pass (at ``f_r`` the best-seen direction keeps half its drive).

The directions the control channels cannot see at a line are those of the whitened FRF
``W^1/2 H p^1/2`` whose singular value is below one: the inverse keeps less than half of
their drive (:func:`unseen_directions`).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import pairwise

import numpy as np

#: Relative noise floor taken when the target has no lines to measure it on.
DEFAULT_FLOOR = 1e-4
#: The finest relative amplitude a target holds (double-precision sums of a record).
ROUND_OFF = 1e-6
#: Half-width of the band, relative to the frequency, over which the drive prior is taken.
PRIOR_BAND = 0.2
#: Fewest lines either side of a frequency in the band of its drive prior.
MIN_BAND_LINES = 8
#: Standard errors by which the drive's power must stand above the noise's to count.
PRIOR_SIGNIFICANCE = 3.0
#: How many times its noise-propagated variance a single line's drive power must be to
#: count on its own (noise alone exceeds 25 times its mean power once in 7e10 lines).
LINE_SIGNIFICANCE = 25.0
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


def bounded_floor(noise: NoiseFloor, Hf: np.ndarray, T: np.ndarray) -> NoiseFloor:
    """The noise floor bounded so that no channel's weight runs away from the others':

    - a channel with signal in the band: at least :data:`ROUND_OFF` squared of its mean
      power per line there (a target read from single precision or made in double holds
      nothing finer);
    - a quiet channel (no power in the band above its noise, such as one held at zero): at
      least :data:`DEFAULT_FLOOR` squared of the power the drive would make there, the
      drive sized line by line from the other channels (their target power over their
      summed FRF power), so that holding it still weighs like a channel measured to
      :data:`DEFAULT_FLOOR` of its response.

    ``Hf`` (n_lines, n_control, n_drives) and ``T`` (n_control, n_lines) on the band's lines.
    """
    if T.shape[1] == 0:
        return noise
    power = np.mean(np.abs(T) ** 2, axis=1)
    var = np.maximum(noise.variance, ROUND_OFF**2 * power)
    quiet = power <= 4 * var
    if quiet.any():
        loud = ~quiet
        gain = np.sum(np.abs(Hf) ** 2, axis=2)  # (n_lines, n_control)
        if loud.any():
            drive = np.sum(np.abs(T[loud]) ** 2, axis=0) / np.maximum(
                gain[:, loud].sum(axis=1), 1e-300)  # fmt: skip
            made = np.mean(gain[:, quiet] * drive[:, None], axis=0)
            var[quiet] = np.maximum(var[quiet], DEFAULT_FLOOR**2 * made)
        var = np.maximum(var, 1e-300)
    with np.errstate(divide="ignore", invalid="ignore"):  # the fraction of what is used
        fraction = np.where(var > noise.variance, noise.fraction * np.sqrt(
            var / np.where(noise.variance > 0, noise.variance, 1.0)), noise.fraction)  # fmt: skip
    return NoiseFloor(var, fraction, noise.source, noise.measured)


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


def least_squares_drive(Hf: np.ndarray, T: np.ndarray,
                        weight: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """(the least-squares drive (n_drives, n_lines), its variance per drive (n_drives,
    n_lines) under the whitened noise): ``min |W^1/2 (T - H D)|`` by QR of ``[W^1/2 H; r I]``
    with a ridge ``r`` of 1e-6 of the norm, and the diagonal of ``pinv(G) pinv(G)^H``, ``G =
    W^1/2 H`` (zero along directions no channel sees, where the drive is left at zero)."""
    _, n_out, n_in = Hf.shape
    G = np.sqrt(weight)[None, :, None] * Hf
    top = np.linalg.norm(G, axis=(1, 2))
    ridge = 1e-6 * np.where(top > 0, top, 1.0)
    M = np.concatenate([G, ridge[:, None, None] * np.eye(n_in)[None]], axis=1)
    Q, R = np.linalg.qr(M)
    Q1 = Q[:, :n_out]  # G = Q1 R
    rhs = np.sqrt(weight)[None, :] * T.T  # (n_lines, n_out)
    ls = np.linalg.solve(R, np.einsum("fmi,fm->fi", Q1.conj(), rhs)[..., None])[..., 0].T
    # the least-squares drive's covariance under unit whitened noise, X X^H with
    # X = R^-1 Q1^H (finite along directions no channel sees, where the drive is left at 0)
    X = np.linalg.solve(R, Q1.conj().transpose(0, 2, 1))
    var = np.sum(np.abs(X) ** 2, axis=2).T  # (n_in, n_lines)
    return ls, var


def drive_prior(Hf: np.ndarray, T: np.ndarray, weight: np.ndarray,
                f: np.ndarray) -> np.ndarray:  # fmt: skip
    """The drive's power per line p (n_drives, n_lines) that the target shows through the
    FRF ``Hf`` (n_lines, n_control, n_drives) at lines ``f`` (n_lines,) with ``T``
    (n_control, n_lines) and ``W = weight`` (n_control,), each drive's:

    - the least-squares drive's power as a band's median over ln 2 (+/- 20 % of the
      frequency, at least 8 lines either side), less the band's mean noise-propagated
      variance times ``1 + 3 / sqrt(lines in the band)``;
    - or a line's own power less that variance where it is more than
      :data:`LINE_SIGNIFICANCE` times it (a sine);

    then their mean over the drives, the same for each (an isotropic prior), floored at 1e-6
    of its largest. The least squares are solved by QR of ``W^1/2 H`` (with a ridge of 1e-6
    of its norm), not by normal equations, so that channels whose weights differ by many
    orders (a channel held at zero beside loud ones) keep their precision; the variance is
    that of the regularised least-squares drive, finite where fewer channels than drives
    leave directions unseen.
    """
    ls, var = least_squares_drive(Hf, T, weight)
    power = np.abs(ls) ** 2
    signal, lines = _band_statistic(power, f, "median")
    signal = signal / np.log(2)
    noise = _band_statistic(var, f, "mean")[0] * (1 + PRIOR_SIGNIFICANCE / np.sqrt(lines))
    # a line standing alone far above the noise (a sine, a sparse multisine) is a drive even
    # where its band's median is not
    alone = np.where(power > LINE_SIGNIFICANCE * var, power - var, 0.0)
    # one power for every drive at a line (their mean): a prior that favoured some actuators
    # would push the drive into them along directions the channels barely see
    p = np.broadcast_to(np.mean(np.maximum(signal - noise, alone), axis=0), power.shape)
    top = np.max(np.mean(signal, axis=0))
    return np.maximum(p, 1e-6 * (top if top > 0 else 1.0)).copy()


def _largest_eigenvalue(Hf: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """The largest eigenvalue of ``H^H W H`` per line (n_lines,): the squared largest
    singular value of ``W^1/2 H``."""
    G = np.sqrt(weight)[None, :, None] * Hf
    return np.linalg.svd(G, compute_uv=False)[:, 0] ** 2


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
        pen = pen + extra * _largest_eigenvalue(Hf, weight)
    return pen


def held_factor(Hf: np.ndarray, weight: np.ndarray, directions: np.ndarray,
                strength: float = 1e4) -> np.ndarray:  # fmt: skip
    """The factor ``C`` (n_lines, k, n_drives) of a penalty ``|C D|^2`` that holds drive
    ``directions`` (n_drives, k, orthonormal) near zero: ``strength`` times the largest
    eigenvalue of ``H^H W H`` on their projector, so that a drive along them costs that many
    times more than along the best-seen direction."""
    scale = np.sqrt(strength * _largest_eigenvalue(Hf, weight))
    return scale[:, None, None] * directions.T[None].astype(complex)


class LineSolver:
    """The Gauss-Newton step of each line's objective (see :func:`objective`): the least
    squares ``min |W^1/2 (E - H x)|^2 + |pen^1/2 (D + x)|^2 + |C (D + x)|^2`` solved by QR
    of the stacked ``[W^1/2 H; diag(pen)^1/2; C]`` (n_lines at once), so that the normal
    equations' squared condition never arises.

    Parameters
    ----------
    Hf : (n_lines, n_control, n_drives); weight : (n_control,) W; pen : (n_drives,
    n_lines); held : (n_lines, k, n_drives) C, or None.
    """

    def __init__(self, Hf: np.ndarray, weight: np.ndarray, pen: np.ndarray,
                 held: np.ndarray | None = None) -> None:  # fmt: skip
        self.n_out = Hf.shape[1]
        self.sqrt_w = np.sqrt(weight)
        self.sqrt_pen = np.sqrt(pen)
        self.held = held
        blocks = [self.sqrt_w[None, :, None] * Hf,
                  np.einsum("if,ij->fij", self.sqrt_pen, np.eye(Hf.shape[2]))]  # fmt: skip
        if held is not None:
            blocks.append(held)
        self.Q, self.R = np.linalg.qr(np.concatenate(blocks, axis=1).astype(complex))

    def step(self, E: np.ndarray, D: np.ndarray) -> np.ndarray:
        """The step x (n_drives, n_lines) from drive ``D`` with response error ``E``
        (n_control, n_lines)."""
        rhs = [(self.sqrt_w[:, None] * E).T, (-self.sqrt_pen * D).T]
        if self.held is not None:
            rhs.append(-np.einsum("fki,if->fk", self.held, D))
        b = np.einsum("fmi,fm->fi", self.Q.conj(), np.concatenate(rhs, axis=1))
        return np.linalg.solve(self.R, b[..., None])[..., 0].T


def objective(weight: np.ndarray, pen: np.ndarray, E: np.ndarray, D: np.ndarray,
              held: np.ndarray | None = None) -> np.ndarray:  # fmt: skip
    """The line's objective ``sum_c W_c |E_c|^2 + sum_j pen_j |D_j|^2 + |C D|^2``
    (n_lines,)."""
    out = weight @ np.abs(E) ** 2 + np.sum(pen * np.abs(D) ** 2, axis=0)
    if held is not None:
        out += np.sum(np.abs(np.einsum("fki,if->fk", held, D)) ** 2, axis=1)
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
