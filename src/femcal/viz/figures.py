"""matplotlib for files: the Agg backend (no display needed) and figures written atomically
as PNG."""

from __future__ import annotations

import os
from types import ModuleType

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
