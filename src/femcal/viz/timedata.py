"""Pictures of rig time histories and what is estimated from them (matplotlib, Agg):
time histories, power spectral densities, the singular values of the input spectral matrix,
coherences and FRF magnitude and phase. Each function writes its PNGs atomically (the time
histories as many as their channels need)."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..testdata.signal import FRFEstimate, Spectra, input_singular_values
from ..testdata.timedata import TimeData
from .figures import pyplot, save_figure

#: Most panels one time-history picture holds (more go on in further pictures) and most
#: curves one PSD panel holds (more go on in further panels); the coherence and FRF pictures
#: draw the first this many outputs.
MAX_CURVES = 12


def _label(name: str, unit: str) -> str:
    return f"{name} ({unit})" if unit else name


def _frequency_axis(ax, ylabel: str, band: tuple[float, float] | None, f_top: float) -> None:
    """Labels, grid and legend of a panel over frequency; the band shaded and the axis up to
    twice its top."""
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel(ylabel)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    if band is not None:
        ax.axvspan(*band, color="tab:green", alpha=0.08)
        ax.set_xlim(0, min(f_top, 2 * band[1]))


#: A record longer than this (s) is drawn over a window of this length by default.
DEFAULT_WINDOW_S = 5.0


def time_window(data: TimeData, channels: Sequence[int],
                seconds: float | None = None) -> tuple[int, int]:  # fmt: skip
    """(first sample, samples) of the window a time-history picture shows: the first
    ``seconds`` when given; the whole record when it is no longer than
    :data:`DEFAULT_WINDOW_S`; else :data:`DEFAULT_WINDOW_S` centred on the record's largest
    peak (the channels each scaled by their RMS about the mean), so that a long record shows
    its signal rather than a block of ink."""
    if seconds is not None:
        return 0, min(data.n_samples, round(seconds / data.dt) + 1)
    n = min(data.n_samples, round(DEFAULT_WINDOW_S / data.dt) + 1)
    if n >= data.n_samples:
        return 0, data.n_samples
    x = data.values[list(channels)]
    x = x - x.mean(axis=1, keepdims=True)
    rms = np.sqrt(np.mean(x**2, axis=1, keepdims=True))
    peak = int(np.argmax(np.max(np.abs(x) / np.where(rms > 0, rms, 1.0), axis=0)))
    start = min(max(peak - n // 2, 0), data.n_samples - n)
    return start, n


def time_histories(path: str | os.PathLike[str], data: TimeData,
                   channels: Sequence[int] | None = None, *, seconds: float | None = None,
                   title: str = "") -> list[Path]:  # fmt: skip
    """One panel per channel of its samples against time over :func:`time_window`'s window,
    :data:`MAX_CURVES` panels to a picture: ``path``, then ``NAME_2.png`` and on for the
    channels beyond. Returns the pictures' paths."""
    plt = pyplot()
    chans = list(range(data.n_channels) if channels is None else channels)
    start, n = time_window(data, chans, seconds)
    t = data.time[start:start + n]
    whole = data.n_samples * data.dt
    span = (f"{t[0]:.4g}-{t[-1]:.4g} s of {whole:.4g} s" if n < data.n_samples
            else f"{whole:.4g} s")  # fmt: skip
    base = Path(path)
    paths = []
    pages = [chans[k:k + MAX_CURVES] for k in range(0, len(chans), MAX_CURVES)]
    for page, some in enumerate(pages, start=1):
        fig, axes = plt.subplots(len(some), 1, figsize=(9.0, 1.5 + 1.4 * len(some)),
                                 sharex=True, squeeze=False)  # fmt: skip
        for ax, c in zip(axes[:, 0], some, strict=True):
            ax.plot(t, data.values[c, start:start + n], color="k", lw=0.6)
            ax.set_ylabel(data.units[c] or "(no unit)")
            ax.set_title(data.names[c], fontsize=9, loc="left")
            ax.grid(True, alpha=0.3)
        axes[-1, 0].set_xlabel("time (s)")
        more = f" ({page} of {len(pages)})" if len(pages) > 1 else ""
        fig.suptitle(f"{title or 'Time histories'}{more}: {span}")
        target = base if page == 1 else base.with_name(f"{base.stem}_{page}{base.suffix}")
        save_figure(fig, target)
        paths.append(target)
    return paths


def power_spectra(path: str | os.PathLike[str], frequency_hz: np.ndarray, psd: np.ndarray,
                  names: Sequence[str], units: Sequence[str], *, band: tuple[float, float] |
                  None = None, title: str = ""):  # fmt: skip
    """Power spectral densities (n, n_f) of every channel on a log scale, grouped by unit
    (a panel per unit, of at most :data:`MAX_CURVES` curves), with the analysis band
    shaded."""
    plt = pyplot()
    by_unit: dict[str, list[int]] = {}
    for k, u in enumerate(units):
        by_unit.setdefault(u, []).append(k)
    groups = [(u, ks[i:i + MAX_CURVES]) for u, ks in by_unit.items()
              for i in range(0, len(ks), MAX_CURVES)]  # fmt: skip
    fig, axes = plt.subplots(len(groups), 1, figsize=(9.0, 1.5 + 2.6 * len(groups)),
                             sharex=True, squeeze=False)  # fmt: skip
    keep = frequency_hz > 0
    for ax, (unit, ks) in zip(axes[:, 0], groups, strict=True):
        for k in ks:
            ax.semilogy(frequency_hz[keep], psd[k, keep], lw=0.8, label=names[k])
        squared = f"({unit})²" if "/" in unit else f"{unit}²"  # (mm/s^2)²/Hz, not mm/s^2²/Hz
        ax.set_ylabel(f"PSD ({squared}/Hz)" if unit else "PSD (1/Hz)")
        ax.legend(fontsize=7, ncol=2)
        ax.grid(True, which="both", alpha=0.3)
        if band is not None:
            ax.axvspan(*band, color="tab:green", alpha=0.08)
    axes[-1, 0].set_xlabel("frequency (Hz)")
    fig.suptitle(title or "Power spectral densities")
    return save_figure(fig, path)


def singular_values_plot(path: str | os.PathLike[str], spectra: Spectra, *,
                         band: tuple[float, float] | None = None, title: str = ""):  # fmt: skip
    """The singular values of the input spectral matrix against frequency (the principal
    inputs' powers): curves of like height mean independent drives; a curve far below the
    others marks drives that move together."""
    plt = pyplot()
    sv = input_singular_values(spectra)
    f = spectra.frequency_hz
    keep = f > 0
    fig, ax = plt.subplots(figsize=(9.0, 4.2))
    for k in range(sv.shape[1]):
        ax.semilogy(f[keep], sv[keep, k], lw=0.9, label=f"principal input {k + 1}")
    _frequency_axis(ax, "singular value of G_xx (input unit²/Hz)", band, f[-1])
    fig.suptitle(title or "Are the drives independent? Singular values of the input spectra")
    return save_figure(fig, path)


def coherence_plot(path: str | os.PathLike[str], estimate: FRFEstimate,
                   outputs: Sequence[str], *, band: tuple[float, float] | None = None,
                   title: str = ""):  # fmt: skip
    """The multiple coherence of each output (the share of its power the inputs explain)."""
    plt = pyplot()
    f = estimate.frequency_hz
    fig, ax = plt.subplots(figsize=(9.0, 4.2))
    for o, name in list(enumerate(outputs))[:MAX_CURVES]:
        ax.plot(f, estimate.multiple_coherence[o], lw=0.8, label=name)
    ax.set_ylim(0, 1.02)
    _frequency_axis(ax, "multiple coherence (-)", band, f[-1])
    fig.suptitle(title or "Multiple coherence of the outputs")
    return save_figure(fig, path)


def frf_plot(path: str | os.PathLike[str], estimate: FRFEstimate, outputs: Sequence[str],
             inputs: Sequence[str], unit: str, *, band: tuple[float, float] | None = None,
             title: str = ""):  # fmt: skip
    """Magnitude (log) and phase of the estimated FRFs: one column per input (at most 4),
    every output in it (at most :data:`MAX_CURVES`), the band the analysis keeps."""
    plt = pyplot()
    f = estimate.frequency_hz
    n_in = min(len(inputs), 4)
    fig, axes = plt.subplots(2, n_in, figsize=(4.4 * n_in, 6.4), sharex=True, squeeze=False)
    lo, hi = band if band is not None else (f[1] if len(f) > 1 else 0.0, f[-1])
    keep = (f >= lo) & (f <= hi)
    for i in range(n_in):
        mag, ph = axes[0, i], axes[1, i]
        for o, name in list(enumerate(outputs))[:MAX_CURVES]:
            h = estimate.H[o, i, keep]
            mag.semilogy(f[keep], np.abs(h), lw=0.8, label=name)
            ph.plot(f[keep], np.degrees(np.angle(h)), lw=0.8)
        mag.set_title(f"input {inputs[i]}", fontsize=9)
        mag.set_ylabel(f"|H| ({unit})")
        ph.set_ylabel("phase (deg)")
        ph.set_xlabel("frequency (Hz)")
        for ax in (mag, ph):
            ax.grid(True, which="both", alpha=0.3)
        if i == 0:
            mag.legend(fontsize=7)
    more = f" (first 4 of {len(inputs)} inputs)" if len(inputs) > 4 else ""
    fig.suptitle(title or f"{estimate.estimator} FRFs{more}")
    return save_figure(fig, path)
