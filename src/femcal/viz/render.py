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


#: A mode's colour and drawn deflection are scaled to the largest motion of the structure's
#: surfaces (shells, solids); bars, springs and rigid legs that move more are drawn at most
#: this many times that scale, their colour at the scale's top.
OUTLIER_DRAWN = 3.0


def structure_nodes(model: Model) -> np.ndarray:
    """The nodes a mode picture is scaled by: those of shells and solids, else those of the
    bars and beams, else every grid (indices into the model's nodes)."""
    surface, lines = [], []
    for kind, nodes in mesh_cells(model):
        if kind not in ("line", "vertex"):
            surface.append(nodes.ravel())
        elif kind == "line":
            lines.append(nodes.ravel())
    for found in (surface, lines):
        if found:
            return np.unique(np.concatenate(found))
    return np.flatnonzero(model.is_grid)


#: The colour bar of a mode picture: deflection over the scale of :func:`mode_scale`.
SCALAR_BAR = {"title": "deflection / largest", "vertical": True, "position_x": 0.84,
              "position_y": 0.15, "height": 0.6, "fmt": "%.2f"}


def mode_scale(u: np.ndarray, structure: np.ndarray) -> float:
    """The deflection a mode picture calls 1 (colour's top, drawn at the picture's scale):
    the largest on the ``structure`` nodes (:func:`structure_nodes`), or a third of the
    overall largest if that is more (so a bar or spring that moves far more is drawn at
    most ``OUTLIER_DRAWN`` times the scale). ``u`` (n_nodes, 3)."""
    mag = np.linalg.norm(u, axis=1)
    top = float(mag.max())
    if top == 0:
        return 1.0
    ref = float(mag[structure].max()) if len(structure) else 0.0
    return max(ref, top / OUTLIER_DRAWN)


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
    undeformed edges, with the mode number and frequency in the title. Colour and deflection
    are scaled to the largest motion of the structure's surfaces (:func:`structure_nodes`),
    so a mode whose largest motion is in a bracket's bar or a mount's spring still shows the
    frame's shape; those parts are drawn at most ``OUTLIER_DRAWN`` times that scale.

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
    structure = structure_nodes(model)
    paths: list[Path] = []
    count = len(modes.eigenvalues) if max_modes is None else min(max_modes, len(modes.eigenvalues))
    for i in range(count) if which is None else which:
        u = disp[:, :, i]
        mag = np.linalg.norm(u, axis=1)
        ref = mode_scale(u, structure)
        grid = base.copy()
        grid.points = model.xyz + u * (scale * size / ref)
        grid.point_data["|u|"] = np.minimum(mag / ref, 1.0)
        pl = pv.Plotter(off_screen=True, window_size=list(window))
        pl.add_mesh(base, style="wireframe", color="grey", opacity=0.35, line_width=1)
        pl.add_mesh(grid, scalars="|u|", cmap="viridis", clim=(0.0, 1.0), show_edges=False,
                    line_width=4, point_size=8,
                    scalar_bar_args=SCALAR_BAR)  # fmt: skip
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
