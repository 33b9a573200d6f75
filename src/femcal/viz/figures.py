"""matplotlib for files: the Agg backend (no display needed) and figures written atomically
as PNG."""

from __future__ import annotations

import os
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
    ``printed_above`` printed in its cell (dark on bright cells); returns the image, for its
    colour bar."""
    im = ax.imshow(M, vmin=0, vmax=1, cmap="viridis", aspect=aspect)
    for (r, c), v in np.ndenumerate(M):
        if v > printed_above:
            ax.text(c, r, f"{v:.2f}", ha="center", va="center", fontsize=fontsize,
                    color="k" if v > 0.6 else "w")  # fmt: skip
    return im
