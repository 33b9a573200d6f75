"""Suspect channels: the outputs whose FRFs the model misses far more than the others', and
the likely reason for each.

A channel stands out when its misfit (the root mean square of its log10 FRF residuals over
inputs and frequencies, magnitude and phase as the metric has them) is more than
:data:`STANDOUT_FACTOR` times the median channel's and above :data:`STANDOUT_FLOOR`, before
or after calibration. Calibration cannot mend such a channel: a sensor that is wrong
pulls the parameters, which is why it is flagged on both sides.

The reasons tried, each a simple mistake a test lab makes, are judged on the calibrated
model:

- **calibration factor or unit**: the test reads a constant multiple of the model at every
  frequency (the median log ratio), and removing that multiple takes away most of the misfit;
- **sign**: the channel fits the model's opposite direction (a sensor mounted upside down, a
  sign lost in the geometry file);
- **direction**: it fits another axis at the same grid (a triaxial's channels swapped, a
  sensor on a tilted face);
- **location**: it fits the same direction at a nearby grid (the sensor was put elsewhere
  than the file says).

Each alternative's FRFs are the modal sum over the calibrated modes at that degree of
freedom, compared with the channel's own modal sum so that the truncation is the same on
both sides. A reason is given only where it removes at least half of the channel's misfit.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..model.model import Model
from ..response.frf import channel_matrix, modal_frf
from ..solve.normal_modes import Modes
from ..testdata.data import Channel
from .metric import residuals
from .robust import robust_scale

#: A channel stands out when its misfit is this many times the median channel's ...
STANDOUT_FACTOR = 3.0
#: ... and above this (log10: a factor 10**0.1 = 1.26 on the FRF).
STANDOUT_FLOOR = 0.1
#: A reason is given only where its alternative removes at least this share of the misfit.
EXPLAINS = 0.5
#: A channel's response is weak below this share of the median channel's level.
WEAK = 0.1
#: A misfit gathers at few frequencies where its RMS is this many times its robust spread.
GATHERED = 4.0
#: Grids within this many nearest neighbours are tried for a misplaced sensor.
NEIGHBOURS = 6


@dataclass(frozen=True)
class SuspectChannel:
    """One output channel that stands out.

    Attributes
    ----------
    label : the channel's label (``455:+Z``); name : the sensor's own name ('' if none).
    misfit_before, misfit_after : its RMS log10 residual at the nominal and the calibrated
        model (NaN where there is no nominal model).
    median_before, median_after : the median channel's, for scale.
    level : the test over the calibrated model, the median ratio of their magnitudes (10 for
        a channel that reads ten times the model).
    reasons : the likely reasons, best first (may be empty: no simple mistake explains it).
    notes : what else marks the channel: a weak response (near a node line, where noise and
        small modelling errors weigh more), a misfit gathered at a few frequencies (the
        channel's antiresonances, which local stiffness and mass decide).
    """

    label: str
    name: str
    misfit_before: float
    misfit_after: float
    median_before: float
    median_after: float
    level: float
    reasons: tuple[str, ...]
    notes: tuple[str, ...] = ()

    @property
    def shown(self) -> str:
        """The sensor's name with its label, or its label."""
        return f"{self.name} ({self.label})" if self.name else self.label

    @property
    def out_before(self) -> bool:
        """It stands out at the nominal model."""
        return bool(stands_out(self.misfit_before, self.median_before))

    @property
    def out_after(self) -> bool:
        """It stands out at the calibrated model."""
        return bool(stands_out(self.misfit_after, self.median_after))

    @property
    def worse_after(self) -> bool:
        """Calibration made this channel's misfit larger."""
        return bool(self.misfit_after > self.misfit_before)

    def brief(self) -> str:
        """A few words: the channel, how far it stands out, its likeliest reason."""
        times = self.misfit_after / self.median_after if self.median_after > 0 else np.inf
        what = [self.reasons[0].split(":")[0] if self.reasons else "no simple mistake"]
        what += ["weak response" if n.startswith("its response is weak") else
                 "misfit at a few frequencies" for n in self.notes]  # fmt: skip
        if self.worse_after:
            what.append("worse after calibration")
        return f"{self.shown}, {times:.1f} times ({', '.join(what)})"

    def describe(self) -> str:
        """One sentence: how far it stands out, before and after, and why it may."""
        times = self.misfit_after / self.median_after if self.median_after > 0 else np.inf
        before = ("" if not np.isfinite(self.misfit_before)
                  else f"{self.misfit_before:.3g} before, ")  # fmt: skip
        why = ("likely " + "; or ".join(self.reasons) if self.reasons
               else "no simple mistake (factor, sign, direction, nearby grid) explains it: "
               "check the sensor's mounting and cable, and the model near it")  # fmt: skip
        notes = "".join(f" {n[0].upper()}{n[1:]}." for n in self.notes)
        return (f"{self.shown}: misfit {before}{self.misfit_after:.3g} after calibration "
                f"({times:.1f} times the median channel's"
                f"{', worse after calibration' if self.worse_after else ''}); {why}.{notes}")


def stands_out(misfit: float | np.ndarray, median: float) -> bool | np.ndarray:
    """A misfit over :data:`STANDOUT_FACTOR` times the median channel's and over
    :data:`STANDOUT_FLOOR` (False for NaN)."""
    return (misfit > STANDOUT_FACTOR * median) & (misfit > STANDOUT_FLOOR)


def _channel_rms(eps: np.ndarray) -> np.ndarray:
    """(n_out,) RMS of residuals laid out (parts, n_out, n_in, n_f)."""
    return np.sqrt(np.mean(eps**2, axis=(0, 2, 3)))


def _log_residuals(H_model: np.ndarray, H_test: np.ndarray, phase: bool) -> np.ndarray:
    """(parts, ...) the metric's log10 residuals (:func:`femcal.calibrate.metric.residuals`:
    magnitude, and with ``phase`` the complex-log metric's phase part) in H's layout."""
    shape = np.broadcast_shapes(np.shape(H_model), np.shape(H_test))
    eps = residuals(H_model, H_test, "complex-log" if phase else "log-magnitude")
    return eps.reshape(-1, *shape)


def _alternatives(model: Model, channel: Channel) -> list[tuple[str, Channel]]:
    """What the channel may really be: its opposite sign, the other axes at its grid (either
    sign), its direction at the nearest grids; each with the reason it stands for."""
    d = (channel.direction or "").upper()
    axis = d.lstrip("+-")
    if channel.grid is None or axis not in ("X", "Y", "Z", "RX", "RY", "RZ"):
        return []
    sign = "-" if d.startswith("-") else "+"
    flip = "+" if sign == "-" else "-"
    rot = "R" if axis.startswith("R") else ""
    out = [(f"sign: it reads the model's {flip}{axis} (mounted reversed, or a sign lost in "
            "the geometry)", Channel(f"{channel.grid}:{flip}{axis}", channel.grid,
                                      f"{flip}{axis}"))]  # fmt: skip
    for other in ("X", "Y", "Z"):
        if rot + other == axis:
            continue
        for s in "+-":
            out.append((f"direction: it reads the model's {s}{rot}{other} at grid "
                        f"{channel.grid} (axes swapped, or a tilted mounting)",
                        Channel(f"{channel.grid}:{s}{rot}{other}", channel.grid,
                                f"{s}{rot}{other}")))  # fmt: skip
    idx = int(model.node_index(channel.grid)[0])
    if idx >= 0:
        grids = np.flatnonzero(model.is_grid)
        dist = np.linalg.norm(model.xyz[grids] - model.xyz[idx], axis=1)
        for k in grids[np.argsort(dist)][1:NEIGHBOURS + 1]:
            gid = int(model.node_ids[k])
            far = float(np.linalg.norm(model.xyz[k] - model.xyz[idx]))
            out.append((f"location: it reads the model's {d} at grid {gid}, {far:.4g} away "
                        "in the deck's length unit (placed elsewhere than the file says)",
                        Channel(f"{gid}:{d}", gid, d)))  # fmt: skip
    return out


def suspect_channels(outputs: Sequence[Channel], inputs: Sequence[Channel],
                     freq_hz: np.ndarray, H_test: np.ndarray, H_after: np.ndarray, *,
                     H_before: np.ndarray | None = None, phase: bool = True,
                     model: Model | None = None, modes: Modes | None = None,
                     zeta: float = 0.01, quantity: str = "receptance",
                     names: dict[str, str] | None = None
                     ) -> tuple[SuspectChannel, ...]:  # fmt: skip
    """The outputs that stand out (see the module docstring), worst after calibration first.

    Parameters
    ----------
    outputs, inputs : the channels of H's rows and columns.
    freq_hz : (n_f,) Hz.
    H_test, H_after, H_before : (n_out, n_in, n_f) complex FRFs: the test's and the model's
        after and (optional) before calibration, in the same quantity and units.
    phase : judge the phase too (the complex-log metric), else magnitudes only.
    model, modes : the calibrated model and its modes, to try the sign, direction and
        location of a channel that stands out (without them only the level is judged).
    zeta : the modal damping ratio of those modal sums; quantity : the FRFs' quantity.
    names : channel label -> the sensor's own name.
    """
    names = names or {}
    after = _channel_rms(_log_residuals(H_after, H_test, phase))
    med_a = float(np.median(after))
    if H_before is not None:
        before = _channel_rms(_log_residuals(H_before, H_test, phase))
        med_b = float(np.median(before))
    else:
        before, med_b = np.full(len(outputs), np.nan), np.nan

    strength = np.median(np.abs(H_test), axis=(1, 2))  # (n_out,) each channel's level
    typical_strength = float(np.median(strength))
    odd = stands_out(after, med_a) | stands_out(before, med_b)  # NaN before: False
    found = []
    for o in np.flatnonzero(odd):
        ch = outputs[o]
        log_ratio = np.log10(np.abs(H_test[o]) / np.abs(H_after[o]))
        level = float(np.median(log_ratio))
        reasons: list[tuple[float, str]] = []
        own = after[o]
        rest = _channel_rms(_log_residuals(H_after[o:o + 1] * 10.0**level,
                                           H_test[o:o + 1], phase))[0]
        if abs(level) >= STANDOUT_FLOOR and rest <= (1 - EXPLAINS) * own:
            reasons.append((rest, f"calibration factor or unit: the test reads "
                                  f"{10.0**level:.3g} times the model at every frequency"))
        if model is not None and modes is not None:
            reasons += _tried(model, modes, ch, o, inputs, freq_hz, H_test, zeta, quantity,
                              phase)
        reasons.sort()
        notes = []
        weak = strength[o] / typical_strength if typical_strength > 0 else 1.0
        if weak < WEAK:
            notes.append(f"its response is weak ({weak:.2g} times the median channel's "
                         "level): near a node line noise and small modelling errors weigh "
                         "more")  # fmt: skip
        eps_o = _log_residuals(H_after[o], H_test[o], phase)
        typical = robust_scale(eps_o)
        if own > GATHERED * typical:
            notes.append(f"its misfit gathers at a few frequencies (typically {typical:.2g}, "
                         f"{own:.2g} in all): the channel's antiresonances, which the "
                         "stiffness and mass near the sensor decide")  # fmt: skip
        found.append(SuspectChannel(ch.label, names.get(ch.label, ""), float(before[o]),
                                    float(own), med_b, med_a, float(10.0**level),
                                    tuple(r for _, r in reasons), tuple(notes)))  # fmt: skip
    return tuple(sorted(found, key=lambda s: -s.misfit_after / max(s.median_after, 1e-300)))


def _tried(model: Model, modes: Modes, channel: Channel, o: int, inputs: Sequence[Channel],
           freq_hz: np.ndarray, H_test: np.ndarray, zeta: float, quantity: str,
           phase: bool) -> list[tuple[float, str]]:  # fmt: skip
    """The alternatives of :func:`_alternatives` that remove at least :data:`EXPLAINS` of the
    channel's misfit against its own modal sum: (their misfit, reason)."""
    alts = _alternatives(model, channel)
    if not alts:
        return []
    try:
        C = channel_matrix(model, [channel] + [c for _, c in alts])
        B = channel_matrix(model, list(inputs)).T
    except ValueError:  # a channel the model cannot place: nothing to try
        return []
    shapes = modes.shapes / np.sqrt(np.where(modes.generalized_mass > 0,
                                             modes.generalized_mass, 1.0))  # fmt: skip
    omega = np.sqrt(np.clip(modes.eigenvalues, 0.0, None))
    H = modal_frf(shapes, omega, C, B, freq_hz, zeta, quantity)  # (1 + n_alt, n_in, n_f)
    with np.errstate(divide="ignore", invalid="ignore"):
        eps = _log_residuals(H, np.broadcast_to(H_test[o], H.shape), phase)
    eps = np.where(np.isfinite(eps), eps, 10.0)  # a zero FRF (a node line) fits nothing
    mis = _channel_rms(eps)
    own = mis[0]
    return [(float(m), why) for (why, _), m in zip(alts, mis[1:], strict=True)
            if m <= (1 - EXPLAINS) * own]
