"""The identification's page (``femcal identify --out DIR`` writes ``identification.html``):
one self-contained file that opens on its verdict (how many modes, how well the identified
model reproduces the FRFs, and what to doubt), then the modes table and the pictures as
evidence, and its provenance last.

What it doubts, each with its reason:

- what the identification itself said it could not do (a CMIF peak without a mode, a poor
  fit, no mode; :attr:`femcal.identify.IdentifiedModel.warnings`);
- a mode whose shape is far from a real one: MPC below :data:`MPC_LOW` or MPD above
  :data:`MPD_HIGH` degrees (close modes mixed, noise, or a computational mode);
- a mode near an edge of the band (within :data:`EDGE` of its width), where fewer data
  bound it;
- a damping ratio above :data:`DAMPING_HIGH` (a structural mode rarely has it);
- modes the sensors can hardly tell apart (AutoMAC above :data:`ALIKE`), and of those the
  ones within :data:`TWICE` in frequency, possibly one mode found twice;
- the channels the identification left out as suspect, with their fit errors against the
  median channel's (:func:`suspect_reason`).
"""

from __future__ import annotations

import html
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..atomic import write_atomic
from ..correlate.shapes import mac
from ..identify.workflow import IdentifiedModel
from .html import PAGE_STYLE, embedded_figure, html_header, html_table

#: A mode's shape is far from real below this modal phase collinearity ...
MPC_LOW = 0.8
#: ... or above this mean phase deviation (degrees).
MPD_HIGH = 20.0
#: A mode this close to an edge of the band (share of the band's width) is doubted.
EDGE = 0.02
#: Damping ratios above this are doubted.
DAMPING_HIGH = 0.10
#: Two modes whose AutoMAC is above this are hard to tell apart at the sensors.
ALIKE = 0.5


#: Why pages of one test can differ a little: each names its identification band with this.
OWN_BANDS = ("each command identifies over its own band, so `femcal identify`, `femcal "
             "correlate` and a calibration can differ in the last digits of the frequencies "
             "and in the suspect channels")

#: Two alike modes closer than this (relative frequency difference) may be one mode found
#: twice.
TWICE = 0.05


@dataclass(frozen=True)
class IdentificationVerdict:
    """What an engineer decides from: ``sentence``, the verdict in one plain sentence;
    ``key`` rows of (measure, value); ``doubts`` about the modes and ``channel_doubts``
    about the suspect channels, one sentence each (empty when nothing stands out)."""

    key: tuple[tuple[str, str], ...]
    doubts: tuple[str, ...]
    channel_doubts: tuple[str, ...] = ()
    sentence: str = ""

    @property
    def all_doubts(self) -> tuple[str, ...]:
        return self.doubts + self.channel_doubts


def _mode(model: IdentifiedModel, k: int) -> str:
    return f"mode {k + 1} at {model.frequency_hz[k]:.2f} Hz"


def identification_verdict(model: IdentifiedModel) -> IdentificationVerdict:
    """The verdict of an identified model (see the module)."""
    lo, hi = model.band
    f, z = model.frequency_hz, model.damping_ratio
    chans = model.shape_channels
    k = len(f)
    key: list[tuple[str, str]] = [
        ("modes in the band", f"{k} in {lo:g}-{hi:g} Hz ({model.method or 'identified'})")]
    if k:
        key.append(("frequencies", ", ".join(f"{x:.2f}" for x in f) + " Hz"))
        key.append(("damping", f"{100 * z.min():.3g} to {100 * z.max():.3g} % of critical"))
    if model.frf_correlation is not None and len(model.frf_correlation):
        i = int(np.argmin(model.frf_correlation))
        key.append(("FRF correlation, measured with synthesised",
                    f"median {np.median(model.frf_correlation):.3f}, lowest "
                    f"{model.frf_correlation[i]:.3f} ({chans[i].label})"))  # fmt: skip
    if len(model.fit_error):
        i = int(np.argmax(model.fit_error))
        key.append(("fit error", f"median {np.median(model.fit_error):.3f}, worst "
                                 f"{model.fit_error[i]:.3f} ({chans[i].label})"))
    if k and model.mpc is not None and model.mpd is not None:
        i, j = int(np.argmin(model.mpc)), int(np.argmax(model.mpd))
        key.append(("shapes' MPC, lowest", f"{model.mpc[i]:.3f} ({_mode(model, i)})"))
        key.append(("shapes' MPD, largest", f"{model.mpd[j]:.1f} deg ({_mode(model, j)})"))
    if model.peaks_hz is not None:
        key.append(("CMIF peaks in the band", f"{len(model.peaks_hz)}"))
    key.append(("suspect channels", f"{int(np.sum(model.suspect))} of {len(chans)}"))

    doubts = [f"{text[0].upper()}{text[1:]}." if not text.endswith(".") else text
              for text in model.warnings]  # fmt: skip
    for m in range(k):
        name = _mode(model, m)
        if model.mpc is not None and (model.mpc[m] < MPC_LOW or model.mpd[m] > MPD_HIGH):
            doubts.append(f"{name[0].upper()}{name[1:]}: MPC {model.mpc[m]:.2f}, MPD "
                          f"{model.mpd[m]:.0f} deg: its shape is far from a real mode's "
                          "(close modes mixed, noise, or a computational mode).")
        if min(f[m] - lo, hi - f[m]) < EDGE * (hi - lo):
            doubts.append(f"{name[0].upper()}{name[1:]} lies at the edge of the band, where "
                          "fewer data bound it: widen the band to see it whole.")
        if z[m] > DAMPING_HIGH:
            doubts.append(f"{name[0].upper()}{name[1:]}: damping {100 * z[m]:.1f} % of "
                          "critical, high for a structural mode (a computational mode, or "
                          "modes the estimator merged).")
    if k > 1:
        auto = mac(model.shapes, model.shapes)
        alike = [(a, b) for a in range(k) for b in range(a + 1, k) if auto[a, b] > ALIKE]
        near = [(a, b) for a, b in alike if abs(f[b] - f[a]) < TWICE * max(f[a], f[b])]
        if alike:
            doubts.append(f"Modes the sensors can hardly tell apart (AutoMAC over {ALIKE:g}): "
                          + ", ".join(f"{a + 1} and {b + 1} ({auto[a, b]:.2f})"
                                      for a, b in alike)
                          + ": too few or badly placed sensors for these shapes.")  # fmt: skip
        for a, b in near:
            doubts.append(f"Modes {a + 1} and {b + 1} ({f[a]:.2f} and {f[b]:.2f} Hz) are close "
                          f"and alike (AutoMAC {auto[a, b]:.2f}): possibly one mode found "
                          "twice.")  # fmt: skip
    channels = [f"Channel {chans[i].label} is suspect: {suspect_reason(model, i)}; it is left "
                "out of correlations and calibrations." for i in np.flatnonzero(model.suspect)]
    return IdentificationVerdict(tuple(key), tuple(doubts), tuple(channels),
                                 _sentence(model, len(doubts) + len(channels)))


def suspect_reason(model: IdentifiedModel, i: int) -> str:
    """Why roving channel ``i`` of ``model`` is suspect, in its numbers: its fit error
    against the median channel's (and its leave-one-out consistency error)."""
    err = np.asarray(model.fit_error, float)
    median = float(np.median(err))
    ratio = f", {err[i] / median:.1f} times the median channel's {median:.3f}" if median > 0 \
        else ""
    cons = ("" if model.consistency is None
            else f"; leave-one-out consistency error {model.consistency[i]:.3f}")  # fmt: skip
    return (f"the identified model misses its FRFs by {err[i]:.3f} (fit error{ratio}"
            f"{cons}): the other channels do not explain it (a loose or misoriented sensor, "
            "a wrong calibration factor, a channel from another measurement, or a mode just "
            "outside the band that it sees most)")


def _sentence(model: IdentifiedModel, n_doubts: int) -> str:
    """The verdict in one sentence: how many modes, how well the model reproduces the FRFs,
    how many doubts."""
    lo, hi = model.band
    k = len(model.frequency_hz)
    if not k:
        return f"No mode identified in {lo:g}-{hi:g} Hz: see what to doubt."
    fit = ""
    if model.frf_correlation is not None and len(model.frf_correlation):
        fit = (f"; the identified model reproduces the measured FRFs with a median FRF "
               f"correlation of {np.median(model.frf_correlation):.3f}")
    elif len(model.fit_error):
        fit = (f"; the identified model reproduces the measured FRFs to a median fit error of "
               f"{np.median(model.fit_error):.3f}")
    said = ("nothing stands out" if not n_doubts
            else f"{n_doubts} point{'s' * (n_doubts > 1)} to doubt, below")
    return (f"{k} mode{'s' * (k > 1)} identified in {lo:g}-{hi:g} Hz{fit}; "
            f"{int(np.sum(model.suspect))} suspect channel"
            f"{'s' * (int(np.sum(model.suspect)) != 1)}; {said}.")


def modes_rows(model: IdentifiedModel) -> list[list[str]]:
    """The modes table: number, frequency (Hz), damping (%), MPC, MPD (deg)."""
    rows = []
    for k, (f, z) in enumerate(zip(model.frequency_hz, model.damping_ratio, strict=True)):
        mpc = "-" if model.mpc is None else f"{model.mpc[k]:.3f}"
        mpd = "-" if model.mpd is None else f"{model.mpd[k]:.1f}"
        rows.append([str(k + 1), f"{f:.4f}", f"{100 * z:.3f}", mpc, mpd])
    return rows


def channel_rows(model: IdentifiedModel) -> list[list[str]]:
    """Each roving channel's fit: label, fit error, FRF correlation, suspect."""
    rows = []
    for i, c in enumerate(model.shape_channels):
        corr = "-" if model.frf_correlation is None else f"{model.frf_correlation[i]:.4f}"
        rows.append([c.label, f"{model.fit_error[i]:.4f}", corr,
                     "suspect" if model.suspect[i] else "ok"])  # fmt: skip
    return rows


def identification_html(model: IdentifiedModel, figures: Sequence[tuple[str, Path, str]],
                        head: dict, *, source: str = "") -> str:  # fmt: skip
    """The page (see the module): ``figures`` (title, PNG path, caption) embedded in order,
    ``head`` the provenance (:func:`femcal.io.html.provenance`), ``source`` the FRF file."""
    esc = html.escape
    v = identification_verdict(model)
    doubts = v.all_doubts or ("Nothing stands out.",)
    lo, hi = model.band
    figs = "".join(embedded_figure(t, p, c, number=n)
                   for n, (t, p, c) in enumerate(figures, start=1))  # fmt: skip
    parts = ", ".join(f"{p.band[0]:g}-{p.band[1]:g} Hz" for p in model.parts) or "one"
    return f"""<!DOCTYPE html><html><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>femcal identification</title><style>{PAGE_STYLE}</style></head><body>
<h1>Identification</h1>
<section id='verdict' class='verdict'><h2>Verdict</h2>
<p class='sentence'>{esc(v.sentence)}</p>
{html_table([list(r) for r in v.key], ["measure", "value"])}
<p><b>What to doubt</b></p><ul class='doubt'>{"".join(f"<li>{esc(x)}</li>" for x in doubts)}</ul>
</section>
<p>Modes of <code>{esc(source or "the FRFs")}</code> ({len(model.outputs)} outputs x
{len(model.inputs)} inputs, {esc(model.quantity)}, {esc(model.units or "no unit given")}) in
{lo:g}-{hi:g} Hz by {esc(model.method or "the estimator")}, in parts {esc(parts)}. Shapes
are at the {len(model.shape_channels)} roving channels, each mode's largest component 1.
MPC (modal phase collinearity, 1 for a real mode) and MPD (mean phase deviation, 0 deg for a
real mode) say how far a shape is from a real one. Fit error: the norm of the measured less
the synthesised FRFs over that of the measured, per channel; FRF correlation: their MAC.</p>
<h2 id='modes'>Modes</h2>
{html_table(modes_rows(model), ["mode", "frequency Hz", "damping %", "MPC", "MPD deg"])}
<h2 id='channels'>Channels</h2>
{html_table(channel_rows(model), ["channel", "fit error", "FRF correlation", "status"])}
{f"<h2 id='figures'>Figures</h2>{figs}" if figs else ""}
<h2 id='provenance'>Provenance</h2>
{html_header(head)}
</body></html>
"""


def write_identification_page(path: str | os.PathLike[str], model: IdentifiedModel,
                              figures: Sequence[tuple[str, Path, str]], head: dict, *,
                              source: str = "") -> Path:  # fmt: skip
    """:func:`identification_html` written to ``path`` atomically."""
    page = identification_html(model, figures, head, source=source)
    return write_atomic(Path(path), lambda tmp: Path(tmp).write_text(page, encoding="utf-8"))
