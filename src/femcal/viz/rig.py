"""Pictures of a drive iteration (matplotlib, Agg): the RMS error of each control channel
against the iteration, and target against response over time and as PSDs. Each function
writes one PNG atomically and returns the figure."""

from __future__ import annotations

import os
from collections.abc import Sequence

import numpy as np
import scipy.signal as ss

from ..testdata.signal import cross_spectra
from .figures import pyplot, save_figure, shows_ticks

#: Most channels drawn in one picture.
MAX_PANELS = 12


def _log(ax, x: np.ndarray, y: np.ndarray, **style) -> None:
    """``y`` against ``x`` on a logarithmic y axis, its non-positive values left out (a
    drive that is zero has no PSD to draw on a log scale; the axis stays linear until a
    curve with a positive value is drawn on it)."""
    y = np.where(y > 0, y, np.nan)
    ax.plot(x, y, **style)
    if np.isfinite(y).any():
        ax.set_yscale("log")


def error_history(path: str | os.PathLike[str], rms_error: np.ndarray, names: Sequence[str],
                  title: str = ""):  # fmt: skip
    """The RMS error over the target's RMS (%) of each control channel against the
    iteration (0: the first drive), on a log scale."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8.0, 4.6))
    k = np.arange(rms_error.shape[0])
    for c, name in list(enumerate(names))[:MAX_PANELS]:
        _log(ax, k, np.maximum(100 * rms_error[:, c], 1e-6), marker="o", ms=3, lw=1.0,
             label=name)  # fmt: skip
    ax.set_xlabel("iteration (0: the first drive, inverse FRF x target)")
    ax.set_ylabel("RMS error / RMS target (%)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.suptitle(title or "Drive iteration: error of each control channel")
    return save_figure(fig, path)


def target_and_response(path: str | os.PathLike[str], dt: float, target: np.ndarray,
                        response: np.ndarray, names: Sequence[str], units: Sequence[str], *,
                        seconds: float = 4.0, title: str = ""):  # fmt: skip
    """One panel per control channel: target and response over the ``seconds`` of the
    record where the target is largest (centred on its peak)."""
    plt = pyplot()
    n = target.shape[1]
    m = min(n, max(2, round(seconds / dt)))
    peak = int(np.argmax(np.abs(target).max(axis=0)))
    start = int(np.clip(peak - m // 2, 0, n - m))
    t = (start + np.arange(m)) * dt
    rows = min(len(names), MAX_PANELS)
    fig, axes = plt.subplots(rows, 1, figsize=(9.0, 1.4 + 1.5 * rows), sharex=True,
                             squeeze=False)  # fmt: skip
    for c in range(rows):
        ax = axes[c, 0]
        ax.plot(t, target[c, start : start + m], color="k", lw=1.0, label="target")
        ax.plot(t, response[c, start : start + m], color="tab:red", lw=0.8, ls="--",
                label="response")  # fmt: skip
        ax.set_title(names[c], fontsize=9, loc="left")
        ax.set_ylabel(units[c] or "(no unit)")
        ax.grid(True, alpha=0.3)
    axes[0, 0].legend(fontsize=7)
    axes[-1, 0].set_xlabel("time (s)")
    fig.suptitle(title or "Target and response")
    return save_figure(fig, path)


def target_and_response_psd(path: str | os.PathLike[str], dt: float, target: np.ndarray,
                            response: np.ndarray, names: Sequence[str],
                            units: Sequence[str], *, segment_s: float = 4.0,
                            band: tuple[float, float] | None = None, title: str = ""):  # fmt: skip
    """One panel per control channel: the PSDs of target and response (Welch, Hann)."""
    return overlay_psd(path, dt, names, units, {"target": target, "response": response},
                       segment_s=segment_s, band=band,
                       title=title or "Target and response: power spectral densities")  # fmt: skip


def overlay_psd(path: str | os.PathLike[str], dt: float, names: Sequence[str],
                units: Sequence[str], series: dict[str, np.ndarray], *, segment_s: float = 4.0,
                band: tuple[float, float] | None = None, title: str = ""):  # fmt: skip
    """One panel per channel, the PSDs of several versions of it (``series``: label ->
    (channels, n); the first drawn in black as the reference)."""
    plt = pyplot()
    rows = min(len(names), MAX_PANELS)
    labels = list(series)
    stacked = np.vstack([series[k][:rows] for k in labels])
    segment = min(stacked.shape[1], max(8, round(segment_s / dt)))
    s = cross_spectra(stacked, stacked[:1], dt, segment)
    psd = np.einsum("fii->if", s.Gxx).real
    f = s.frequency_hz
    keep = f > 0
    cols = 2 if rows > 1 else 1
    n_rows = -(-rows // cols)
    fig, axes = plt.subplots(n_rows, cols, figsize=(5.0 * cols, 1.6 + 2.2 * n_rows),
                             squeeze=False, sharex=True)  # fmt: skip
    styles = [("k", "-", 1.1)] + [(None, "--", 0.9)] * (len(labels) - 1)
    for c in range(rows):
        ax = axes[c // cols, c % cols]
        for m, label in enumerate(labels):
            color, ls, lw = styles[m]
            _log(ax, f[keep], psd[m * rows + c, keep], color=color, ls=ls, lw=lw,
                        label=label)  # fmt: skip
        ax.set_title(names[c], fontsize=9, loc="left")
        ax.set_ylabel(f"PSD ({units[c]}²/Hz)" if units[c] else "PSD")
        ax.grid(True, which="both", alpha=0.3)
        if band is not None:
            ax.set_xlim(0, min(f[-1], 1.5 * band[1]))
    _hide_spare(axes, rows)
    _xlabel(axes, "frequency (Hz)")
    axes[0, 0].legend(fontsize=7)
    fig.suptitle(title or "Power spectral densities")
    return save_figure(fig, path)


def _panels(plt, count: int, height: float = 2.2):
    """A grid of two columns of panels (fewer for one), the extra ones hidden."""
    rows = min(count, MAX_PANELS)
    cols = 2 if rows > 1 else 1
    n_rows = -(-rows // cols)
    fig, axes = plt.subplots(n_rows, cols, figsize=(5.2 * cols, 1.6 + height * n_rows),
                             squeeze=False, sharex=True)  # fmt: skip
    _hide_spare(axes, rows)
    return fig, [axes[c // cols, c % cols] for c in range(rows)]


def _hide_spare(axes: np.ndarray, used: int) -> None:
    """Hide the grid's panels past the ``used`` first (row by row); the panel above a
    hidden one shows its frequency or time ticks, being the lowest of its column."""
    cols = axes.shape[1]
    for c in range(used, axes.size):
        axes[c // cols, c % cols].axis("off")
        if c - cols >= 0:
            axes[(c - cols) // cols, c % cols].tick_params(labelbottom=True)


def _xlabel(axes, text: str) -> None:
    """The x label on every panel that shows its x ticks (the lowest of each column)."""
    for ax in np.ravel(axes):
        if ax.axison and shows_ticks(ax.xaxis):
            ax.set_xlabel(text)


def drive_psd_history(path: str | os.PathLike[str], frequency_hz: np.ndarray,
                      psd: np.ndarray, names: Sequence[str], unit: str, *,
                      reference: np.ndarray | None = None,
                      band: tuple[float, float] | None = None, title: str = ""):  # fmt: skip
    """One panel per actuator: its drive's PSD after each step (``psd``: (steps, n_drives,
    n_f), light to dark from the first drive to the last), and the reference drive's
    (n_drives, n_f) in black when given."""
    plt = pyplot()
    fig, axes = _panels(plt, len(names))
    steps = psd.shape[0]
    colours = plt.get_cmap("viridis")(np.linspace(0.85, 0.0, max(steps, 1)))
    keep = frequency_hz > 0
    for j, ax in enumerate(axes):
        for k in range(steps):
            label = ("first drive" if k == 0 else "last drive" if k == steps - 1 else None)
            _log(ax, frequency_hz[keep], psd[k, j, keep], color=colours[k],
                        lw=1.2 if k == steps - 1 else 0.7, label=label)  # fmt: skip
        if reference is not None:
            _log(ax, frequency_hz[keep], reference[j, keep], color="k", lw=1.0, ls="--",
                        label="reference")  # fmt: skip
        ax.set_title(names[j], fontsize=9, loc="left")
        ax.set_ylabel(f"PSD ({unit}²/Hz)")
        ax.grid(True, which="both", alpha=0.3)
        if band is not None:
            ax.set_xlim(0, min(frequency_hz[-1], 1.5 * band[1]))
    _xlabel(axes, "frequency (Hz)")
    axes[0].legend(fontsize=7)
    fig.suptitle(title or "Drives at each iteration: power spectral densities")
    return save_figure(fig, path)


def drive_histories(path: str | os.PathLike[str], dt: float, drive: np.ndarray,
                    names: Sequence[str], unit: str, *, stroke: np.ndarray | None = None,
                    reference: np.ndarray | None = None, first: np.ndarray | None = None,
                    first_label: str = "first drive", title: str = ""):  # fmt: skip
    """One panel per actuator: the drive over the whole record, its stroke (+/-) dashed in
    red where one is given, the first drive in light green and the reference drive in grey
    when given."""
    plt = pyplot()
    fig, axes = _panels(plt, len(names), height=1.8)
    t = np.arange(drive.shape[1]) * dt
    for j, ax in enumerate(axes):
        if reference is not None:
            ax.plot(t, reference[j], color="0.6", lw=0.6, label="reference")
        if first is not None:
            ax.plot(t, first[j], color="yellowgreen", lw=0.6, label=first_label)
        ax.plot(t, drive[j], color="tab:blue", lw=0.6,
                label="last drive" if first_label == "first drive" else "next drive")
        if stroke is not None and np.isfinite(stroke[j]):
            for sign in (1, -1):
                ax.axhline(sign * stroke[j], color="tab:red", ls="--", lw=0.9,
                           label="stroke" if sign > 0 else None)  # fmt: skip
        ax.set_title(names[j], fontsize=9, loc="left")
        ax.set_ylabel(unit)
        ax.grid(True, alpha=0.3)
    _xlabel(axes, "time (s)")
    axes[0].legend(fontsize=7)
    fig.suptitle(title or "Drives: time histories")
    return save_figure(fig, path)


def error_spectra(path: str | os.PathLike[str], dt: float, target: np.ndarray,
                  response: np.ndarray, names: Sequence[str], units: Sequence[str], *,
                  noise_fraction: np.ndarray | None = None,
                  band: tuple[float, float] | None = None, segment_s: float = 4.0,
                  title: str = ""):  # fmt: skip
    """One panel per control channel: the PSD of target - response against the target's,
    the drive band shaded, and the target's noise floor (white, ``noise_fraction`` of its
    RMS) as a dotted line."""
    plt = pyplot()
    fig, axes = _panels(plt, len(names))
    m = min(target.shape[1], max(8, round(segment_s / dt)))
    f, Pt = ss.welch(target, fs=1.0 / dt, nperseg=m, axis=1)
    _, Pe = ss.welch(target - response, fs=1.0 / dt, nperseg=m, axis=1)
    keep = f > 0
    for c, ax in enumerate(axes):
        _log(ax, f[keep], Pt[c, keep], color="0.55", lw=0.8, label="target")
        _log(ax, f[keep], Pe[c, keep], color="tab:red", lw=0.9,
                    label="target - response")  # fmt: skip
        if noise_fraction is not None:
            level = (noise_fraction[c] * np.sqrt(np.mean(target[c] ** 2))) ** 2 * 2 * dt
            if level > 0 and ax.get_yscale() == "log":
                ax.axhline(level, color="k", ls=":", lw=0.9, label="noise floor")
        if band is not None:
            ax.axvspan(band[0], band[1], color="tab:green", alpha=0.07, lw=0)
        ax.set_title(names[c], fontsize=9, loc="left")
        ax.set_ylabel(f"PSD ({units[c]}²/Hz)" if units[c] else "PSD")
        ax.grid(True, which="both", alpha=0.3)
    _xlabel(axes, "frequency (Hz); shaded: the drive band")
    axes[0].legend(fontsize=7)
    fig.suptitle(title or "Error spectra: target - response")
    return save_figure(fig, path)
