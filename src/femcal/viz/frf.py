"""FRF overlays (matplotlib, Agg backend: no display needed), written atomically as PNG."""

from __future__ import annotations

import os

import numpy as np

from ..testdata.data import FRFData
from .figures import pyplot, save_figure


def phase_line(f: np.ndarray, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(frequencies, phase in degrees wrapped to (-180, 180]) with a NaN point between two
    lines where the phase wraps, so that a line drawn through it does not cross the panel
    at each wrap."""
    deg = np.degrees(np.angle(h))
    jump = np.flatnonzero(np.abs(np.diff(deg)) > 180.0) + 1
    return np.insert(np.asarray(f, float), jump, np.nan), np.insert(deg, jump, np.nan)


def frf_overlay(
    path: str | os.PathLike[str],
    test: FRFData,
    model: FRFData | None = None,
    *,
    pairs: list[tuple[int, int]] | None = None,
    max_panels: int = 12,
    title: str = "",
    columns: int = 4,
):
    """Grid of magnitude (log) and phase panels, one column per output/input pair: the test
    FRFs and, if given, the model's on top (same channels by label). The test's phase is
    drawn as points (a measured phase wraps and scatters: lines through it turn into
    bands), the model's as a line broken where it wraps.

    Parameters
    ----------
    pairs : (output index, input index) of ``test`` to draw; default the first ``max_panels``
        pairs in output-major order.
    columns : panels side by side at most (fewer and larger read better on a page).

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
    cols = min(len(pairs), max(columns, 1))
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
        ph.plot(test.frequency_hz, np.degrees(np.angle(h)), ".", color="k", ms=1.5, mew=0)
        if model is not None:
            lo, li = test.outputs[o].label, test.inputs[i].label
            if lo not in m_out or li not in m_in:
                raise ValueError(f"the model has no FRF {lo} / {li}")
            hm = model.H[m_out[lo], m_in[li]]
            mag.semilogy(model.frequency_hz, np.abs(hm), color="tab:red", lw=1.0, label="model")
            ph.plot(*phase_line(model.frequency_hz, hm), color="tab:red", lw=1.0)
        mag.set_title(f"{test.outputs[o].label} / {test.inputs[i].label}", fontsize=9)
        mag.grid(True, which="both", alpha=0.3)
        ph.grid(True, alpha=0.3)
        ph.set_ylim(-180, 180)
        ph.set_yticks([-180, -90, 0, 90, 180])
        ph.set_xlabel("frequency (Hz)")
        mag.set_ylabel(f"|H| ({test.units})" if test.units
                       else f"|{test.quantity}| (units not given)")  # fmt: skip
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
