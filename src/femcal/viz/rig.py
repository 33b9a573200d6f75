"""Pictures of a drive iteration (matplotlib, Agg): the RMS error of each control channel
against the iteration, and target against response over time and as PSDs. Each function
writes one PNG atomically and returns the figure."""

from __future__ import annotations

import os
from collections.abc import Sequence

import numpy as np

from ..testdata.signal import cross_spectra
from .figures import pyplot, save_figure

#: Most channels drawn in one picture.
MAX_PANELS = 12


def error_history(path: str | os.PathLike[str], rms_error: np.ndarray, names: Sequence[str],
                  title: str = ""):  # fmt: skip
    """The RMS error over the target's RMS (%) of each control channel against the
    iteration (0: the first drive), on a log scale."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8.0, 4.6))
    k = np.arange(rms_error.shape[0])
    for c, name in list(enumerate(names))[:MAX_PANELS]:
        ax.semilogy(k, np.maximum(100 * rms_error[:, c], 1e-6), marker="o", ms=3, lw=1.0,
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
        ax.set_ylabel(units[c] or "-")
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
            ax.semilogy(f[keep], psd[m * rows + c, keep], color=color, ls=ls, lw=lw,
                        label=label)  # fmt: skip
        ax.set_title(names[c], fontsize=9, loc="left")
        ax.set_ylabel(f"PSD ({units[c]}²/Hz)" if units[c] else "PSD")
        ax.grid(True, which="both", alpha=0.3)
        if band is not None:
            ax.set_xlim(0, min(f[-1], 1.5 * band[1]))
    for c in range(rows, axes.size):
        axes[c // cols, c % cols].axis("off")
    axes[0, 0].legend(fontsize=7)
    fig.suptitle(title or "Power spectral densities")
    return save_figure(fig, path)
