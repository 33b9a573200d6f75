"""The reference study's identification workflow on top of the subspace method.

For a band [f_lo, f_hi] split into parts at chosen frequencies (e.g. 10-60, 60-100,
100-120 Hz):

1. Channels are scaled to unit RMS over the band (outputs and inputs), so that no sensor
   dominates the fits by its units or position; the scaling is undone at the end. Channels
   the others do not explain (:mod:`femcal.identify.channels`) may be broken, or the only
   sensors of some mode: the identification is run with and without them, and the model
   that fits the other channels better is kept.
2. Each part is identified by the frequency-domain subspace method
   (:mod:`femcal.identify.subspace`) at its order, given or the automatic order of its
   stabilisation diagram (:mod:`femcal.identify.stabilization`). Its physical poles are
   those inside the part with damping between 0 and ``zeta_max``, and with an automatic
   order only those at the diagram's physical modes.
3. The residual effect of modes outside a part is taken by extra fixed poles: one at
   ``gamma`` times the part's upper edge (gamma = 1.43), one far away at ``beta`` times it
   (beta = 100), and (femcal's addition, on by default, ``lower_residual``) one at the lower
   edge divided by gamma for the modes below; together with the feedthrough D they stand for
   the out-of-band modes, so the in-band residues are not bent to fit them.
4. The parts' physical poles are joined (a pole found in two parts is kept once, from the
   part where it lies farthest from the edges), and B, C, D of the joined model, with the
   residual poles of the whole band, are estimated over the whole band by linear least
   squares for the fixed poles, alternating B and (C, D) until the fit stops improving
   (:func:`femcal.identify.lsq.fit_fixed_poles`).

The result holds the real state-space model (residual states flagged), the physical poles
as frequency and damping ratio, the complex mode shapes at the outputs (C times the
eigenvectors, normalised to a largest component of 1), the fit error of every channel and
the channels whose fit is poor enough to suspect the sensor.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass, field, replace

import numpy as np

from ..parallel.cluster import result_of
from ..response.statespace import StateSpace, frequency_response, poles_to_modal
from ..testdata.data import Channel, FRFData, FRFError
from .channels import consistency_error, outliers
from .lsq import FixedPoleModel, Resolvent, fit_c, fit_fixed_poles, response
from .stabilization import Stabilization, physical_poles, poles_at_modes, stabilization
from .subspace import default_block_rows, model_of_order, subspace_basis

#: Highest model order of a part (and at most half its frequencies).
MAX_ORDER = 200
#: Largest band edge (Hz), largest ratio of the band's edges, and largest magnitude of a
#: nonzero FRF value (smallest: its inverse) that identification takes: bounds no
#: structural test comes near, inside which the scaling, the bilinear map about the band's
#: geometric centre and the powers of the frequency stay far from overflow and round-off.
MAX_HZ, MAX_SPAN, MAX_ABS = 1e9, 1e12, 1e100


@dataclass(frozen=True)
class Settings:
    """Identification options (defaults: the reference study's).

    gamma, beta : residual poles at gamma and beta times a band's upper edge.
    lower_residual : also a residual pole at the lower edge / gamma.
    residual_damping : damping ratio of the residual poles.
    feedthrough : estimate D. stable : reflect unstable subspace poles.
    zeta_max : poles damped more than this are not physical modes.
    max_order : highest order of the stabilisation diagrams (automatic orders).
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
    """

    gamma: float = 1.43
    beta: float = 100.0
    lower_residual: bool = True
    residual_damping: float = 0.05
    feedthrough: bool = True
    stable: bool = True
    zeta_max: float = 0.2
    max_order: int = 24
    max_iter: int = 50
    tol: float = 1e-7
    suspect_factor: float = 4.0
    suspect_floor: float = 0.1
    exclude_suspects: bool = True
    frequency_weighting: bool = True

    def __post_init__(self) -> None:
        """Refuse settings that make no sense (ValueError naming the setting and what is
        expected): the residual poles must lie outside the band (gamma > 1) and apart
        (beta > gamma), damping ratios between 0 and 1, orders and counts positive."""
        checks = [
            (self.gamma > 1, "gamma", self.gamma, "a number above 1 (the residual poles sit "
             "at gamma times the upper band edge and the lower edge / gamma, outside the "
             "band)"),
            (self.beta > self.gamma, "beta", self.beta, f"a number above gamma = {self.gamma} "
             "(the far residual pole sits at beta times the upper band edge)"),
            (0 < self.residual_damping < 1, "residual_damping", self.residual_damping,
             "a damping ratio between 0 and 1"),
            (0 < self.zeta_max <= 1, "zeta_max", self.zeta_max, "a damping ratio in (0, 1]"),
            (2 <= self.max_order <= MAX_ORDER, "max_order", self.max_order,
             f"a whole number from 2 to {MAX_ORDER}"),
            (self.max_iter >= 1, "max_iter", self.max_iter, "at least 1"),
            (self.tol > 0, "tol", self.tol, "a positive number"),
            (self.suspect_factor > 0, "suspect_factor", self.suspect_factor, "a positive number"),
            (self.suspect_floor >= 0, "suspect_floor", self.suspect_floor, "0 or more"),
        ]
        for ok, name, value, expected in checks:
            if not (ok and np.isfinite(value)):
                raise ValueError(f"identification setting {name} = {value!r}: expected "
                                 f"{expected}")  # fmt: skip


@dataclass(frozen=True)
class Part:
    """One part of the band: its limits (Hz), the order used, whether it was chosen
    automatically, its physical poles, and its stabilisation diagram (if computed)."""

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
    system : real state-space model, H(s) = C (sI - A)^-1 B + D in the data's units.
    residual_states : (n,) True for the states of residual poles.
    poles : (k,) physical poles (Im > 0), ascending frequency, rad/s.
    frequency_hz, damping_ratio : (k,).
    shapes : (p, k) complex mode shapes at the outputs, largest component 1.
    participation : (m, k) complex modal participation of the inputs (V^-1 B rows),
        scaled with the shapes' normalisation so ``shape participation^T`` is the residue.
    outputs, inputs, quantity, units : as the data's.
    band : (f_lo, f_hi) Hz.
    fit_error : (p,) per output channel, ``||H - H_model|| / ||H||`` over the band.
    suspect : (p,) channels whose fit is poor, or that the other channels do not explain
        (see :class:`Settings` and :mod:`femcal.identify.channels`).
    consistency : (p,) leave-one-out consistency error of each channel.
    parts : the parts identified.
    history : cost of the whole-band fit after each alternating step (scaled data).
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


def _dedupe(found: list[tuple[complex, tuple[float, float]]]) -> np.ndarray:
    """Poles found in several parts kept once: the one farthest (relatively) from its part's
    edges; poles closer than 0.5 % in frequency and 20 % in damping count as one."""
    def margin(item):
        pole, (lo, hi) = item
        f = abs(pole) / (2 * np.pi)
        return min(f / lo - 1.0, 1.0 - f / hi)

    kept: list[tuple[complex, tuple[float, float]]] = []
    for item in sorted(found, key=margin, reverse=True):
        f, z = poles_to_modal(np.array([item[0]]))
        same = False
        for other in kept:
            fo, zo = poles_to_modal(np.array([other[0]]))
            if abs(f[0] / fo[0] - 1) < 0.005 and abs(z[0] / zo[0] - 1) < 0.2:
                same = True
                break
        if not same:
            kept.append(item)
    poles = np.array([k[0] for k in kept], complex)
    return poles[np.argsort(np.abs(poles))]


def identify(data: FRFData, band: tuple[float, float], *,
             splits: Sequence[float] = (), orders: int | Sequence[int | None] | None = None,
             settings: Settings | None = None,
             progress: Callable[[str], None] | None = None,
             pool: Executor | None = None) -> IdentifiedModel:  # fmt: skip
    """Identify a continuous-time model of ``data`` over ``band`` (see the module docstring).

    Parameters
    ----------
    data : FRFs (p outputs, m inputs, K frequencies).
    band : (f_lo, f_hi) Hz.
    splits : frequencies inside the band where it is split into parts.
    orders : the model order of every part (one number), of each part (a list; None for
        automatic), or None: automatic for all (stabilisation diagram up to
        ``settings.max_order``).
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
        For a band that is not 0 < f_lo < f_hi, splits outside the band, or an order list of
        the wrong length.
    """
    s = settings or Settings()
    say = progress or (lambda _msg: None)
    f_all = np.asarray(data.frequency_hz, float)
    lo, hi = float(band[0]), float(band[1])
    if not (lo < hi) or lo <= 0 or not np.isfinite(hi):
        raise ValueError(f"band {lo}-{hi} Hz: expected 0 < f_lo < f_hi, finite")
    if lo < f_all[0] * (1 - 1e-12) or hi > f_all[-1] * (1 + 1e-12):
        raise FRFError(f"band {lo}-{hi} Hz lies outside the data ({f_all[0]}-{f_all[-1]} Hz)")
    edges = [lo, *sorted(float(x) for x in splits), hi]
    if any(not (lo < x < hi) for x in edges[1:-1]):
        raise ValueError(f"splits {list(splits)} must lie inside the band {lo}-{hi} Hz")
    n_parts = len(edges) - 1
    if orders is None or isinstance(orders, int):
        part_orders: list[int | None] = [orders] * n_parts
    else:
        part_orders = list(orders)
        if len(part_orders) != n_parts:
            raise ValueError(f"{len(part_orders)} orders for {n_parts} parts")
    check_band_data(data, (lo, hi))
    sel = (f_all >= lo) & (f_all <= hi)
    f = f_all[sel]
    so, si = _scales(data.H[:, :, sel])
    Hs = data.H[:, :, sel] / so[:, None, None] / si[None, :, None]
    consistency = consistency_error(Hs)
    odd = outliers(consistency, s.suspect_factor, s.suspect_floor)
    use = np.ones(len(odd), bool)
    result = _identify_pass(data, f, Hs, so, si, edges, part_orders, use, s, say, pool)
    if odd.any() and (~odd).sum() >= 2:
        # a channel the others do not explain is either broken, or the one sensor that sees
        # some mode: identify without such channels too, and keep the model that fits the
        # other channels better
        bad = [data.outputs[i].label for i in np.flatnonzero(odd)]
        say(f"channels {', '.join(bad)} are not consistent with the others (leave-one-out "
            "error " + ", ".join(f"{e:.2f}" for e in consistency[odd])
            + "): identifying without them as well")  # fmt: skip
        screened = _identify_pass(data, f, Hs, so, si, edges, part_orders, ~odd, s, say,
                                  pool)
        if np.median(screened.fit_error[~odd]) < np.median(result.fit_error[~odd]):
            say("the model without them fits the other channels better: kept")
            result, use = screened, ~odd
        else:
            say("the model of all channels fits the others as well: kept")
    result = replace(result, consistency=consistency)
    if s.exclude_suspects and (result.suspect & use).any() and (~result.suspect).sum() >= 2:
        bad = [data.outputs[i].label for i in np.flatnonzero(result.suspect)]
        say(f"suspect channels {', '.join(bad)}: identified again without them")
        again = _identify_pass(data, f, Hs, so, si, edges, part_orders, ~result.suspect, s,
                               say, pool)  # fmt: skip
        if np.median(again.fit_error[~result.suspect]) <= np.median(
                result.fit_error[~result.suspect]):  # fmt: skip
            result = replace(again, consistency=consistency,
                             suspect=again.suspect | result.suspect)  # fmt: skip
        else:
            say("the other channels fit better with them: the first model kept")
    return result


def _identify_part(f: np.ndarray, H: np.ndarray, a: float, b: float, n: int | None,
                   s: Settings) -> tuple[int, np.ndarray, Stabilization | None]:
    """One part's physical poles: its order (``n``, or automatic from a stabilisation
    diagram, which is returned too) and poles, from its frequencies ``f`` (K,) and FRFs
    ``H`` (p, m, K) in [a, b] Hz. The subspace step sees the part scaled on its own (its
    poles do not depend on it)."""
    po, pi = _scales(H)
    Hp = H / po[:, None, None] / pi[None, :, None]
    if n is None:
        diagram = stabilization(f, Hp, (a, b), orders=range(2, s.max_order + 1, 2),
                                zeta_max=s.zeta_max, stable_system=s.stable)  # fmt: skip
        n_use = diagram.auto_order
        at = next(op for op in diagram.orders if op.order == n_use)
        return n_use, at.poles[poles_at_modes(at, diagram.modes_hz)], diagram
    basis = subspace_basis(f, Hp, default_block_rows(int(n), H.shape[0]))
    A, C = model_of_order(basis, int(n), stable=s.stable)
    lam, _ = physical_poles(A, C, (a, b), s.zeta_max)
    return int(n), lam, None


def _identify_pass(data: FRFData, f: np.ndarray, Hs: np.ndarray, so: np.ndarray,
                   si: np.ndarray, edges: list[float], part_orders: list[int | None],
                   use: np.ndarray, s: Settings, say: Callable[[str], None],
                   pool: Executor | None = None) -> IdentifiedModel:  # fmt: skip
    """One identification: poles and B from the channels in ``use`` (p,), C and D of every
    channel for those; the parts' poles on ``pool`` when given."""
    Hu = Hs[use]
    found: list[tuple[complex, tuple[float, float]]] = []
    parts: list[Part] = []
    bands = list(zip(edges[:-1], edges[1:], part_orders, strict=True))
    masks = [(f >= a) & (f <= b) for a, b, _ in bands]
    for (a, b, n), ps in zip(bands, masks, strict=True):
        if ps.sum() < 4:
            raise FRFError(f"part {a:g}-{b:g} Hz holds {ps.sum()} frequencies; expected at "
                           "least 4")  # fmt: skip
        if n is not None:
            limit = min(MAX_ORDER, int(ps.sum()) // 2)
            if not 1 <= int(n) <= limit:
                raise FRFError(f"order {int(n)} is outside 1..{limit} for part {a:g}-{b:g} "
                               f"Hz ({ps.sum()} frequencies)")  # fmt: skip
    args = [(f[ps], Hu[:, :, ps], a, b, n, s) for (a, b, n), ps in zip(bands, masks, strict=True)]
    if pool is not None and len(bands) > 1:  # the parts are independent: side by side
        jobs = [pool.submit(_identify_part, *x) for x in args]
        done = (result_of(job, f"the identification of part {a:g}-{b:g} Hz")
                for job, (a, b, _) in zip(jobs, bands, strict=True))  # fmt: skip
    else:
        done = (_identify_part(*x) for x in args)
    for (a, b, n), (n_use, lam, diagram) in zip(bands, done, strict=True):
        fr, z = poles_to_modal(lam)
        say(f"part {a:g}-{b:g} Hz: order {n_use}{' (automatic)' if n is None else ''}, "
            + (", ".join(f"{x:.2f} Hz ({100 * y:.2f} %)" for x, y in zip(fr, z, strict=True))
               or "no physical pole"))  # fmt: skip
        parts.append(Part((a, b), n_use, n is None, lam, diagram))
        found += [(complex(x), (a, b)) for x in lam]
    poles = _dedupe(found)
    lo, hi = edges[0], edges[-1]
    sk = 2j * np.pi * f
    w = None
    if s.frequency_weighting:  # each frequency weighted by 1 / (RMS of |H| there)
        level = np.sqrt(np.mean(np.abs(Hu) ** 2, axis=(0, 1)))
        w = 1.0 / np.where(level > 0, level, level[level > 0].min() if (level > 0).any() else 1)
    model, history = fit_fixed_poles(sk, Hu, poles, _residual_poles((lo, hi), s),
                                     feedthrough=s.feedthrough, max_iter=s.max_iter,
                                     tol=s.tol, weights=w)  # fmt: skip
    if not use.all():  # C and D of every channel for the B of the channels used
        C, D = fit_c(Resolvent(model.A, sk), model.B, Hs, s.feedthrough, w)
        model = replace(model, C=C, D=D)
    say(f"whole band {lo:g}-{hi:g} Hz: {len(poles)} poles, B, C, D refined in "
        f"{len(history) - 1} alternating steps (cost {history[0]:.4g} -> {history[-1]:.4g})")
    return _result(data, model, so, si, f, Hs, (lo, hi), parts, history, s)


def _result(data: FRFData, model: FixedPoleModel, so: np.ndarray, si: np.ndarray,
            f: np.ndarray, Hs: np.ndarray, band: tuple[float, float], parts: list[Part],
            history: list[float], s: Settings) -> IdentifiedModel:  # fmt: skip
    system = StateSpace(model.A, model.B * si[None, :], model.C * so[:, None],
                        model.D * so[:, None] * si[None, :])  # fmt: skip
    Hm = response(model, 2j * np.pi * f)
    err = np.sqrt(np.sum(np.abs(Hm - Hs) ** 2, axis=(1, 2)) / np.sum(np.abs(Hs) ** 2, axis=(1, 2)))
    suspect = outliers(err, s.suspect_factor, s.suspect_floor)
    k = len(model.poles)
    lam, V = np.linalg.eig(model.A[: 2 * k, : 2 * k])  # the physical states come first
    W = np.linalg.inv(V)
    up = np.flatnonzero(lam.imag > 0)
    up = up[np.argsort(lam[up].imag)]
    lam = lam[up]
    shapes = system.C[:, : 2 * k] @ V[:, up]
    part = W[up] @ system.B[: 2 * k]  # (k, m)
    big = np.argmax(np.abs(shapes), axis=0)
    norm = shapes[big, np.arange(len(up))]
    shapes = shapes / norm
    part = (part * norm[:, None]).T
    fr, z = poles_to_modal(lam)
    return IdentifiedModel(system, model.residual.copy(), lam, fr, z, shapes, part,
                           data.outputs, data.inputs, data.quantity, data.units, band, err,
                           suspect, parts, history)  # fmt: skip


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
