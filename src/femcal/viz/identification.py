"""Pictures of an identification (matplotlib, Agg backend), written atomically as PNG:
stabilisation diagrams with the chosen poles explained, and the mode indicator functions
(CMIF and MIF) with the peaks and the identified modes."""

from __future__ import annotations

import os

import numpy as np

from ..identify.indicators import cmif, mif
from ..identify.stabilization import Stabilization
from ..testdata.data import FRFData
from .figures import pyplot, save_figure


def _units(data: FRFData) -> str:
    return data.units if data.units else f"{data.quantity}, units not given"


def stabilization_diagram(path: str | os.PathLike[str], diagram: Stabilization,
                          data: FRFData | None = None, *, title: str = ""):  # fmt: skip
    """Stabilisation diagram as PNG: the physical-looking poles of every model order against
    frequency (filled: stable in frequency, damping and vector; half: in frequency only;
    hollow: new), each chosen mode as a vertical line labelled with its frequency and in
    how many of its orders it was stable, and, with ``data``, the CMIF curves on a second
    axis.

    Returns the Figure.
    """
    import matplotlib.ticker

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(10, 6))
    lo, hi = diagram.band
    if data is not None:
        sel = (data.frequency_hz >= lo) & (data.frequency_hz <= hi)
        H = data.H[:, :, sel]
        if H.shape[1] > H.shape[0]:
            H = np.swapaxes(H, 0, 1)
        ax2 = ax.twinx()
        S = cmif(H)
        for k, curve in enumerate(S[:3]):
            ax2.semilogy(data.frequency_hz[sel], curve, color=f"{0.45 + 0.15 * k:.2f}",
                         lw=0.8)  # fmt: skip
        ax2.set_ylabel(f"CMIF ({_units(data)})", color="0.4")
        ax2.tick_params(axis="y", colors="0.4")
    for op in diagram.orders:
        st, sf = op.stable, op.stable_frequency & ~op.stable
        new = ~op.stable & ~op.stable_frequency
        y = np.full(len(op.poles), op.order)
        ax.plot(op.frequency_hz[st], y[st], "o", color="tab:blue", ms=3.5)
        ax.plot(op.frequency_hz[sf], y[sf], "o", color="tab:green", ms=3.5, mfc="none")
        ax.plot(op.frequency_hz[new], y[new], ".", color="tab:red", ms=2.5)
    top = diagram.max_order
    for fm, n, seen in zip(diagram.modes_hz, diagram.support, diagram.n_orders_seen,
                           strict=True):  # fmt: skip
        ax.axvline(fm, color="k", lw=0.8, alpha=0.7)
        ax.annotate(f"{fm:.4g} Hz: {n} of {seen}", (fm, top), xytext=(2, 2),
                    textcoords="offset points", rotation=90, fontsize=7, va="bottom")
    ax.yaxis.set_major_locator(matplotlib.ticker.MaxNLocator(integer=True))
    ax.set_xlim(lo, hi)
    ax.set_ylim(0, top * 1.25 + 1)
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("model order" + (" (polynomial order)" if diagram.method == "plscf" else
                                   " (states)"))  # fmt: skip
    ax.plot([], [], "o", color="tab:blue", ms=3.5, label="stable: frequency, damping, vector")
    ax.plot([], [], "o", color="tab:green", ms=3.5, mfc="none", label="stable in frequency")
    ax.plot([], [], ".", color="tab:red", ms=2.5, label="new")
    ax.plot([], [], "-", color="k", lw=0.8, label="chosen: stable in N of its M orders")
    # below the axes: inside, it would cover the modes' labels or the poles
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.1), fontsize=8, ncol=4,
              frameon=False)  # fmt: skip
    name = {"plscf": "pLSCF (PolyMAX)", "subspace": "subspace"}.get(diagram.method,
                                                                    diagram.method)
    ax.set_title(title or f"{name} stabilisation {lo:g}-{hi:g} Hz: {len(diagram.modes)} "
                 "modes chosen (poles stable in at least half of the orders from their first "
                 "stable one)", fontsize=9)  # fmt: skip
    ax.set_zorder(3)
    ax.patch.set_visible(False)
    return save_figure(fig, path)


def indicator_plot(path: str | os.PathLike[str], data: FRFData, band: tuple[float, float],
                   modes_hz: np.ndarray, peaks_hz: np.ndarray | None = None):  # fmt: skip
    """The CMIF curves (log, the data's units) and the MIF (0 to 1: dips at normal modes)
    over the band, the CMIF peaks marked and the identified modes as vertical lines.

    Returns the Figure.
    """
    plt = pyplot()
    f = data.frequency_hz
    sel = (f >= band[0]) & (f <= band[1]) & (f > 0)
    H = data.H[:, :, sel]
    if H.shape[1] > H.shape[0]:
        H = np.swapaxes(H, 0, 1)
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(10, 6.5), sharex=True,
                                 gridspec_kw={"height_ratios": [2, 1]})  # fmt: skip
    S = cmif(H)
    for k, curve in enumerate(S):
        a1.semilogy(f[sel], curve, lw=0.9, label=f"CMIF {k + 1}" if k < 6 else None)
    if peaks_hz is not None and len(peaks_hz):
        at = np.searchsorted(f[sel], peaks_hz).clip(0, sel.sum() - 1)
        a1.plot(f[sel][at], S[0][at], "v", color="k", ms=5, label="peak")
    for fm in modes_hz:
        a1.axvline(fm, color="tab:red", lw=0.7, alpha=0.7)
        a2.axvline(fm, color="tab:red", lw=0.7, alpha=0.7)
    a1.plot([], [], color="tab:red", lw=0.7, label="identified mode")
    a1.set_ylabel(f"singular values of H ({_units(data)})")
    a1.grid(True, which="both", alpha=0.3)
    a1.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))  # beside the peaks
    a1.set_title(f"mode indicators {band[0]:g}-{band[1]:g} Hz: CMIF (peaks at modes) and MIF "
                 "(dips at modes)", fontsize=9)  # fmt: skip
    M = mif(f[sel], H, data.quantity)
    for curve in M[:3]:
        a2.plot(f[sel], curve, lw=0.8)
    a2.set_ylim(-0.02, 1.02)
    a2.set_ylabel("MIF (no unit)")
    a2.set_xlabel("frequency (Hz)")
    a2.grid(True, alpha=0.3)
    return save_figure(fig, path)
