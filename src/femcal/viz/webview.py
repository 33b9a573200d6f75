"""An interactive 3-D viewer of mode shapes: one self-contained HTML file, no server.

:func:`write_webview` writes a page that any current browser opens from disk: no external
script, style sheet, font or network request; the model and its modes are in the file, drawn
by vanilla JavaScript on a ``<canvas>`` (an orthographic projection). The viewer is also a
block other pages embed (:func:`viewer_block` and, once per page, :func:`viewer_assets`): the
correlation and calibration pages show their paired modes in it, the test shape at the sensors
over the FE shape (:mod:`femcal.viz.pair_view`). It has:

- the shells' faces and the solids' outer faces, shaded by their angle to the view and drawn
  far to near (the painter's order, sorted when the view turns), so what lies behind a
  surface is hidden; their edges outlined where the elements are large enough on screen;
  bars, rigid elements' legs (RBE2, RBAR, RBE3; dashed red) and springs between two grids
  (CELAS1/2, CBUSH; orange) as lines in the same order; masses (CONM1/2) and springs to
  ground as small squares; with the surfaces off, the wireframe of every edge;
- a mode selector with each mode's frequency, rigid-body modes marked (a rigid motion explains
  at least :data:`femcal.correlate.shapes.RIGID_SHARE` of the shape) and the other modes at
  zero frequency too (:func:`near_zero`: mechanisms), opening on the first flexible mode;
  animation on or off (one period in 2 s: the shape times sin(2 pi t / 2 s)), a "drawn
  scale" slider (the largest deflection as drawn, in the model's length unit, 8 % of the
  model's size to start: a mode shape has no size of its own), colouring by the deflection
  drawn with its legend in that unit, the undeformed edges faint;
- an axis triad; mouse drag to rotate, shift-drag (or the right button) to pan, the wheel to
  zoom, double-click to return to the isometric view; a click names the grid (or sensor)
  under the pointer, nearest the eye, with its position and its motion in the mode.

The data are one JSON block per viewer (``<script type="application/json"
class="femcal-data">``) whose arrays are base64 of little-endian binary: grid coordinates in
basic (float32, the model's units), grid ids (int32), edges (uint32 pairs of grid rows) and
their kinds, faces (uint32 quadruples, a triangle repeating its third corner), each mode's
translations in basic at every grid (float32, divided by the mode's largest translation,
``modes[i].max``, so each mode's largest is 1), and optionally the test overlay.
:func:`read_webview` decodes them. The page sets ``data-femcal="ok"`` on its ``<html>``
element once every viewer has drawn (``"error: ..."`` on a script error); ``#still`` after
the file name starts it with the animation off, and ``#selftest`` (or ``#still-selftest``)
also steps through the modes, drives the mouse handlers (drag, wheel, double-click, a click
on the grid nearest the eye), toggles scale, colour and surfaces and sets
``data-femcal-selftest`` to ``pass`` or ``fail: <reasons>``. :func:`browser_check` opens a
page so in a headless Chromium and reports both, the console's messages and a screenshot
(``benchmarks/webview_check.py``).

Size: 16 bytes per grid and mode (float32 x 3 in base64) plus the grids, edges and faces: the
hammer frame (16 059 grids, 32 239 lines, 14 964 faces, its 14 modes to 150 Hz) makes a page
of 4.7 MB, written in 0.1 s.
"""

from __future__ import annotations

import base64
import html
import json
import os
import re
import shutil
import signal
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..atomic import write_atomic
from ..io.modes import RIGID_TYPES, basic_translations, element_cells
from ..io.uff_shapes import mesh_edges
from ..model.model import Model
from ..solve.normal_modes import Modes

#: Modes a page holds unless told otherwise (20 keep the hammer frame's page under 8 MB).
MAX_MODES = 20
#: Edge kinds of the page's ``edge_kind`` array: lines of line elements (bars, beams, rods),
#: rigid elements' legs, springs between two grids, and sides of shells and solids (drawn
#: as the faces' outlines when the surfaces are shown).
EDGE_ELEMENT, EDGE_RIGID, EDGE_SPRING, EDGE_SURFACE = 0, 1, 2, 3
#: Marker kinds of the page's ``marker_kind`` array.
MARKER_MASS, MARKER_GROUND_SPRING = 0, 1
_SPRING_TYPES = ("CELAS1", "CELAS2", "CBUSH")
_MASS_TYPES = ("CONM1", "CONM2")
#: Corner faces of each cell kind (VTK corner order, which :func:`element_cells` keeps);
#: a triangle repeats its last corner to make four.
_FACES: dict[str, list[tuple[int, int, int, int]]] = {
    "triangle": [(0, 1, 2, 2)],
    "triangle6": [(0, 1, 2, 2)],
    "quad": [(0, 1, 2, 3)],
    "quad8": [(0, 1, 2, 3)],
    "tetra": [(0, 2, 1, 1), (0, 1, 3, 3), (1, 2, 3, 3), (0, 3, 2, 2)],
    "pyramid": [(0, 3, 2, 1), (0, 1, 4, 4), (1, 2, 4, 4), (2, 3, 4, 4), (3, 0, 4, 4)],
    "wedge": [(0, 1, 2, 2), (3, 5, 4, 4), (0, 3, 4, 1), (1, 4, 5, 2), (2, 5, 3, 0)],
    "hexahedron": [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6),
                   (3, 0, 4, 7)],
}  # fmt: skip
_SOLIDS = ("tetra", "pyramid", "wedge", "hexahedron")


def _b64(a: np.ndarray, dtype: str) -> str:
    return base64.b64encode(np.ascontiguousarray(a, dtype=dtype).tobytes()).decode("ascii")


def _unb64(s: str, dtype: str) -> np.ndarray:
    return np.frombuffer(base64.b64decode(s), dtype=dtype)


@dataclass(frozen=True)
class ViewerMesh:
    """What the viewer draws of a model, its grids as rows ``0 .. P-1``.

    Attributes
    ----------
    xyz : (P, 3) grid positions in the basic frame (model length unit).
    grid_ids : (P,) their ids.
    edges : (E, 2) rows of ``xyz`` joined by a line; ``edge_kind`` (E,) ``EDGE_*``.
    faces : (F, 4) rows of ``xyz`` at the corners of each shell and of each solid's outer
        faces (a triangle repeats its third corner).
    markers : (K,) rows of ``xyz`` with a mass or a spring to ground; ``marker_kind`` (K,).
    unit : the model's length unit (``mm``, ``m``) or ``""`` when its cards do not tell.
    """

    xyz: np.ndarray
    grid_ids: np.ndarray
    edges: np.ndarray
    edge_kind: np.ndarray
    faces: np.ndarray
    markers: np.ndarray
    marker_kind: np.ndarray
    unit: str = ""

    @property
    def n_points(self) -> int:
        return len(self.xyz)


def viewer_mesh(model: Model) -> ViewerMesh:
    """The lines, faces and markers of a model's grids and elements (see the module)."""
    from ..model.units import length_unit

    grids = np.flatnonzero(model.is_grid)
    if not len(grids):
        raise ValueError("the model has no grids to draw")
    row = np.full(model.n_nodes, -1, np.int64)
    row[grids] = np.arange(len(grids))
    blocks = element_cells(model)
    pairs = model.node_index(mesh_edges(model).ravel()).reshape(-1, 2)
    springs = [b.nodes for b in blocks if b.element_type in _SPRING_TYPES and b.kind == "line"]
    if springs:
        pairs = np.vstack([pairs, *springs])
    pairs = np.sort(pairs, axis=1)
    pairs = pairs[(pairs[:, 0] != pairs[:, 1]) & model.is_grid[pairs].all(axis=1)]
    pairs = np.unique(pairs, axis=0) if len(pairs) else np.zeros((0, 2), np.int64)

    def keys(p: np.ndarray) -> np.ndarray:
        return p[:, 0] * model.n_nodes + p[:, 1]

    def edge_keys(select) -> np.ndarray:
        got = [np.sort(b.nodes[:, list(e)], axis=1) for b in blocks if select(b)
               for e in _edge_list(b.kind)]  # fmt: skip
        return keys(np.vstack(got)) if got else np.zeros(0, np.int64)

    lines = edge_keys(lambda b: b.kind == "line"
                      and b.element_type not in (*RIGID_TYPES, *_SPRING_TYPES))  # fmt: skip
    surface = edge_keys(lambda b: b.kind != "line")
    k = keys(pairs)
    kind = np.full(len(pairs), EDGE_ELEMENT, np.uint8)
    kind[np.isin(k, surface) & ~np.isin(k, lines)] = EDGE_SURFACE
    element = np.isin(k, lines) | np.isin(k, surface)
    spring = np.isin(k, edge_keys(lambda b: b.element_type in _SPRING_TYPES and b.kind == "line"))
    rigid = np.isin(k, edge_keys(lambda b: b.element_type in RIGID_TYPES and b.kind == "line"))
    kind[spring & ~element] = EDGE_SPRING
    kind[rigid & ~element] = EDGE_RIGID

    markers, marker_kind = [], []
    for b in blocks:
        if b.kind != "vertex":
            continue
        if b.element_type in _MASS_TYPES:
            markers.append(b.nodes[:, 0])
            marker_kind.append(np.full(len(b.nodes), MARKER_MASS, np.uint8))
        elif b.element_type in _SPRING_TYPES:
            markers.append(b.nodes[:, 0])
            marker_kind.append(np.full(len(b.nodes), MARKER_GROUND_SPRING, np.uint8))
    mk = np.concatenate(markers) if markers else np.zeros(0, np.int64)
    mkk = np.concatenate(marker_kind) if marker_kind else np.zeros(0, np.uint8)
    keep = model.is_grid[mk] if len(mk) else np.zeros(0, bool)
    faces = _faces(blocks, model.is_grid)
    return ViewerMesh(model.xyz[grids], model.node_ids[grids], row[pairs], kind,
                      row[faces] if len(faces) else np.zeros((0, 4), np.int64),
                      row[mk[keep]], mkk[keep], length_unit(model) or "")  # fmt: skip


def _faces(blocks, is_grid: np.ndarray) -> np.ndarray:
    """(F, 4) node indices of the shells' faces and the solids' outer faces (a face two
    solids share is inside and left out)."""
    from ..io.uff_shapes import _CORNERS

    shells, solids = [], []
    for b in blocks:
        corner_kind = _CORNERS.get(b.kind, b.kind)
        for face in _FACES.get(corner_kind, ()):
            f = b.nodes[:, list(face)]
            (solids if corner_kind in _SOLIDS else shells).append(f)
    out = list(shells)
    if solids:
        f = np.vstack(solids)
        key = f.copy()
        key[f[:, 3] == f[:, 2], 3] = -1  # a triangle: one key whichever corner it starts at
        key = np.sort(key, axis=1)
        _, first, count = np.unique(key, axis=0, return_index=True, return_counts=True)
        out.append(f[first[count == 1]])
    if not out:
        return np.zeros((0, 4), np.int64)
    f = np.vstack(out)
    return f[(f >= 0).all(axis=1) & is_grid[np.maximum(f, 0)].all(axis=1)]


def grid_cloud(xyz: np.ndarray, grid_ids: np.ndarray, unit: str = "") -> ViewerMesh:
    """A mesh of points only: the grids of a modes file read without its deck."""
    none = np.zeros((0, 2), np.int64)
    return ViewerMesh(np.asarray(xyz, float), np.asarray(grid_ids), none,
                      np.zeros(0, np.uint8), np.zeros((0, 4), np.int64),
                      np.zeros(0, np.int64), np.zeros(0, np.uint8), unit)  # fmt: skip


@dataclass(frozen=True)
class PairOverlay:
    """Test shapes drawn over the FE ones, one paired mode at a time.

    Attributes
    ----------
    sensor_xyz : (S, 3) sensor positions in basic (model length unit); ``sensor_names`` (S,).
    sensor_edges : (Q, 2) sensors joined by a line (a wireframe of the test).
    labels : (n,) each pair's name in the selector.
    fe_mode : (n,) the page's mode (0-based row of its modes) each pair shows.
    test, fe : (n, S, 3) the test shape and the FE shape as the test's channels see it, at
        each sensor in basic, in the FE mode's (mass-normalised) scale: the test shape
        scaled by the modal scale factor.
    mac : (n,) each pair's MAC.
    """

    sensor_xyz: np.ndarray
    sensor_names: tuple[str, ...]
    sensor_edges: np.ndarray
    labels: tuple[str, ...]
    fe_mode: np.ndarray
    test: np.ndarray
    fe: np.ndarray
    mac: np.ndarray


def _mass_unit(unit: str) -> str:
    return {"mm": "t", "m": "kg"}.get(unit, "")


def viewer_data(
    mesh: ViewerMesh,
    translations: np.ndarray,
    frequencies_hz: np.ndarray,
    *,
    title: str = "",
    mode_numbers: np.ndarray | None = None,
    overlay: PairOverlay | None = None,
    free_rigid: int = 6,
) -> dict:
    """A viewer's data block as a JSON-ready dict (see the module's description).

    ``translations`` (m, P, 3) each mode's translations at the mesh's grids in basic
    (mass-normalised shapes); ``frequencies_hz`` (m,); ``mode_numbers`` (m,) their numbers
    as solved (default 1 .. m). Rigid-body modes are marked: the lowest ``free_rigid`` (the
    rigid motions the supports leave free, :func:`free_rigid_motions`) of those a rigid
    motion explains (:func:`femcal.correlate.rigid_share` at least
    :data:`~femcal.correlate.shapes.RIGID_SHARE`); the page starts on the first mode that
    is not one (or on the first pair of an ``overlay``)."""
    from ..correlate.shapes import RIGID_SHARE, rigid_share

    disp = np.asarray(translations, float)
    n_modes, p = disp.shape[0], mesh.n_points
    if disp.shape[1:] != (p, 3):
        raise ValueError(f"translations of shape {disp.shape}; expected (m, {p}, 3)")
    umax = np.linalg.norm(disp, axis=2).max(axis=1) if p else np.zeros(n_modes)
    umax = np.where(umax > 0, umax, 1.0)
    shapes = disp / umax[:, None, None]
    rigid = np.zeros(n_modes, bool)
    if n_modes and p >= 3:
        rigid = rigid_share(mesh.xyz, disp) >= RIGID_SHARE
        rigid[np.flatnonzero(rigid)[max(free_rigid, 0):]] = False
    zero = near_zero(np.asarray(frequencies_hz, float))
    flexible = np.flatnonzero(~rigid & ~zero)
    numbers = np.arange(1, n_modes + 1) if mode_numbers is None else np.asarray(mode_numbers)
    xyz = mesh.xyz
    lo, hi = xyz.min(axis=0), xyz.max(axis=0)
    mass = _mass_unit(mesh.unit)
    data = {
        "format": "femcal-webview 2",
        "title": title,
        "unit": mesh.unit,
        "shape_unit": f"{mesh.unit}/\u221a{mass}" if mass else "",
        "n_points": p,
        "n_edges": len(mesh.edges),
        "n_faces": len(mesh.faces),
        "n_markers": len(mesh.markers),
        "n_modes": n_modes,
        "start": int(flexible[0]) if len(flexible) else 0,
        "center": ((lo + hi) / 2).tolist(),
        "size": float(np.ptp(xyz, axis=0).max()) or 1.0,
        "points": _b64(xyz, "<f4"),
        "grid_ids": _b64(mesh.grid_ids, "<i4"),
        "edges": _b64(mesh.edges, "<u4"),
        "edge_kind": _b64(mesh.edge_kind, "u1"),
        "faces": _b64(mesh.faces, "<u4"),
        "markers": _b64(mesh.markers, "<u4"),
        "marker_kind": _b64(mesh.marker_kind, "u1"),
        "modes": [
            {
                "mode": int(numbers[i]),
                "frequency_hz": float(frequencies_hz[i]),
                "max": float(umax[i]),
                "rigid": bool(rigid[i]),
                "zero": bool(zero[i]),
            }
            for i in range(n_modes)
        ],
        "shapes": _b64(shapes, "<f4"),
    }
    if overlay is not None:
        o = overlay
        scale = umax[np.asarray(o.fe_mode, int)][:, None, None] if len(o.labels) else 1.0
        data["overlay"] = {
            "n_sensors": len(o.sensor_xyz),
            "n_sensor_edges": len(o.sensor_edges),
            "n_pairs": len(o.labels),
            "sensor_points": _b64(o.sensor_xyz, "<f4"),
            "sensor_names": list(o.sensor_names),
            "sensor_edges": _b64(o.sensor_edges, "<u4"),
            "pairs": [
                {"label": o.labels[i], "mode": int(o.fe_mode[i]), "mac": float(o.mac[i])}
                for i in range(len(o.labels))
            ],
            "test": _b64(np.asarray(o.test) / scale, "<f4"),
            "fe": _b64(np.asarray(o.fe) / scale, "<f4"),
        }
        data["start"] = 0
    return data


#: A frequency at most this (Hz), or this share of the highest solved, is zero: a rigid-body
#: or mechanism mode whatever its shape (roundoff leaves it a hair off zero, either side).
ZERO_HZ, ZERO_SHARE = 1e-3, 1e-4


def near_zero(frequencies_hz: np.ndarray) -> np.ndarray:
    """(m,) True for the modes whose frequency is zero to the solution's precision
    (:data:`ZERO_HZ`, :data:`ZERO_SHARE`)."""
    f = np.abs(np.asarray(frequencies_hz, float))
    if not len(f):
        return np.zeros(0, bool)
    return f <= max(ZERO_HZ, ZERO_SHARE * float(f.max()))


def free_rigid_motions(modes: Modes, model: Model) -> int:
    """How many independent rigid-body motions a model's supports leave free: 6 less the rank
    of the rigid motions at the DOFs its constraints hold (those no solved mode moves, less
    the empty DOFs AUTOSPC fixed, which hold nothing). 6 for a free body or one on springs,
    0 for a clamped one."""
    from ..assembly.weight import rigid_body_vectors

    held = (modes.shapes == 0).all(axis=1)
    if len(modes.autospc):
        rows = model.node_index(modes.autospc[:, 0])
        held[model.dof_start[rows] + modes.autospc[:, 1] - 1] = False
    if not held.any():
        return 6
    grids = model.xyz[model.is_grid]
    centre = (grids.min(axis=0) + grids.max(axis=0)) / 2
    size = float(np.ptp(grids, axis=0).max()) or 1.0
    basis = rigid_body_vectors(model, centre)[held]
    basis[:, 3:] /= size  # turns of one radian over the model's size: all columns alike
    return 6 - int(np.linalg.matrix_rank(basis, tol=1e-8 * max(np.abs(basis).max(), 1e-300)))


def webview_data(
    modes: Modes, model: Model, *, title: str = "", max_modes: int | None = MAX_MODES
) -> dict:
    """The page's data block of a model's first ``max_modes`` modes (all if None)."""
    mesh = viewer_mesh(model)
    n_all = len(modes.eigenvalues)
    n_modes = n_all if max_modes is None else min(max_modes, n_all)
    grids = np.flatnonzero(model.is_grid)
    disp = basic_translations(modes, model)[grids][:, :, :n_modes]  # (P, 3, m)
    return viewer_data(mesh, np.moveaxis(disp, 2, 0), modes.frequencies_hz[:n_modes],
                       title=title, free_rigid=free_rigid_motions(modes, model))  # fmt: skip


def _edge_list(kind: str) -> list[tuple[int, int]]:
    """Corner-to-corner pairs of a cell kind (sides of quadratic shells through their
    midside nodes)."""
    from ..io.uff_shapes import _CORNERS, _EDGES, _SIDES

    if kind in _SIDES:
        return [p for a, m, b in _SIDES[kind] for p in ((a, m), (m, b))]
    return list(_EDGES.get(_CORNERS.get(kind, kind), []))


def _data_script(data: dict, n: int) -> str:
    blob = json.dumps(data, separators=(",", ":")).replace("<", "\\u003c")
    name = "femcal-data" if n == 0 else f"femcal-data-{n}"
    return f'<script type="application/json" class="femcal-data" id="{name}">{blob}</script>'


def viewer_block(data: dict, *, n: int = 0, full: bool = False) -> str:
    """The HTML of one viewer (its controls, canvas and data) to put in a page that also
    carries :func:`viewer_assets` once; ``n`` numbers the page's viewers from 0."""
    overlay = "overlay" in data
    test = ('<label title="test shape (red) and FE shape at the sensors (blue)">'
            '<input type="checkbox" class="fv-test" checked> sensors</label>'
            if overlay else "")  # fmt: skip
    what = "Pair" if overlay else "Mode"
    return (
        f'<div class="femcal-viewer{" fv-full" if full else ""}" data-viewer="{n}">\n'
        '<div class="fv-bar"><b class="fv-name"></b>\n'
        f'<label>{what} <select class="fv-mode"></select></label>\n'
        '<label><input type="checkbox" class="fv-anim" checked> animate</label>\n'
        '<label title="the largest deflection as drawn: a mode shape has no size of its own">'
        'drawn scale <input type="range" class="fv-scale" min="0" max="0.3" step="0.005"'
        ' value="0.08"> <span class="fv-scaleval"></span></label>\n'
        '<label><input type="checkbox" class="fv-surf" checked> surfaces</label>\n'
        '<label><input type="checkbox" class="fv-colour" checked> colour</label>\n'
        '<label><input type="checkbox" class="fv-undef" checked> undeformed</label>\n'
        f"{test}<span class=\"fv-err\"></span></div>\n"
        '<canvas class="fv-view"></canvas>\n<div class="fv-info"></div>\n'
        '<div class="fv-help">drag: rotate &middot; shift-drag or right button: pan &middot; '
        "wheel: zoom &middot; click: a grid's id and motion &middot; double-click: reset"
        + "".join(f" &middot; {k}" for k in _keys(data))
        + "</div>\n"
        f"{_data_script(data, n)}\n</div>"
    )  # fmt: skip


def _keys(data: dict) -> list[str]:
    """The help line's key to what the drawing holds."""
    kinds = set(_unb64(data["edge_kind"], "u1").tolist())
    marks = set(_unb64(data["marker_kind"], "u1").tolist())
    keys = ["red: test, blue: FE at the sensors"] if "overlay" in data else []
    keys += [text for present, text in ((EDGE_RIGID in kinds, "red dashed: rigid elements"),
                                        (EDGE_SPRING in kinds, "orange: springs"),
                                        (MARKER_MASS in marks, "black squares: masses"),
                                        (MARKER_GROUND_SPRING in marks,
                                         "orange squares: springs to ground"))
             if present]  # fmt: skip
    return keys


def viewer_assets() -> tuple[str, str]:
    """The viewers' style sheet and script (``<style>`` and ``<script>`` elements), once
    per page, the script after the last viewer."""
    return f"<style>{_STYLE.strip()}</style>", f"<script>\n{_SCRIPT.strip()}\n</script>"


def render_page(data: dict) -> str:
    """The standalone HTML page of a data block from :func:`viewer_data`."""
    style, script = viewer_assets()
    title = html.escape(f"femcal modes: {data.get('title') or 'model'}")
    return ("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
            '<meta name="viewport" content="width=device-width, initial-scale=1">\n'
            f"<title>{title}</title>\n{style}\n</head>\n<body>\n"
            f"{viewer_block(data, full=True)}\n{script}\n</body>\n</html>\n")  # fmt: skip


def write_webview(
    path: Path,
    modes: Modes,
    model: Model,
    *,
    title: str = "",
    max_modes: int | None = MAX_MODES,
) -> Path:
    """Write the page of the first ``max_modes`` modes (all if None) to ``path``, atomically.
    Returns ``path``."""
    page = render_page(webview_data(modes, model, title=title, max_modes=max_modes))

    def w(tmp: str) -> None:
        Path(tmp).write_text(page, encoding="utf-8")

    return write_atomic(path, w)


_DATA_RE = re.compile(
    r'<script type="application/json" class="femcal-data" id="femcal-data[-0-9]*">(.*?)'
    r"</script>", re.S)  # fmt: skip


def read_webview(source: str | Path, n: int = 0) -> dict:
    """Decode a page's ``n``-th viewer (a path or the page's text): the data block with its
    arrays as NumPy arrays: ``points`` (P, 3), ``grid_ids`` (P,), ``edges`` (E, 2) rows of
    ``points``, ``edge_kind`` (E,), ``faces`` (F, 4), ``markers`` (K,), ``marker_kind``
    (K,), ``shapes`` (m, P, 3) the translations in basic as solved (the stored unit shapes
    times each mode's ``max``); with an overlay, its ``test`` and ``fe`` (n, S, 3) in the
    same scale as ``shapes``."""
    text = Path(source).read_text(encoding="utf-8") if isinstance(source, Path) else source
    found = _DATA_RE.findall(text)
    if len(found) <= n:
        raise ValueError(f"no femcal viewer {n} in the page ({len(found)} found)")
    d = json.loads(found[n])
    p, e, k, nm = d["n_points"], d["n_edges"], d["n_markers"], d["n_modes"]
    out = dict(d)
    out["points"] = _unb64(d["points"], "<f4").reshape(p, 3)
    out["grid_ids"] = _unb64(d["grid_ids"], "<i4")
    out["edges"] = _unb64(d["edges"], "<u4").reshape(e, 2)
    out["edge_kind"] = _unb64(d["edge_kind"], "u1")
    out["faces"] = _unb64(d["faces"], "<u4").reshape(d["n_faces"], 4)
    out["markers"] = _unb64(d["markers"], "<u4").reshape(k)
    out["marker_kind"] = _unb64(d["marker_kind"], "u1")
    unit = _unb64(d["shapes"], "<f4").reshape(nm, p, 3)
    scale = np.array([mode["max"] for mode in d["modes"]], dtype=float).reshape(nm, 1, 1)
    out["unit_shapes"] = unit
    out["shapes"] = unit * scale
    if "overlay" in d:
        o = dict(d["overlay"])
        s, q, n_pairs = o["n_sensors"], o["n_sensor_edges"], o["n_pairs"]
        o["sensor_points"] = _unb64(o["sensor_points"], "<f4").reshape(s, 3)
        o["sensor_edges"] = _unb64(o["sensor_edges"], "<u4").reshape(q, 2)
        pair_scale = np.array([scale[pr["mode"], 0, 0] for pr in o["pairs"]]).reshape(-1, 1, 1)
        o["test"] = _unb64(o["test"], "<f4").reshape(n_pairs, s, 3) * pair_scale
        o["fe"] = _unb64(o["fe"], "<f4").reshape(n_pairs, s, 3) * pair_scale
        out["overlay"] = o
    return out


#: What would make a page reach outside its file: network and file URLs, attributes that load
#: something, style imports, frames, images, plugins, workers and requests.
_EXTERNAL = re.compile(
    r"""(?ix) (?:https?|ftp|file|data|javascript) \s*: (?=\S)
    | \b(?:src|href|action|poster|srcset|xlink:href) \s*=
    | @import | url\s*\( | <(?:link|iframe|img|object|embed|base|frame|audio|video)\b
    | \bimport\s*\( | \bfetch\s*\( | XMLHttpRequest | WebSocket | EventSource
    | \bnew\s+(?:Shared)?Worker\b | importScripts | navigator\.sendBeacon"""
)


def external_references(text: str) -> list[str]:
    """The places (up to 20, with some context) where a page's markup or script would load
    or send something outside the file (:func:`render_page`'s pages have none). The data
    block is left out: base64 may hold any letters and slashes."""
    text = _DATA_RE.sub("", text)
    return [text[max(0, m.start() - 30) : m.end() + 30].replace("\n", " ")
            for m in _EXTERNAL.finditer(text)][:20]  # fmt: skip


#: Browsers :func:`browser_check` looks for, in this order.
BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")


def find_browser() -> str | None:
    """The path of a Chromium-family browser on PATH, or None."""
    for name in BROWSERS:
        path = shutil.which(name)
        if path:
            return path
    return None


@dataclass(frozen=True)
class BrowserCheck:
    """What a headless browser made of a page: ``status`` its ``data-femcal`` (``"ok"``,
    ``"error: ..."``, ``""`` if the script never ran), ``selftest`` its
    ``data-femcal-selftest``, ``ink`` the dark pixels of its first drawing, ``edges``,
    ``faces`` and ``modes`` what it drew from, ``start`` the mode it opened on (from 1),
    ``console`` the page's console messages (uncaught errors among them; a good page logs
    none), ``screenshot`` the PNG taken (or None). For a page of several viewers, the
    first viewer's figures and every viewer's self-test."""

    status: str
    selftest: str
    ink: int
    edges: int
    modes: int
    console: tuple[str, ...]
    screenshot: Path | None = None
    faces: int = 0
    start: int = 0

    @property
    def ok(self) -> bool:
        return self.status == "ok" and self.selftest == "pass" and not self.console


def _run_browser(browser: str, args: list[str], timeout: float) -> tuple[str, str]:
    """Run the browser headless in a fresh profile; its (stdout, stderr). The browser and
    its helper processes (one process group) are ended if it overruns ``timeout``."""
    with tempfile.TemporaryDirectory(prefix="femcal-browser-") as profile:
        cmd = [browser, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
               "--disable-extensions", "--hide-scrollbars", "--enable-logging=stderr", "--v=0",
               f"--user-data-dir={profile}", *args]  # fmt: skip
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                start_new_session=True)  # fmt: skip
        try:
            out, err = proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate()
            raise RuntimeError(f"{browser} did not finish within {timeout:g} s") from None
    return out, err


def browser_check(
    page: Path,
    *,
    browser: str | None = None,
    screenshot: Path | None = None,
    window: tuple[int, int] = (1200, 800),
    timeout: float = 120.0,
) -> BrowserCheck:
    """Open ``page`` in a headless Chromium with ``#still-selftest`` (the page draws, steps
    through its modes and drives its mouse handlers), read back its marker attributes and
    console messages, and with ``screenshot`` take a PNG of it (animation off, mode 1).
    RuntimeError when there is no browser (``browser`` None: :func:`find_browser`)."""
    browser = browser or find_browser()
    if browser is None:
        raise RuntimeError(f"no browser found (looked for {', '.join(BROWSERS)})")
    url = Path(page).resolve().as_uri()
    size = f"--window-size={window[0]},{window[1]}"
    dom, err = _run_browser(browser, [size, "--dump-dom", url + "#still-selftest"], timeout)
    tag = re.search(r"<html\b[^>]*>", dom)
    attrs = dict(re.findall(r'(data-femcal[a-z-]*)="([^"]*)"', tag.group(0))) if tag else {}
    console = tuple(m.strip() for m in re.findall(r":CONSOLE[^\]]*\]\s*(.*)", err))
    shot = None
    if screenshot is not None:
        screenshot = Path(screenshot).resolve()
        screenshot.parent.mkdir(parents=True, exist_ok=True)
        screenshot.unlink(missing_ok=True)
        _, err2 = _run_browser(browser, [size, f"--screenshot={screenshot}", url + "#still"],
                               timeout)  # fmt: skip
        console += tuple(m.strip() for m in re.findall(r":CONSOLE[^\]]*\]\s*(.*)", err2))
        shot = screenshot if screenshot.exists() else None

    def number(key: str) -> int:
        try:
            return int(attrs.get(key, "0"))
        except ValueError:
            return 0

    return BrowserCheck(html.unescape(attrs.get("data-femcal", "")),
                        html.unescape(attrs.get("data-femcal-selftest", "")),
                        number("data-femcal-ink"), number("data-femcal-edges"),
                        number("data-femcal-modes"), console, shot,
                        number("data-femcal-faces"), number("data-femcal-start"))  # fmt: skip


_STYLE = """
.femcal-viewer { position: relative; height: 560px; margin: 10px 0; overflow: hidden;
  border: 1px solid #ccc; background: #fff; color: #222;
  font: 13px system-ui, -apple-system, "Segoe UI", Roboto, sans-serif; }
.femcal-viewer.fv-full { position: fixed; top: 0; left: 0; right: 0; bottom: 0; height: auto;
  margin: 0; border: 0; }
.femcal-viewer .fv-bar { position: absolute; top: 0; left: 0; right: 0; z-index: 1;
  display: flex; flex-wrap: wrap; gap: 4px 9px; align-items: center; padding: 6px 10px;
  font-size: 12px;
  background: rgba(255, 255, 255, 0.92); border-bottom: 1px solid #ddd; }
.femcal-viewer .fv-bar b { font-weight: 600; max-width: 10em; overflow: hidden;
  text-overflow: ellipsis; white-space: nowrap; }
.femcal-viewer .fv-bar label { white-space: nowrap; }
.femcal-viewer .fv-scale { width: 80px; vertical-align: middle; }
.femcal-viewer .fv-mode { max-width: 10em; font-size: 12px; }
.femcal-viewer .fv-view { position: absolute; top: 0; left: 0; width: 100%; height: 100%;
  display: block; cursor: grab; touch-action: none; }
.femcal-viewer .fv-info { position: absolute; right: 10px; top: 48px; z-index: 1;
  max-width: 46%; padding: 4px 8px; background: rgba(255, 255, 255, 0.92);
  border: 1px solid #ddd; white-space: pre-line; font-variant-numeric: tabular-nums; }
.femcal-viewer .fv-info:empty { display: none; }
.femcal-viewer .fv-help { position: absolute; bottom: 6px; left: 10px; right: 230px;
  color: #666; font-size: 12px; }
.femcal-viewer .fv-err { color: #b00; font-weight: 600; }
body > .femcal-viewer.fv-full { font-size: 13px; }
"""


_SCRIPT = r"""
(function () {
  "use strict";
  var root = document.documentElement;
  window.addEventListener("error", function (ev) {
    root.setAttribute("data-femcal", "error: " + (ev.message || "script error"));
  });
  function bytes(s) {
    var bin = atob(s), n = bin.length, u = new Uint8Array(n);
    for (var i = 0; i < n; i++) { u[i] = bin.charCodeAt(i); }
    return u.buffer;
  }
  function hz(md) {  // a zero frequency a hair below zero reads 0.000, not -0.000
    return (md.zero ? 0 : md.frequency_hz).toFixed(3);
  }
  function note(md) {
    return md.rigid ? " (rigid body)" : md.zero ? " (zero frequency)" : "";
  }
  function fmt(v, d) {
    var a = Math.abs(v);
    if (a !== 0 && (a < 1e-3 || a >= 1e5)) { return v.toExponential(2); }
    return v.toFixed(d === undefined ? 3 : d);
  }
  function length(v) {
    /* a length to three significant digits, no trailing zeros */
    return Number(v.toPrecision(3)).toString();
  }
  function signed(v) { return (v >= 0 ? "+" : "\u2212") + fmt(Math.abs(v)); }

  /* viridis, 16 steps */
  var VIR = [[68, 1, 84], [72, 26, 108], [71, 47, 125], [65, 68, 135], [57, 86, 140],
    [49, 104, 142], [42, 120, 142], [35, 137, 142], [31, 154, 138], [34, 170, 130],
    [53, 183, 121], [84, 197, 104], [122, 209, 81], [165, 219, 54], [210, 226, 27],
    [253, 231, 37]];
  var NB = VIR.length, PLAIN = [176, 190, 214], NL = 8;
  var VIRS = VIR.map(function (c) { return "rgb(" + c.join(",") + ")"; });
  /* face fill styles: (colour bin or the plain colour) x light level */
  var FILL = [];
  (function () {
    for (var b = 0; b <= NB; b++) {
      var c = b < NB ? VIR[b] : PLAIN;
      for (var l = 0; l < NL; l++) {
        var f = 0.45 + 0.55 * l / (NL - 1);
        FILL.push("rgb(" + Math.round(c[0] * f) + "," + Math.round(c[1] * f) + "," +
                  Math.round(c[2] * f) + ")");
      }
    }
  })();

  function norm(v) {
    var l = Math.hypot(v[0], v[1], v[2]) || 1;
    return [v[0] / l, v[1] / l, v[2] / l];
  }
  function cross(a, b) {
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  }
  function mix(a, b, p, q) {
    return [p * a[0] + q * b[0], p * a[1] + q * b[1], p * a[2] + q * b[2]];
  }
  /* the view: R's rows are the screen's x (right), y (up) and z (towards the eye) in basic */
  function iso() {
    var d = norm([1, 1, 1]), up = [0, 0, 1], r = norm(cross(up, d));
    return [r, cross(d, r), d];
  }
  function turn(R, ax, ang) {
    /* turn the model about the screen's x (ax 0: its front goes down for ang > 0) or y axis
       (ax 1: its front goes right) */
    var c = Math.cos(ang), s = Math.sin(ang);
    if (ax === 1) { return [mix(R[0], R[2], c, s), R[1], mix(R[0], R[2], -s, c)]; }
    return [R[0], mix(R[1], R[2], c, -s), mix(R[1], R[2], s, c)];
  }
  function same(a, b) {
    for (var i = 0; i < 3; i++) {
      for (var j = 0; j < 3; j++) { if (Math.abs(a[i][j] - b[i][j]) > 1e-12) { return false; } }
    }
    return true;
  }

  function viewer(box) {
    function q(c) { return box.querySelector("." + c); }
    var D = JSON.parse(box.querySelector("script.femcal-data").textContent);
    var NP = D.n_points, NE = D.n_edges, NF = D.n_faces, NK = D.n_markers, NM = D.n_modes;
    var P = new Float32Array(bytes(D.points)), IDS = new Int32Array(bytes(D.grid_ids));
    var E = new Uint32Array(bytes(D.edges)), EK = new Uint8Array(bytes(D.edge_kind));
    var F = new Uint32Array(bytes(D.faces));
    var MK = new Uint32Array(bytes(D.markers)), MKK = new Uint8Array(bytes(D.marker_kind));
    var S = new Float32Array(bytes(D.shapes));
    if (P.length !== 3 * NP || IDS.length !== NP || E.length !== 2 * NE || EK.length !== NE ||
        F.length !== 4 * NF || MK.length !== NK || MKK.length !== NK ||
        S.length !== 3 * NP * NM) {
      throw new Error("the page's data do not have the sizes it states");
    }
    var O = D.overlay || null, NS = 0, SP, SE, TS, FS, NSE = 0;
    if (O) {
      NS = O.n_sensors; NSE = O.n_sensor_edges;
      SP = new Float32Array(bytes(O.sensor_points));
      SE = new Uint32Array(bytes(O.sensor_edges));
      TS = new Float32Array(bytes(O.test)); FS = new Float32Array(bytes(O.fe));
      if (SP.length !== 3 * NS || SE.length !== 2 * NSE || TS.length !== 3 * NS * O.n_pairs ||
          FS.length !== 3 * NS * O.n_pairs || O.sensor_names.length !== NS) {
        throw new Error("the page's test data do not have the sizes it states");
      }
    }
    var C = D.center, SIZE = D.size, PERIOD = 2000, UNIT = D.unit || "";
    var UNITS = UNIT ? " " + UNIT : " (model units)";
    var testing = /selftest/.test(location.hash), full = box.classList.contains("fv-full");
    var canvas = q("fv-view");
    var ctx = canvas.getContext("2d", testing ? { willReadFrequently: true } : {});
    var sel = q("fv-mode"), anim = q("fv-anim"), scale = q("fv-scale");
    var scaleval = q("fv-scaleval"), colour = q("fv-colour"), undef = q("fv-undef");
    var surf = q("fv-surf"), info = q("fv-info"), showTest = q("fv-test");
    q("fv-name").textContent = q("fv-name").title = D.title || "";
    if (!NF) { surf.checked = false; surf.parentNode.style.display = "none"; }
    var choices = O ? O.n_pairs : NM;
    for (var m = 0; m < choices; m++) {
      var o = document.createElement("option");
      o.value = String(m);
      if (O) { o.textContent = O.pairs[m].label; } else {
        o.textContent = D.modes[m].mode + ": " + hz(D.modes[m]) + " Hz" + note(D.modes[m]);
      }
      sel.appendChild(o);
    }
    sel.value = String(D.start || 0);
    function choice() { return Number(sel.value) || 0; }
    function modeOf() { return O ? O.pairs[choice()].mode : choice(); }

    var MAG = [];
    function magnitudes(m) {
      if (!MAG[m]) {
        var a = new Float32Array(NP), off = 3 * NP * m;
        for (var i = 0; i < NP; i++) {
          a[i] = Math.hypot(S[off + 3 * i], S[off + 3 * i + 1], S[off + 3 * i + 2]);
        }
        MAG[m] = a;
      }
      return MAG[m];
    }

    var view = { R: iso(), zoom: 1, px: 0, py: 0, turns: 0 };
    function reset() { view.R = iso(); view.zoom = 1; view.px = 0; view.py = 0; view.turns++; }
    /* view coordinates (VX right, VY up, VZ towards the eye) and screen positions */
    var VX = new Float32Array(NP), VY = new Float32Array(NP), VZ = new Float32Array(NP);
    var X = new Float32Array(NP), Y = new Float32Array(NP);
    var X0 = new Float32Array(NP), Y0 = new Float32Array(NP), Z0 = new Float32Array(NP);
    var SX = new Float32Array(NS), SY = new Float32Array(NS), SZ = new Float32Array(NS);
    var SX0 = new Float32Array(NS), SY0 = new Float32Array(NS);
    var FX = new Float32Array(NS), FY = new Float32Array(NS);
    var W = 0, H = 0, DPR = 1, t0 = null, phase = 1, picked = null, visible = true;
    var last = { ink: 0, shift: 0, triad: false, mode: -1 };
    var K = 1, CX = 0, CY = 0;
    function place() {
      K = view.zoom * 0.8 * Math.min(W, H - 80) / SIZE;
      CX = W / 2 + view.px; CY = H / 2 + 20 + view.py;
    }
    function project(src, n, amp, shape, off, XX, YY, ZZ, keep) {
      var R = view.R;
      for (var i = 0; i < n; i++) {
        var x = src[3 * i] - C[0], y = src[3 * i + 1] - C[1], z = src[3 * i + 2] - C[2];
        if (amp !== 0) {
          x += amp * shape[off + 3 * i]; y += amp * shape[off + 3 * i + 1];
          z += amp * shape[off + 3 * i + 2];
        }
        var vx = R[0][0] * x + R[0][1] * y + R[0][2] * z;
        var vy = R[1][0] * x + R[1][1] * y + R[1][2] * z;
        XX[i] = CX + K * vx; YY[i] = CY - K * vy;
        if (ZZ) { ZZ[i] = R[2][0] * x + R[2][1] * y + R[2][2] * z; }
        if (keep) { VX[i] = vx; VY[i] = vy; }
      }
    }

    /* the drawing order of faces and lines, far to near, kept while the view turns not */
    var LINES = [];
    for (var e0 = 0; e0 < NE; e0++) { if (EK[e0] !== 3) { LINES.push(e0); } }
    var NLN = LINES.length, ORDER = null, orderTurns = -1;
    function sortPrims() {
      var n = NF + NLN, depth = new Float32Array(n), idx = new Array(n), lift = 0.002 * SIZE;
      for (var f = 0; f < NF; f++) {
        depth[f] = 0.25 * (Z0[F[4 * f]] + Z0[F[4 * f + 1]] + Z0[F[4 * f + 2]] + Z0[F[4 * f + 3]]);
        idx[f] = f;
      }
      for (var l = 0; l < NLN; l++) {
        var e = LINES[l];
        depth[NF + l] = 0.5 * (Z0[E[2 * e]] + Z0[E[2 * e + 1]]) + lift;
        idx[NF + l] = NF + l;
      }
      idx.sort(function (a, b) { return depth[a] - depth[b]; });
      ORDER = Uint32Array.from(idx);
      orderTurns = view.turns;
    }
    var EDGE_STYLE = ["#1f4e9c", "#d62728", "#ff7f0e", "#1f4e9c"];
    var EDGE_WIDTH = [2, 1.5, 2.5, 1];

    function size() {
      var w = canvas.clientWidth, h = canvas.clientHeight, d = window.devicePixelRatio || 1;
      if (w !== W || h !== H || d !== DPR) {
        W = w; H = h; DPR = d;
        canvas.width = Math.max(1, Math.round(w * d));
        canvas.height = Math.max(1, Math.round(h * d));
      }
    }
    function strokeEdges(XX, YY, kind, style, width, dash) {
      ctx.beginPath();
      var n = 0;
      for (var e = 0; e < NE; e++) {
        if (kind === 0 ? (EK[e] !== 0 && EK[e] !== 3) : EK[e] !== kind) { continue; }
        var a = E[2 * e], b = E[2 * e + 1];
        ctx.moveTo(XX[a], YY[a]); ctx.lineTo(XX[b], YY[b]); n++;
      }
      if (!n) { return; }
      ctx.strokeStyle = style; ctx.lineWidth = width; ctx.setLineDash(dash || []);
      ctx.stroke(); ctx.setLineDash([]);
    }

    function drawSurfaces(mag, f, coloured) {
      if (!ORDER || orderTurns !== view.turns) { sortPrims(); }
      /* outlines only where the faces are big enough on screen to show them */
      var sample = 0, ns = 0, step = Math.max(1, Math.floor(NF / 200));
      for (var s = 0; s < NF; s += step) {
        var a0 = F[4 * s], c0 = F[4 * s + 2];
        sample += Math.abs(X[a0] - X[c0]) + Math.abs(Y[a0] - Y[c0]); ns++;
      }
      var outline = ns && sample / ns > 6, style = -1, open = 0;
      /* faces of one fill style in a row are one path: far fewer canvas calls */
      function flush() {
        if (!open) { return; }
        ctx.fillStyle = FILL[style]; ctx.fill();
        ctx.strokeStyle = outline ? "rgba(0,0,0,0.35)" : FILL[style];
        ctx.lineWidth = outline ? 0.6 : 0.5; ctx.stroke();
        open = 0;
      }
      ctx.lineJoin = "round"; ctx.setLineDash([]);
      for (var k = 0; k < ORDER.length; k++) {
        var p = ORDER[k];
        if (p >= NF) {
          flush(); style = -1;
          var e = LINES[p - NF], ea = E[2 * e], eb = E[2 * e + 1], kind = EK[e];
          ctx.beginPath(); ctx.moveTo(X[ea], Y[ea]); ctx.lineTo(X[eb], Y[eb]);
          ctx.strokeStyle = EDGE_STYLE[kind]; ctx.lineWidth = EDGE_WIDTH[kind];
          ctx.setLineDash(kind === 1 ? [5, 3] : []);
          ctx.stroke(); ctx.setLineDash([]);
          continue;
        }
        var a = F[4 * p], b = F[4 * p + 1], c = F[4 * p + 2], d = F[4 * p + 3];
        var ux = VX[c] - VX[a], uy = VY[c] - VY[a], uz = VZ[c] - VZ[a];
        var wx = VX[d] - VX[b], wy = VY[d] - VY[b], wz = VZ[d] - VZ[b];
        if (d === c) { wx = VX[c] - VX[b]; wy = VY[c] - VY[b]; wz = VZ[c] - VZ[b]; }
        var nx = uy * wz - uz * wy, ny = uz * wx - ux * wz, nz = ux * wy - uy * wx;
        var light = Math.abs(nz) / (Math.hypot(nx, ny, nz) || 1);
        var bin = NB;
        if (coloured) {
          var v = (d === c ? (mag[a] + mag[b] + mag[c]) / 3
                   : 0.25 * (mag[a] + mag[b] + mag[c] + mag[d])) * f;
          bin = Math.min(NB - 1, Math.floor(v * NB));
        }
        var st = bin * NL + Math.min(NL - 1, Math.floor(light * NL));
        if (st !== style) { flush(); style = st; ctx.beginPath(); }
        ctx.moveTo(X[a], Y[a]); ctx.lineTo(X[b], Y[b]); ctx.lineTo(X[c], Y[c]);
        if (d !== c) { ctx.lineTo(X[d], Y[d]); }
        ctx.closePath(); open++;
      }
      flush();
    }

    function drawWires(mag, f, coloured, thick) {
      if (coloured) {
        var bins = [];
        for (var b = 0; b < NB; b++) { bins.push([]); }
        for (var e = 0; e < NE; e++) {
          if (EK[e] !== 0 && EK[e] !== 3) { continue; }
          var v = 0.5 * (mag[E[2 * e]] + mag[E[2 * e + 1]]) * f;
          bins[Math.min(NB - 1, Math.floor(v * NB))].push(e);
        }
        ctx.lineWidth = thick;
        for (var bb = 0; bb < NB; bb++) {
          var list = bins[bb];
          if (!list.length) { continue; }
          ctx.beginPath();
          for (var j = 0; j < list.length; j++) {
            var a = E[2 * list[j]], c = E[2 * list[j] + 1];
            ctx.moveTo(X[a], Y[a]); ctx.lineTo(X[c], Y[c]);
          }
          ctx.strokeStyle = VIRS[bb]; ctx.stroke();
        }
      } else {
        strokeEdges(X, Y, 0, "#1f4e9c", thick);
      }
      strokeEdges(X, Y, 1, "#d62728", 1.5, [5, 3]);
      strokeEdges(X, Y, 2, "#ff7f0e", 2.5);
      if (!NE && !NF) {
        /* a grid cloud */
        for (var i = 0; i < NP; i++) {
          var vv = coloured ? Math.min(NB - 1, Math.floor(mag[i] * f * NB)) : -1;
          ctx.fillStyle = vv < 0 ? "#1f4e9c" : VIRS[vv];
          ctx.fillRect(X[i] - 1.5, Y[i] - 1.5, 3, 3);
        }
      }
    }

    function drawSensors(amp, pair) {
      var off = 3 * NS * pair;
      project(SP, NS, 0, TS, 0, SX0, SY0, null, false);
      project(SP, NS, amp, TS, off, SX, SY, SZ, false);
      project(SP, NS, amp, FS, off, FX, FY, null, false);
      /* the FE shape at the sensors wide and blue under the test's narrow red: where they
         agree, red lines in blue borders and red dots in blue rings */
      var sets = [[FX, FY, "#1f5fbf", 4.5, 5.5], [SX, SY, "#d62728", 1.8, 3]];
      ctx.setLineDash([]);
      for (var s = 0; s < 2; s++) {
        var XX = sets[s][0], YY = sets[s][1];
        ctx.strokeStyle = sets[s][2]; ctx.lineWidth = sets[s][3]; ctx.beginPath();
        for (var e = 0; e < NSE; e++) {
          var a = SE[2 * e], b = SE[2 * e + 1];
          ctx.moveTo(XX[a], YY[a]); ctx.lineTo(XX[b], YY[b]);
        }
        ctx.stroke();
        ctx.lineWidth = 1; ctx.beginPath();
        for (var i = 0; i < NS; i++) { ctx.moveTo(SX0[i], SY0[i]); ctx.lineTo(XX[i], YY[i]); }
        ctx.stroke();
        ctx.fillStyle = sets[s][2];
        for (var j = 0; j < NS; j++) {
          ctx.beginPath(); ctx.arc(XX[j], YY[j], sets[s][4], 0, 2 * Math.PI); ctx.fill();
        }
      }
      ctx.fillStyle = "#555";
      for (var k = 0; k < NS; k++) { ctx.fillRect(SX0[k] - 1.5, SY0[k] - 1.5, 3, 3); }
    }

    function triad() {
      var R = view.R, ox = 46, oy = H - 62, L = 30, names = ["X", "Y", "Z"];
      var colours = ["#c0392b", "#27ae60", "#2456c4"], order = [0, 1, 2];
      order.sort(function (a, b) { return R[2][a] - R[2][b]; });
      ctx.font = "bold 12px system-ui, sans-serif"; ctx.textAlign = "center";
      ctx.textBaseline = "middle"; ctx.lineWidth = 2.5; ctx.setLineDash([]);
      for (var n = 0; n < 3; n++) {
        var i = order[n], dx = R[0][i] * L, dy = -R[1][i] * L;
        ctx.strokeStyle = colours[i]; ctx.fillStyle = colours[i];
        ctx.beginPath(); ctx.moveTo(ox, oy); ctx.lineTo(ox + dx, oy + dy); ctx.stroke();
        ctx.fillText(names[i], ox + dx * 1.35, oy + dy * 1.35);
      }
      ctx.textBaseline = "alphabetic";
      last.triad = true;
    }

    function legend(frac) {
      var w = 170, h = 10, x = W - w - 24, y = H - 40;
      for (var b = 0; b < NB; b++) {
        ctx.fillStyle = VIRS[b]; ctx.fillRect(x + b * w / NB, y, w / NB + 1, h);
      }
      ctx.fillStyle = "#333"; ctx.font = "12px system-ui, sans-serif";
      ctx.textAlign = "left"; ctx.fillText("0", x, y + h + 13);
      ctx.textAlign = "right";
      ctx.fillText(length(frac * SIZE) + UNITS, x + w, y + h + 13);
      ctx.textAlign = "center"; ctx.fillText("deflection as drawn", x + w / 2, y - 5);
    }

    function draw() {
      size();
      var pair = choice(), m = modeOf(), frac = Number(scale.value), off = 3 * NP * m;
      var amp = NM ? frac * SIZE * phase : 0, thick = NE > 5000 ? 1 : 2;
      scaleval.textContent = length(frac * SIZE) + UNITS;
      ctx.setTransform(DPR, 0, 0, DPR, 0, 0);
      ctx.fillStyle = "#fff"; ctx.fillRect(0, 0, W, H);
      ctx.lineCap = "round";
      place();
      project(P, NP, 0, S, off, X0, Y0, Z0, false);
      project(P, NP, amp, S, off, X, Y, VZ, true);
      var mag = NM ? magnitudes(m) : new Float32Array(NP), f = Math.abs(phase);
      var coloured = colour.checked && NM > 0;
      if (undef.checked && !(surf.checked && NF)) {
        ctx.globalAlpha = 0.35;
        for (var kk = 0; kk < 3; kk++) { strokeEdges(X0, Y0, kk, "#888", 1); }
        ctx.globalAlpha = 1;
      }
      if (surf.checked && NF) {
        if (undef.checked) {
          ctx.globalAlpha = NE > 5000 ? 0.15 : 0.3;
          strokeEdges(X0, Y0, 0, "#888", 1);
          ctx.globalAlpha = 1;
        }
        drawSurfaces(mag, f, coloured);
      } else {
        drawWires(mag, f, coloured, thick);
      }
      for (var i = 0; i < NK; i++) {
        var p = MK[i];
        ctx.fillStyle = MKK[i] === 0 ? "#000" : "#ff7f0e";
        ctx.fillRect(X[p] - 3.5, Y[p] - 3.5, 7, 7);
      }
      var shift = 0;
      for (var j = 0; j < NP; j++) {
        shift = Math.max(shift, Math.abs(X[j] - X0[j]) + Math.abs(Y[j] - Y0[j]));
      }
      if (O && (!showTest || showTest.checked)) {
        /* the model steps back behind the sensors: a white veil */
        ctx.globalAlpha = 0.45; ctx.fillStyle = "#fff"; ctx.fillRect(0, 0, W, H);
        ctx.globalAlpha = 1;
        drawSensors(amp, pair);
        for (var s = 0; s < NS; s++) {
          shift = Math.max(shift, Math.abs(SX[s] - SX0[s]) + Math.abs(SY[s] - SY0[s]));
        }
      }
      if (picked) { mark(); }
      triad();
      if (coloured) { legend(frac); }
      last.shift = shift; last.mode = m;
      box.setAttribute("data-femcal-mode", String(m + 1));
    }

    /* picking: the nearest grid (or sensor) under the pointer, the front one first */
    function mark() {
      var x = picked.sensor ? SX[picked.i] : X[picked.i];
      var y = picked.sensor ? SY[picked.i] : Y[picked.i];
      ctx.setLineDash([]); ctx.lineWidth = 2; ctx.strokeStyle = "#000";
      ctx.beginPath(); ctx.arc(x, y, 7, 0, 2 * Math.PI); ctx.stroke();
      ctx.strokeStyle = "#fff"; ctx.lineWidth = 1;
      ctx.beginPath(); ctx.arc(x, y, 9, 0, 2 * Math.PI); ctx.stroke();
    }
    function pick(x, y) {
      var best = -1, bz = -Infinity, r2 = 81;
      if (O && (!showTest || showTest.checked)) {
        for (var s = 0; s < NS; s++) {
          var ds = (SX[s] - x) * (SX[s] - x) + (SY[s] - y) * (SY[s] - y);
          if (ds <= r2 && SZ[s] > bz) { bz = SZ[s]; best = s; }
        }
        if (best >= 0) { picked = { sensor: true, i: best }; describe(); redraw(); return; }
      }
      for (var i = 0; i < NP; i++) {
        var d = (X[i] - x) * (X[i] - x) + (Y[i] - y) * (Y[i] - y);
        if (d <= r2 && VZ[i] > bz) { bz = VZ[i]; best = i; }
      }
      picked = best >= 0 ? { sensor: false, i: best } : null;
      describe(); redraw();
    }
    function vec(a, off) {
      return "(" + signed(a[off]) + ", " + signed(a[off + 1]) + ", " + signed(a[off + 2]) + ")";
    }
    function describe() {
      if (!picked) { info.textContent = ""; return; }
      var m = modeOf(), md = D.modes[m], i = picked.i, t;
      var head = "mode " + md.mode + ", " + hz(md) + " Hz";
      if (picked.sensor) {
        var off = 3 * NS * choice() + 3 * i;
        t = "sensor " + O.sensor_names[i] + " at (" + fmt(SP[3 * i], 1) + ", " +
          fmt(SP[3 * i + 1], 1) + ", " + fmt(SP[3 * i + 2], 1) + ")" + UNITS + "\n" +
          O.pairs[choice()].label + "\ntest " + vec(TS, off) + "\nFE   " + vec(FS, off) +
          "\n(x, y, z in basic, as a fraction of the FE mode's largest translation)";
      } else {
        var so = 3 * NP * m + 3 * i, mag = magnitudes(m)[i];
        t = "grid " + IDS[i] + " at (" + fmt(P[3 * i], 1) + ", " + fmt(P[3 * i + 1], 1) +
          ", " + fmt(P[3 * i + 2], 1) + ")" + UNITS + "\n" + head +
          note(md) + "\nmotion " + vec(S, so) + ", |u| " + fmt(mag) +
          "\n(x, y, z in basic, as a fraction of the mode's largest translation; " +
          "mass-normalised: times " + fmt(md.max) +
          (D.shape_unit ? " " + D.shape_unit : "") + ")";
      }
      info.textContent = t;
      box.setAttribute("data-femcal-picked", picked.sensor ? "sensor " + O.sensor_names[i]
                       : "grid " + IDS[i]);
    }

    function ink() {
      var img = ctx.getImageData(0, 0, canvas.width, canvas.height).data, n = 0;
      for (var i = 0; i < img.length; i += 4) {
        if (img[i] + img[i + 1] + img[i + 2] < 600) { n++; }
      }
      return n;
    }

    var raf = 0;
    function frame(ts) {
      raf = 0;
      if (!anim.checked) { phase = 1; draw(); return; }
      if (!visible) { return; }
      if (t0 === null) { t0 = ts; }
      phase = Math.sin(2 * Math.PI * ((ts - t0) % PERIOD) / PERIOD);
      draw();
      raf = window.requestAnimationFrame(frame);
    }
    function redraw() {
      if (anim.checked) {
        if (!raf) { raf = window.requestAnimationFrame(frame); }
      } else { phase = 1; draw(); }
    }
    if (!full && "IntersectionObserver" in window) {
      new IntersectionObserver(function (entries) {
        visible = entries[entries.length - 1].isIntersecting;
        if (visible) { redraw(); }
      }).observe(box);
    }

    var drag = null;
    canvas.addEventListener("pointerdown", function (ev) {
      drag = { x: ev.clientX, y: ev.clientY, x0: ev.clientX, y0: ev.clientY,
               pan: ev.shiftKey || ev.button === 2 || ev.button === 1 };
      try { canvas.setPointerCapture(ev.pointerId); } catch (err) { /* a synthetic pointer */ }
      canvas.style.cursor = "grabbing";
    });
    canvas.addEventListener("pointermove", function (ev) {
      if (!drag) { return; }
      var dx = ev.clientX - drag.x, dy = ev.clientY - drag.y;
      drag.x = ev.clientX; drag.y = ev.clientY;
      if (drag.pan) { view.px += dx; view.py += dy; } else {
        view.R = turn(turn(view.R, 1, dx * 0.01), 0, dy * 0.01); view.turns++;
      }
      redraw();
    });
    function up(ev) {
      if (drag && ev && ev.type === "pointerup" && !drag.pan &&
          Math.abs(ev.clientX - drag.x0) + Math.abs(ev.clientY - drag.y0) < 4) {
        var r = canvas.getBoundingClientRect();
        pick(ev.clientX - r.left, ev.clientY - r.top);
      }
      drag = null; canvas.style.cursor = "grab";
    }
    canvas.addEventListener("pointerup", up);
    canvas.addEventListener("pointercancel", up);
    canvas.addEventListener("contextmenu", function (ev) { ev.preventDefault(); });
    canvas.addEventListener("wheel", function (ev) {
      ev.preventDefault();
      view.zoom = Math.min(200, Math.max(0.05, view.zoom * Math.exp(-ev.deltaY * 0.0015)));
      redraw();
    }, { passive: false });
    canvas.addEventListener("dblclick", function () { reset(); redraw(); });
    [sel, scale, colour, undef, surf].concat(showTest ? [showTest] : []).forEach(function (el) {
      el.addEventListener("input", redraw); el.addEventListener("change", redraw);
    });
    sel.addEventListener("change", describe);
    anim.addEventListener("change", function () { t0 = null; redraw(); });
    window.addEventListener("resize", redraw);

    function selftest() {
      var bad = [], wasAnim = anim.checked, start = sel.value;
      anim.checked = false; phase = 1;
      for (var c = 0; c < choices; c++) {
        sel.value = String(c); sel.dispatchEvent(new Event("change"));
        var what = O ? "pair " + (c + 1) : "mode " + (c + 1);
        if (ink() < 50) { bad.push(what + " draws nothing"); }
        if (!(last.shift > 1)) { bad.push(what + " does not move the model"); }
      }
      sel.value = start; sel.dispatchEvent(new Event("change"));
      var R0 = view.R, rect = canvas.getBoundingClientRect();
      function pointer(type, x, y) {
        canvas.dispatchEvent(new PointerEvent(type, { clientX: rect.left + x,
          clientY: rect.top + y, button: 0, pointerId: 7, bubbles: true }));
      }
      pointer("pointerdown", 200, 200);
      pointer("pointermove", 260, 230);
      pointer("pointerup", 260, 230);
      if (same(R0, view.R)) { bad.push("dragging does not rotate"); }
      var z = view.zoom;
      canvas.dispatchEvent(new WheelEvent("wheel", { deltaY: -300, bubbles: true,
        cancelable: true }));
      if (!(view.zoom > z)) { bad.push("the wheel does not zoom"); }
      canvas.dispatchEvent(new MouseEvent("dblclick", { bubbles: true }));
      if (!same(view.R, iso()) || view.zoom !== 1) { bad.push("double-click does not reset"); }
      /* a click on the grid nearest the eye names it */
      draw();
      var front = 0;
      for (var i = 1; i < NP; i++) { if (VZ[i] > VZ[front]) { front = i; } }
      if (showTest) { showTest.checked = false; draw(); }
      pointer("pointerdown", X[front], Y[front]);
      pointer("pointerup", X[front], Y[front]);
      if (!picked || picked.sensor || picked.i !== front ||
          info.textContent.indexOf("grid " + IDS[front]) !== 0) {
        bad.push("a click does not name grid " + IDS[front]);
      }
      if (showTest) { showTest.checked = true; }
      picked = null; describe(); box.removeAttribute("data-femcal-picked");
      if (!last.triad) { bad.push("no axis triad"); }
      scale.value = "0"; scale.dispatchEvent(new Event("input"));
      if (last.shift > 1e-3) { bad.push("scale 0 still deforms"); }
      scale.value = "0.08"; scale.dispatchEvent(new Event("input"));
      colour.checked = false; colour.dispatchEvent(new Event("change"));
      if (ink() < 50) { bad.push("uncoloured drawing is empty"); }
      colour.checked = true; colour.dispatchEvent(new Event("change"));
      if (NF) {
        surf.checked = false; surf.dispatchEvent(new Event("change"));
        if (ink() < 50) { bad.push("the wireframe is empty"); }
        surf.checked = true; surf.dispatchEvent(new Event("change"));
      }
      anim.checked = wasAnim; anim.dispatchEvent(new Event("change"));
      var bar = box.querySelector(".fv-bar");
      if (box.clientWidth >= 900 && bar && bar.offsetHeight > 44) {
        bad.push("the toolbar wraps (" + bar.offsetHeight + " px high at " + box.clientWidth +
                 " px wide)");
      }
      return bad;
    }

    if (/still/.test(location.hash)) { anim.checked = false; }
    phase = anim.checked ? 0.999 : 1;
    draw();
    last.ink = ink();
    box.setAttribute("data-femcal-start", String(modeOf() + 1));
    var result = { ink: last.ink, edges: NE, faces: NF, modes: NM, start: modeOf() + 1,
                   bad: testing ? selftest() : null };
    box.setAttribute("data-femcal", "ok");
    redraw();
    return result;
  }

  var boxes = document.querySelectorAll(".femcal-viewer"), status = "ok", bad = [];
  var first = null;
  for (var b = 0; b < boxes.length; b++) {
    var r = null;
    try { r = viewer(boxes[b]); } catch (err) {
      var msg = "error: " + (err && err.message ? err.message : String(err));
      boxes[b].setAttribute("data-femcal", msg);
      var el = boxes[b].querySelector(".fv-err");
      if (el) { el.textContent = msg; }
      if (status === "ok") { status = msg; }
    }
    if (r && !first) { first = r; }
    if (r && r.bad) {
      var tag = boxes.length > 1 ? "viewer " + (b + 1) + ": " : "";
      r.bad.forEach(function (x) { bad.push(tag + x); });
    }
  }
  if (first) {
    root.setAttribute("data-femcal-ink", String(first.ink));
    root.setAttribute("data-femcal-edges", String(first.edges));
    root.setAttribute("data-femcal-faces", String(first.faces));
    root.setAttribute("data-femcal-modes", String(first.modes));
    root.setAttribute("data-femcal-start", String(first.start));
  }
  if (/selftest/.test(location.hash) && status === "ok") {
    root.setAttribute("data-femcal-selftest", bad.length ? "fail: " + bad.join("; ") : "pass");
  }
  root.setAttribute("data-femcal", status);
})();
"""
