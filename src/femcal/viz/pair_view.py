"""Test shapes over FE shapes in the 3-D viewer (:mod:`femcal.viz.webview`), pair by pair.

A test measures a few directions at a few grids. Each sensor grid's displacement is the
least-squares fit of its translational channels (a triaxial sensor's three readings, a
uniaxial one's along its direction; rotations are not drawn), for the test shape and for the
FE shape as the same channels see it, so the two are compared like with like. The test shape
is made real in the FE shape's phase and scale (the modal scale factor) before it comes here.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..testdata.data import Channel
from .webview import PairOverlay, ViewerMesh

_AXES = {"X": 0, "Y": 1, "Z": 2}


def channel_direction(channel: Channel, frame: np.ndarray) -> np.ndarray | None:
    """The unit vector (3,) in basic a channel measures along at a grid whose displacement
    frame has the axes ``frame`` (3, 3, columns in basic): ``+X``/``-Y``/``Z`` in basic,
    ``1``-``3`` (signed) along the frame's axes; None for a rotation."""
    d = (channel.direction or "").upper()
    sign = -1.0 if d.startswith("-") else 1.0
    axis = d.lstrip("+-")
    if axis in _AXES:
        return sign * np.eye(3)[_AXES[axis]]
    if axis.isdigit() and 1 <= int(axis) <= 3:
        return sign * np.asarray(frame, float)[:, int(axis) - 1]
    return None


def sensor_displacements(grids: Sequence[int], directions: Sequence[np.ndarray | None],
                         shapes: np.ndarray) -> tuple[list[int], np.ndarray]:  # fmt: skip
    """Each sensor grid's displacement in basic from its channels.

    ``grids`` (p,) each channel's grid id, ``directions`` (p,) its unit vector in basic (None:
    not drawn), ``shapes`` (p, k) real values at the channels. Returns the sensor grids in
    order of first appearance and their displacements (k, g, 3), each the least-squares fit
    of the grid's channels (minimum norm where they span fewer than three directions)."""
    shapes = np.asarray(shapes, float).reshape(len(grids), -1)
    rows: dict[int, list[int]] = {}
    for n, (g, v) in enumerate(zip(grids, directions, strict=True)):
        if v is not None:
            rows.setdefault(int(g), []).append(n)
    order = list(rows)
    out = np.zeros((shapes.shape[1], len(order), 3))
    for s, g in enumerate(order):
        d = np.array([directions[n] for n in rows[g]])
        out[:, s] = np.linalg.lstsq(d, shapes[rows[g]], rcond=None)[0].T
    return order, out


def sensor_edges(xyz: np.ndarray, k: int = 2) -> np.ndarray:
    """(Q, 2) each sensor joined to its ``k`` nearest neighbours (a wireframe of the test)."""
    xyz = np.asarray(xyz, float)
    if len(xyz) < 2:
        return np.zeros((0, 2), np.int64)
    d = np.linalg.norm(xyz[:, None, :] - xyz[None, :, :], axis=2)
    np.fill_diagonal(d, np.inf)
    near = np.argsort(d, axis=1)[:, : min(k, len(xyz) - 1)]
    pairs = np.sort(np.column_stack([np.repeat(np.arange(len(xyz)), near.shape[1]),
                                     near.ravel()]), axis=1)  # fmt: skip
    return np.unique(pairs, axis=0)


@dataclass(frozen=True)
class OverlayPair:
    """One pair to draw: ``label`` its name in the selector, ``fe_mode`` the page's mode
    (0-based row) it shows, ``test`` and ``fe`` (p,) real shapes at the channels (the test's
    in the FE shape's scale), ``mac`` its MAC."""

    label: str
    fe_mode: int
    test: np.ndarray
    fe: np.ndarray
    mac: float


def pair_overlay(mesh: ViewerMesh, frames: np.ndarray, channels: Sequence[Channel],
                 pairs: Sequence[OverlayPair], names: Mapping[str, str] | None = None
                 ) -> PairOverlay:  # fmt: skip
    """The overlay of ``pairs`` measured at ``channels`` on a mesh whose grids have the
    displacement frames ``frames`` (P, 3, 3). A sensor is named by its channels' sensor name
    (``names``: label -> ``L01 +X``, the first word) or else its grid id. ValueError for a
    channel on a grid the mesh lacks."""
    row_of = {int(g): n for n, g in enumerate(np.asarray(mesh.grid_ids).tolist())}
    missing = sorted({c.label for c in channels if c.grid is None or int(c.grid) not in row_of})
    if missing:
        raise ValueError(f"channels on no grid of the drawn model: {', '.join(missing)}")
    dirs = [channel_direction(c, frames[row_of[int(c.grid)]]) for c in channels]
    grids = [int(c.grid) for c in channels]
    names = names or {}
    columns = [c for p in pairs for c in (np.real(p.test), np.real(p.fe))]  # test, FE, ...
    shapes = np.column_stack(columns) if columns else np.zeros((len(channels), 0))
    order, disp = sensor_displacements(grids, dirs, shapes)
    label_of: dict[int, str] = {}
    for c in channels:
        name = names.get(c.label, c.label)
        label_of.setdefault(int(c.grid), str(c.grid) if name == c.label else name.split()[0])
    xyz = mesh.xyz[[row_of[g] for g in order]] if order else np.zeros((0, 3))
    disp = disp.reshape(len(pairs), 2, len(order), 3) if pairs else np.zeros((0, 2, 0, 3))
    return PairOverlay(xyz, tuple(label_of[g] for g in order), sensor_edges(xyz),
                       tuple(p.label for p in pairs),
                       np.array([p.fe_mode for p in pairs], np.int64),
                       disp[:, 0], disp[:, 1], np.array([p.mac for p in pairs]))  # fmt: skip


@dataclass(frozen=True)
class ShapePair:
    """A test mode and the FE mode paired with it: numbers from 1, frequencies in Hz, their
    MAC, and both shapes at the test's channels (p,): the test's as identified (complex, any
    scale), the FE's as solved (mass-normalised)."""

    test_mode: int
    test_hz: float
    fe_mode: int
    fe_hz: float
    mac: float
    test: np.ndarray
    fe: np.ndarray


def paired_modes_block(mesh: ViewerMesh, frames: np.ndarray,
                       translations: Callable[[list[int]], np.ndarray],
                       frequencies_hz: np.ndarray, channels: Sequence[Channel],
                       pairs: Sequence[ShapePair], names: Mapping[str, str] | None = None, *,
                       title: str = "", n: int = 0, free_rigid: int = 6) -> str:  # fmt: skip
    """The viewer (:func:`femcal.viz.webview.viewer_block`, the ``n``-th of its page) of
    ``pairs``: each paired FE mode animated on ``mesh`` (``translations(columns)``: (k, P, 3)
    the FE modes' translations in basic at the mesh's grids, for 0-based ``columns``;
    ``frequencies_hz`` of every FE mode), the test shape at the sensors over the FE shape as
    the same ``channels`` see it. The test shape is made real in the FE shape's phase and
    scale (the modal scale factor). ``free_rigid``: the rigid motions the model's supports
    leave free (:func:`femcal.viz.webview.free_rigid_motions`; 6 when not known)."""
    from ..correlate.shapes import in_scale_of, mac_text
    from .webview import viewer_block, viewer_data

    columns = sorted({p.fe_mode - 1 for p in pairs})
    row = {c: k for k, c in enumerate(columns)}
    overlay = pair_overlay(mesh, frames, channels, [
        OverlayPair(f"test {p.test_mode} ({p.test_hz:.2f} Hz) / FE {p.fe_mode} "
                    f"({p.fe_hz:.2f} Hz), MAC {mac_text(p.mac, 2)}", row[p.fe_mode - 1],
                    in_scale_of(p.test, p.fe), np.real(p.fe), p.mac)
        for p in pairs], names)  # fmt: skip
    freqs = np.asarray(frequencies_hz)[columns]
    data = viewer_data(mesh, translations(columns), freqs, title=title,
                       mode_numbers=np.array(columns) + 1, overlay=overlay,
                       free_rigid=free_rigid)  # fmt: skip
    return viewer_block(data, n=n)
