"""Pictures of an identification: stabilisation diagrams (matplotlib, Agg backend), written
atomically as PNG."""

from __future__ import annotations

import os

import numpy as np

from ..identify.stabilization import Stabilization
from ..testdata.data import FRFData
from .figures import pyplot, save_figure


def stabilization_diagram(path: str | os.PathLike[str], diagram: Stabilization,
                          data: FRFData | None = None, *, title: str = ""):  # fmt: skip
    """Stabilisation diagram as PNG: the physical-looking poles of every model order
    (filled: stable, hollow: not) against frequency, the physical modes as vertical lines,
    the chosen order as a horizontal line and, with ``data``, the sum over channels of
    |H|^2 on a second axis (a mode indicator).

    Returns the Figure.
    """
    import matplotlib.ticker

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(9, 5.5))
    lo, hi = diagram.band
    if data is not None:
        sel = (data.frequency_hz >= lo) & (data.frequency_hz <= hi)
        ind = np.sum(np.abs(data.H[:, :, sel]) ** 2, axis=(0, 1))
        ax2 = ax.twinx()
        ax2.semilogy(data.frequency_hz[sel], ind, color="0.6", lw=0.8)
        ax2.set_ylabel("sum of |H|^2 over channels", color="0.4")
        ax2.tick_params(axis="y", colors="0.4")
    for fm in diagram.modes_hz:
        ax.axvline(fm, color="tab:green", lw=0.8, alpha=0.6)
    for op in diagram.orders:
        st = op.stable
        ax.plot(op.frequency_hz[st], np.full(st.sum(), op.order), "o", color="tab:blue", ms=4)
        ax.plot(op.frequency_hz[~st], np.full((~st).sum(), op.order), "o", mfc="none",
                color="tab:red", ms=4)  # fmt: skip
    ax.axhline(diagram.auto_order, color="k", ls="--", lw=0.8)
    ax.yaxis.set_major_locator(matplotlib.ticker.MaxNLocator(integer=True))
    ax.set_xlim(lo, hi)
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("model order")
    ax.set_title(title or f"stabilisation {lo:g}-{hi:g} Hz: filled stable, hollow not; "
                 f"order chosen {diagram.auto_order}", fontsize=10)  # fmt: skip
    ax.set_zorder(3)
    ax.patch.set_visible(False)
    return save_figure(fig, path)
