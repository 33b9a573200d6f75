"""Plots of FRFs (matplotlib, Agg backend: no display needed), written atomically as PNG."""

from __future__ import annotations

import os

import numpy as np

from ..testdata.data import FRFData
from .figures import pyplot, save_figure


def frf_overlay(
    path: str | os.PathLike[str],
    test: FRFData,
    model: FRFData | None = None,
    *,
    pairs: list[tuple[int, int]] | None = None,
    max_panels: int = 12,
    title: str = "",
):
    """Grid of magnitude (log) and phase panels, one column per output/input pair: the test
    FRFs and, if given, the model's on top (same channels by label).

    Parameters
    ----------
    pairs : (output index, input index) of ``test`` to draw; default the first ``max_panels``
        pairs in output-major order.

    Returns
    -------
    The matplotlib Figure (already written to ``path``).

    Raises
    ------
    ValueError
        If the model lacks one of the drawn channels.
    """
    plt = pyplot()
    if pairs is None:
        pairs = [(o, i) for o in range(len(test.outputs)) for i in range(len(test.inputs))]
        pairs = pairs[:max_panels]
    cols = min(len(pairs), 4)
    rows = -(-len(pairs) // cols)
    fig, axes = plt.subplots(2 * rows, cols, figsize=(4.2 * cols, 4.4 * rows), squeeze=False,
                             sharex=True)  # fmt: skip
    m_out = {c.label: k for k, c in enumerate(model.outputs)} if model else {}
    m_in = {c.label: k for k, c in enumerate(model.inputs)} if model else {}
    for n, (o, i) in enumerate(pairs):
        r, c = divmod(n, cols)
        mag, ph = axes[2 * r, c], axes[2 * r + 1, c]
        h = test.H[o, i]
        mag.semilogy(test.frequency_hz, np.abs(h), color="k", lw=1.0, label="test")
        ph.plot(test.frequency_hz, np.degrees(np.angle(h)), color="k", lw=1.0)
        if model is not None:
            lo, li = test.outputs[o].label, test.inputs[i].label
            if lo not in m_out or li not in m_in:
                raise ValueError(f"the model has no FRF {lo} / {li}")
            hm = model.H[m_out[lo], m_in[li]]
            mag.semilogy(model.frequency_hz, np.abs(hm), color="tab:red", lw=1.0, label="model")
            ph.plot(model.frequency_hz, np.degrees(np.angle(hm)), color="tab:red", lw=1.0)
        mag.set_title(f"{test.outputs[o].label} / {test.inputs[i].label}", fontsize=9)
        mag.grid(True, which="both", alpha=0.3)
        ph.grid(True, alpha=0.3)
        ph.set_ylim(-180, 180)
        ph.set_yticks([-180, -90, 0, 90, 180])
        ph.set_xlabel("frequency (Hz)")
        if c == 0:
            mag.set_ylabel(f"|H| ({test.units})" if test.units else f"|{test.quantity}|")
            ph.set_ylabel("phase (deg)")
        if n == 0 and model is not None:
            mag.legend(fontsize=8)
    for n in range(len(pairs), rows * cols):  # empty panels
        r, c = divmod(n, cols)
        axes[2 * r, c].set_visible(False)
        axes[2 * r + 1, c].set_visible(False)
    if title:
        fig.suptitle(title)
    return save_figure(fig, path)


def stabilization_diagram(path: str | os.PathLike[str], diagram, data: FRFData | None = None,
                          *, title: str = ""):  # fmt: skip
    """Stabilisation diagram as PNG: the physical-looking poles of every model order
    (filled: stable, hollow: not) against frequency, the physical modes as vertical lines,
    the chosen order as a horizontal line and, with ``data``, the sum over channels of
    |H|^2 on a second axis (a mode indicator).

    ``diagram`` is a :class:`femcal.identify.Stabilization`. Returns the Figure.
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
