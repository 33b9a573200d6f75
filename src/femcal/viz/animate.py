"""Animated GIFs of mode shapes, rendered off-screen with pyvista (imported only here).

Each mode is drawn as :func:`femcal.viz.render.render_modes` draws it (the same mesh,
isometric camera and viridis colouring by displacement magnitude over the faint undeformed
edges), oscillating over one period: frame k of n shows the shape times sin(2 pi k / n),
scaled so that the largest displacement is ``scale`` times the model's size, coloured by
the displacement at that instant (fixed range, so the colour swells with the motion). The
camera is set once, on the bounds of both extremes, so the model does not jump. The GIF is
written with Pillow on one palette shared by every frame, so
the colours do not flicker, and loops forever.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..atomic import write_atomic
from ..io.modes import basic_translations
from ..model.model import Model
from ..solve.normal_modes import Modes
from .render import SCALAR_BAR, _grid, mode_scale, structure_nodes


def phases(n_frames: int) -> np.ndarray:
    """(n_frames,) factors sin(2 pi k / n) of one period, k = 0 .. n-1."""
    return np.sin(2.0 * np.pi * np.arange(n_frames) / n_frames)


def animate_modes(
    modes: Modes,
    model: Model,
    out_dir: Path,
    *,
    title: str = "",
    scale: float = 0.08,
    n_frames: int = 24,
    fps: float = 12.0,
    window: tuple[int, int] = (800, 600),
    max_modes: int | None = None,
    which: Sequence[int] | None = None,
) -> list[Path]:
    """Write ``mode_NNN.gif`` for each mode into ``out_dir`` (each written atomically).

    Parameters
    ----------
    scale : largest displacement drawn as this fraction of the model's size.
    n_frames : frames per period (at least 2); fps : frames per second.
    max_modes : animate at most this many (all if None).
    which : 0-based mode indices to animate instead (overrides ``max_modes``).

    Returns
    -------
    Paths of the GIF files written.
    """
    if n_frames < 2:
        raise ValueError(f"n_frames {n_frames}: expected at least 2 frames per period")
    if not fps > 0:
        raise ValueError(f"fps {fps}: expected a positive frame rate")
    import pyvista as pv
    from vtkmodules.vtkCommonCore import vtkObject

    vtkObject.GlobalWarningDisplayOff()  # no X server here: VTK's notice is noise
    pv.OFF_SCREEN = True
    out_dir.mkdir(parents=True, exist_ok=True)
    base = _grid(model)
    xyz = np.asarray(model.xyz, dtype=float)
    size = float(np.ptp(xyz, axis=0).max()) or 1.0
    disp = basic_translations(modes, model)
    count = len(modes.eigenvalues) if max_modes is None else min(max_modes, len(modes.eigenvalues))
    s = phases(n_frames)
    paths: list[Path] = []
    structure = structure_nodes(model)
    for i in range(count) if which is None else which:
        u = disp[:, :, i]
        umax = mode_scale(u, structure)
        mag = np.minimum(np.linalg.norm(u, axis=1) / umax, 1.0)
        d = u * (scale * size / umax)
        grid = base.copy()
        grid.points = xyz + d
        grid.point_data["|u|"] = mag
        pl = pv.Plotter(off_screen=True, window_size=list(window))
        try:
            pl.add_mesh(base, style="wireframe", color="grey", opacity=0.35, line_width=1)
            pl.add_mesh(grid, scalars="|u|", cmap="viridis", clim=[0.0, 1.0], show_edges=False,
                        line_width=4, point_size=8,
                        scalar_bar_args=SCALAR_BAR)  # fmt: skip
            label = f"Mode {i + 1}: {modes.frequencies_hz[i]:.3f} Hz"
            pl.add_text(f"{title}  {label}" if title else label, font_size=12)
            both = np.vstack([xyz + d, xyz - d])
            bounds = np.ravel(np.column_stack([both.min(axis=0), both.max(axis=0)]))
            pl.view_isometric(bounds=tuple(float(b) for b in bounds))
            frames = []
            for f in s:
                grid.points = xyz + f * d
                grid.point_data["|u|"] = abs(f) * mag
                pl.render()
                frames.append(np.asarray(pl.screenshot(return_img=True)))
        finally:
            pl.close()
        path = out_dir / f"mode_{i + 1:03d}.gif"
        paths.append(write_atomic(path, lambda tmp, frames=frames: write_gif(tmp, frames, fps)))
    return paths


def write_gif(path: str | Path, frames: Sequence[np.ndarray], fps: float) -> None:
    """Write RGB(A) ``frames`` (h, w, 3|4 uint8 arrays) as a looping GIF at ``fps``, on one
    256-colour palette made from the first, a quarter and the last frame together."""
    from PIL import Image

    rgb = [np.ascontiguousarray(f[..., :3], dtype=np.uint8) for f in frames]
    probe = np.concatenate([rgb[0], rgb[len(rgb) // 4], rgb[-1]], axis=0)
    palette = Image.fromarray(probe).quantize(colors=256, method=Image.Quantize.MEDIANCUT)
    images = [Image.fromarray(f).quantize(palette=palette, dither=Image.Dither.NONE)
              for f in rgb]  # fmt: skip
    images[0].save(path, format="GIF", save_all=True, append_images=images[1:], loop=0,
                   duration=max(round(1000.0 / fps), 20), disposal=1)  # fmt: skip
