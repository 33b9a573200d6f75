"""matplotlib for files: the Agg backend (no display needed) and figures written atomically
as PNG."""

from __future__ import annotations

import os
import re
from types import ModuleType

import numpy as np

from ..atomic import write_atomic


def pyplot() -> ModuleType:
    """matplotlib.pyplot on the Agg backend, imported when first drawing."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig, path: str | os.PathLike[str], dpi: int = 110):
    """Lay out, write atomically as PNG and close a matplotlib figure; returns it."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    try:
        write_atomic(path, lambda tmp: fig.savefig(tmp, dpi=dpi))
    finally:
        plt.close(fig)
    return fig


def shape_scatter(ax, fe_shape: np.ndarray, test_shape: np.ndarray) -> float:
    """A test shape against its FE shape, component by component, on equal axes with the
    diagonal where they agree; returns the axes' half-width."""
    ax.plot(fe_shape, test_shape, ".", ms=4)
    lim = float(np.abs(np.concatenate([fe_shape, test_shape])).max()) * 1.05 or 1.0
    ax.plot([-lim, lim], [-lim, lim], "k--", lw=0.7)
    ax.set_xlim(-lim, lim)
    ax.set_ylim(-lim, lim)
    ax.set_aspect("equal")
    return lim


def mac_image(ax, M: np.ndarray, *, printed_above: float, fontsize: float,
              aspect: str = "auto"):  # fmt: skip
    """A MAC-like matrix (values 0-1) drawn on ``ax`` (viridis), each value over
    ``printed_above`` printed in its cell (dark on bright cells) at ``fontsize`` or smaller,
    as the cell's width allows; returns the image, for its colour bar."""
    im = ax.imshow(M, vmin=0, vmax=1, cmap="viridis", aspect=aspect)
    # a value must fit its cell: "0.38" is about 2.4 font sizes wide
    fig = ax.figure
    cell_pt = 72 * fig.get_size_inches()[0] * ax.get_position().width / max(M.shape[1], 1)
    if aspect != "auto":
        cell_pt = min(cell_pt, 72 * fig.get_size_inches()[1] * ax.get_position().height
                      / max(M.shape[0], 1))  # fmt: skip
    size = min(fontsize, 0.85 * cell_pt / 2.4)
    for (r, c), v in np.ndenumerate(M):
        if v > printed_above:
            ax.text(c, r, f"{v:.2f}", ha="center", va="center", fontsize=size,
                    color="k" if v > 0.6 else "w")  # fmt: skip
    return im


#: Axis labels that count rather than measure need no unit.
_COUNTS = ("mode", "channel", "sensor", "order", "input", "output", "start", "cycle", "step",
           "parameter", "iteration", "pair", "point", "grid", "configuration", "test", "FE")
#: A label that is a unit alone (``mm/s^2``, ``N``), over a panel its title names.
_UNIT_ALONE = re.compile(r"^[A-Za-z\u00b5\u00b0]{1,5}([/*^.][A-Za-z0-9\u00b5\u00b0^]{1,5})*$")
#: What marks a unit in a label.
_UNIT_MARKS = ("(", "[", "Hz", "%", "dB", "no unit")


def shows_ticks(axis) -> bool:
    """Whether an axis shows tick labels (shared axes hide theirs on inner panels)."""
    kw = axis._major_tick_kw  # what set_tick_params / label_outer set
    return axis.get_visible() and (kw.get("label1On", True) or kw.get("label2On", False))


def unlabelled_axes(fig) -> list[str]:
    """The axes of a figure a reader cannot read: an x, y (or z) axis that shows tick labels
    but has no label, or whose label gives no unit (a unit in parentheses or brackets,
    ``Hz``, ``%``, ``dB``, ``no unit``, or a unit alone over a panel) and is not a count
    (mode, channel, order ...). Each as ``"<axes title>: <which> axis <problem>"``; empty
    for a good figure."""
    problems = []
    suptitle = fig._suptitle.get_text() if fig._suptitle else ""
    for n, ax in enumerate(fig.axes):
        if not ax.get_visible() or not ax.axison:
            continue
        name = ax.get_title() or suptitle or f"axes {n + 1}"
        axes = [("x", ax.xaxis), ("y", ax.yaxis)]
        if hasattr(ax, "zaxis"):
            axes.append(("z", ax.zaxis))
        for which, axis in axes:
            if not shows_ticks(axis) or not len(axis.get_ticklocs()):
                continue
            label = axis.get_label_text().strip()
            if not label:
                problems.append(f"{name}: {which} axis has no label")
            elif not (any(m in label for m in _UNIT_MARKS) or _UNIT_ALONE.match(label)
                      or any(w.lower() in label.lower() for w in _COUNTS)):
                problems.append(f"{name}: {which} axis '{label}' gives no unit")
    return problems
