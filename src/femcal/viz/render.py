"""Off-screen pictures of mode shapes with pyvista (imported only here)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..atomic import write_atomic
from ..io.modes import basic_translations, mesh_cells
from ..model.model import Model
from ..solve.normal_modes import Modes

_VTK_TYPES = {
    "vertex": 1, "line": 3, "triangle": 5, "quad": 9, "tetra": 10, "hexahedron": 12,
    "wedge": 13, "pyramid": 14, "triangle6": 22, "quad8": 23, "tetra10": 24,
    "hexahedron20": 25, "wedge15": 26, "pyramid13": 27,
}  # fmt: skip


def _grid(model: Model):
    import pyvista as pv

    cells, types = [], []
    for kind, nodes in mesh_cells(model):
        k = nodes.shape[1]
        cells.append(np.hstack([np.full((len(nodes), 1), k), nodes]).ravel())
        types.append(np.full(len(nodes), _VTK_TYPES[kind], np.uint8))
    if not cells:
        raise ValueError("the model has no elements to draw")
    return pv.UnstructuredGrid(np.concatenate(cells), np.concatenate(types), model.xyz)


def render_modes(
    modes: Modes,
    model: Model,
    out_dir: Path,
    *,
    title: str = "",
    scale: float = 0.08,
    window: tuple[int, int] = (1280, 800),
    max_modes: int | None = None,
    which: Sequence[int] | None = None,
) -> list[Path]:
    """Render each mode: deformed shape coloured by displacement magnitude over the
    undeformed edges, with the mode number and frequency in the title.

    Parameters
    ----------
    scale : largest displacement drawn as this fraction of the model's size.
    max_modes : render at most this many (all if None).
    which : 0-based mode indices to render instead (overrides ``max_modes``).

    Returns
    -------
    Paths of the PNG files written (``mode_001.png`` ...), each written atomically.
    """
    import pyvista as pv
    from vtkmodules.vtkCommonCore import vtkObject

    vtkObject.GlobalWarningDisplayOff()  # no X server here: VTK's notice is noise
    pv.OFF_SCREEN = True
    out_dir.mkdir(parents=True, exist_ok=True)
    base = _grid(model)
    size = float(np.ptp(model.xyz, axis=0).max()) or 1.0
    disp = basic_translations(modes, model)
    paths: list[Path] = []
    count = len(modes.eigenvalues) if max_modes is None else min(max_modes, len(modes.eigenvalues))
    for i in range(count) if which is None else which:
        u = disp[:, :, i]
        umax = float(np.linalg.norm(u, axis=1).max()) or 1.0
        grid = base.copy()
        grid.points = model.xyz + u * (scale * size / umax)
        grid.point_data["|u|"] = np.linalg.norm(u, axis=1) / umax
        pl = pv.Plotter(off_screen=True, window_size=list(window))
        pl.add_mesh(base, style="wireframe", color="grey", opacity=0.35, line_width=1)
        pl.add_mesh(grid, scalars="|u|", cmap="viridis", show_edges=False, line_width=4,
                    point_size=8, scalar_bar_args={"title": "|u| (normalised)"})  # fmt: skip
        label = f"Mode {i + 1}: {modes.frequencies_hz[i]:.3f} Hz"
        pl.add_text(f"{title}  {label}" if title else label, font_size=12)
        pl.view_isometric()
        try:
            paths.append(write_atomic(out_dir / f"mode_{i + 1:03d}.png", pl.screenshot))
        finally:
            pl.close()
    return paths


def render_mesh(
    model: Model, path: Path, *, title: str = "", window: tuple[int, int] = (1600, 900)
) -> Path:
    """Render the undeformed mesh (element faces with their edges, coloured by element type)
    to the PNG ``path`` (written atomically)."""
    import pyvista as pv
    from vtkmodules.vtkCommonCore import vtkObject

    vtkObject.GlobalWarningDisplayOff()
    pv.OFF_SCREEN = True
    grid = _grid(model)
    grid.cell_data["cell type"] = grid.celltypes.astype(float)
    pl = pv.Plotter(off_screen=True, window_size=list(window))
    pl.add_mesh(grid, scalars="cell type", cmap="tab10", show_edges=True, edge_color="black",
                line_width=0.5, show_scalar_bar=False)  # fmt: skip
    if title:
        pl.add_text(title, font_size=12)
    pl.view_isometric()
    try:
        return write_atomic(path, pl.screenshot)
    finally:
        pl.close()
