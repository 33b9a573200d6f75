"""Mode shapes, their grids and trace lines as a universal file (UFF), through pyuff.

Test engineers look at shapes in LMS Test.Lab (Simcenter Testlab), ME'scope, pyuff and the
like; those read universal files. One file written by :func:`write_uff_shapes` holds:

- dataset 164 (units), only when :attr:`Grids.units` is a length unit femcal knows (``m``,
  ``cm``, ``mm``, ``in``, ``ft``): units code 9 (user defined) with that length's factor to
  metres and force factor 1 (newton). Without it a reader takes the numbers as they are;
- dataset 15 (nodes): each grid's id and its coordinates in the basic frame, definition and
  displacement systems 0 (basic), in the model's length unit (E13.5: 6 significant digits);
- dataset 82 (trace lines): the lines to draw between grids (pairs of grid ids, chained
  into polylines, at most 250 points a dataset: the format's limit);
- dataset 55 (data at nodes), one per mode: data characteristic 2 (3 DOF translation),
  specific data type 8 (displacement), the three translations of each grid in the basic
  frame (E13.5). Real normal modes are analysis type 2 with the frequency (Hz), the modal
  (generalised) mass and the viscous damping ratio (0 for FE modes); complex modes of an
  identified model are analysis type 3 with the complex eigenvalue, the pole
  ``-zeta w + i w sqrt(1 - zeta^2)`` in rad/s, and modal A and B written 0 (the identified
  shapes are normalised to a largest component of 1, not scaled to a modal A).

Units: coordinates in the model's length unit; FE shapes as femcal solved them (EIGRL NORM:
mass-normalised shapes are length / sqrt(mass) in the model's units, modal mass 1); the
identified shapes are dimensionless (largest component 1). The ID lines of each dataset 55
say which.

Inputs are typed: :class:`Grids` (from a model: :func:`model_grids`), :class:`TraceLines`
(the FE mesh's element edges, :func:`mesh_edges`, or a wireframe of the sensors along the
mesh, :func:`sensor_wireframe`) and :class:`ModeShapes` (FE modes: :func:`fe_shapes`, at
every grid or a chosen set; identified modes: :func:`identified_shapes`). The file is written
to a temporary name and renamed, as :mod:`femcal.testdata.formats.uff` writes dataset 58.
"""

from __future__ import annotations

import gc
import os
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import FemcalWarning
from ..identify.workflow import IdentifiedModel
from ..model.model import Model
from ..solve.normal_modes import Modes
from ..testdata.formats.uff import write_uff_sets
from .modes import mesh_cells

#: Most points of one trace line dataset (record 1 field 2: "maximum of 250").
MAX_TRACE_POINTS = 250
#: Length units a dataset 164 is written for: metres per unit.
LENGTH_UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001, "in": 0.0254, "ft": 0.3048}


@dataclass(frozen=True)
class Grids:
    """Grids to draw: ``ids`` (n,) grid ids; ``xyz`` (n, 3) coordinates in the basic frame;
    ``units`` the length unit of ``xyz`` (``"mm"``; ``""`` unknown: no dataset 164)."""

    ids: np.ndarray
    xyz: np.ndarray
    units: str = ""

    def __post_init__(self) -> None:
        ids = np.asarray(self.ids, dtype=np.int64).reshape(-1)
        xyz = np.asarray(self.xyz, dtype=float)
        if xyz.shape != (len(ids), 3):
            raise ValueError(f"grid coordinates have shape {xyz.shape}; expected "
                             f"({len(ids)}, 3) for {len(ids)} grids")  # fmt: skip
        if len(np.unique(ids)) != len(ids) or (ids <= 0).any():
            raise ValueError("grid ids must be positive and each given once")
        if not np.isfinite(xyz).all():
            raise ValueError("grid coordinates must be finite")
        object.__setattr__(self, "ids", ids)
        object.__setattr__(self, "xyz", xyz)


@dataclass(frozen=True)
class TraceLines:
    """Lines between grids: ``pairs`` (m, 2) grid ids, one row per line; ``name`` the
    identification line of the datasets 82 (not blank)."""

    pairs: np.ndarray
    name: str = "femcal wireframe"

    def __post_init__(self) -> None:
        pairs = np.asarray(self.pairs, dtype=np.int64).reshape(-1, 2)
        if (pairs <= 0).any():
            raise ValueError("trace lines join grids: expected positive grid ids")
        object.__setattr__(self, "pairs", pairs)


@dataclass(frozen=True)
class ModeShapes:
    """Mode shapes at grids, translations in the basic frame.

    Attributes
    ----------
    grid_ids : (n,) the grids the shapes are given at.
    values : (k, n, 3) the translations of each grid in each mode, real (normal modes) or
        complex (complex modes).
    frequency_hz : (k,) natural (normal) or damped (complex) frequencies.
    kind : ``"normal"`` (dataset 55 analysis type 2) or ``"complex"`` (type 3).
    modal_mass : (k,) generalised masses (normal modes; 0 where unknown).
    damping_ratio : (k,) viscous damping ratios (0 where none).
    poles : (k,) complex eigenvalues, rad/s (complex modes).
    title : what the shapes are (ID line 1); ``units`` what their values are in (ID line 4).
    """

    grid_ids: np.ndarray
    values: np.ndarray
    frequency_hz: np.ndarray
    kind: str = "normal"
    modal_mass: np.ndarray | None = None
    damping_ratio: np.ndarray | None = None
    poles: np.ndarray | None = None
    title: str = "femcal modes"
    units: str = ""

    def __post_init__(self) -> None:
        ids = np.asarray(self.grid_ids, dtype=np.int64).reshape(-1)
        values = np.asarray(self.values)
        f = np.asarray(self.frequency_hz, dtype=float).reshape(-1)
        k = len(f)
        if self.kind not in ("normal", "complex"):
            raise ValueError(f"shapes of kind {self.kind!r}; expected 'normal' or 'complex'")
        if values.shape != (k, len(ids), 3):
            raise ValueError(f"shape values have shape {values.shape}; expected (modes, grids, "
                             f"3) = ({k}, {len(ids)}, 3)")  # fmt: skip
        if not np.isfinite(values).all() or not np.isfinite(f).all():
            raise ValueError("shape values and frequencies must be finite")
        if len(np.unique(ids)) != len(ids):
            raise ValueError("each grid of the shapes must be given once")
        values = values.astype(complex if self.kind == "complex" else float)
        mass = np.zeros(k) if self.modal_mass is None else np.asarray(self.modal_mass, float)
        zeta = (np.zeros(k) if self.damping_ratio is None
                else np.asarray(self.damping_ratio, float))  # fmt: skip
        poles = self.poles
        if self.kind == "complex":
            if poles is None:  # from the frequency and the damping
                w = 2 * np.pi * f
                poles = -zeta * w + 1j * w * np.sqrt(np.clip(1 - zeta**2, 0, None))
            poles = np.asarray(poles, complex).reshape(-1)
        for name, arr in (("modal_mass", mass), ("damping_ratio", zeta)) + (
                (("poles", poles),) if poles is not None else ()):  # fmt: skip
            if arr.shape != (k,):
                raise ValueError(f"{name} has shape {arr.shape}; expected ({k},), one per mode")
        object.__setattr__(self, "grid_ids", ids)
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "frequency_hz", f)
        object.__setattr__(self, "modal_mass", mass)
        object.__setattr__(self, "damping_ratio", zeta)
        object.__setattr__(self, "poles", poles)

    @property
    def n_modes(self) -> int:
        return len(self.frequency_hz)


# ---------------------------------------------------------------------------- from a model


def _grid_rows(model: Model, ids: Sequence[int] | np.ndarray | None) -> np.ndarray:
    """Node indices of GRID ids (all GRIDs for None); ValueError naming an id that is not a
    GRID of the model."""
    if ids is None:
        return np.flatnonzero(model.is_grid)
    ids = np.asarray(ids, dtype=np.int64).reshape(-1)
    rows = model.node_index(ids)
    bad = (rows < 0) | ~model.is_grid[np.maximum(rows, 0)]
    if bad.any():
        missing = ", ".join(str(i) for i in ids[bad][:8])
        more = f" and {int(bad.sum()) - 8} more" if bad.sum() > 8 else ""
        raise ValueError(f"no GRID {missing}{more} in the model; expected grids of the model")
    if len(np.unique(ids)) != len(ids):
        raise ValueError("a grid is given twice; expected each grid once")
    return rows


def model_grids(model: Model, ids: Sequence[int] | np.ndarray | None = None, *,
                units: str = "") -> Grids:  # fmt: skip
    """The model's GRIDs (or those of ``ids``, in that order) with their basic coordinates;
    ValueError for an id that is not a GRID."""
    rows = _grid_rows(model, ids)
    return Grids(model.node_ids[rows], model.xyz[rows], units)


def fe_shapes(modes: Modes, model: Model, grid_ids: Sequence[int] | np.ndarray | None = None,
              *, title: str = "femcal normal modes", units: str = "") -> ModeShapes:  # fmt: skip
    """The normal modes' translations at every GRID (or at ``grid_ids``: the sensors, say, as
    a whole-model shape at every grid is large), taken from each grid's displacement (CD)
    frame, in which femcal keeps them, to the basic frame; with the frequencies and the
    generalised masses. ValueError for an id that is not a GRID."""
    rows = _grid_rows(model, grid_ids)
    k = modes.shapes.shape[1]
    if not np.array_equal(modes.node_ids, model.node_ids):
        raise ValueError("the modes were not solved for this model (other nodes)")
    g = model.dof_start[rows][:, None] + np.arange(3)
    local = modes.shapes[g]  # (r, 3, k) in each grid's CD frame
    basic = np.einsum("rij,rjk->kri", model.cd_frames[rows], local)
    return ModeShapes(model.node_ids[rows], basic, modes.frequencies_hz, "normal",
                      modal_mass=modes.generalized_mass, damping_ratio=np.zeros(k),
                      title=title, units=units)  # fmt: skip


_AXES = {"X": 0, "Y": 1, "Z": 2}


def identified_shapes(ident: IdentifiedModel, model: Model | None = None, *, real: bool = False,
                      title: str = "femcal identified modes") -> ModeShapes:  # fmt: skip
    """The identified modes' shapes at the grids their channels name (the roving side:
    the outputs, or the excitation points of a roving-hammer set), as translations in the
    basic frame.

    A channel ``GRID:+X`` (a signed axis) measures along that basic axis; ``GRID:3`` (a
    component number) along the grid's displacement (CD) frame's axis, taken from ``model``
    (without a model, as the basic axis). At each grid the translation is the least-squares
    (minimum-norm) vector that gives the channels' values along their directions: the
    measured components for a triaxial sensor, the one direction's value along it for a
    uniaxial one (the others 0), the mean of a direction measured twice. Rotation channels
    and channels that name no grid are left out with a :class:`FemcalWarning`.

    With ``real`` the shapes are the real parts (the shapes are normalised to a largest
    component of 1, so the real part is the normal mode's for a proportionally damped
    structure) and the modes normal ones with their damping ratios; otherwise complex with
    their poles.

    Raises
    ------
    ValueError
        For a channel grid that ``model`` has no GRID of, or no channel on a grid.
    """
    dirs: dict[int, list[tuple[int, np.ndarray]]] = {}
    skipped = []
    for i, ch in enumerate(ident.shape_channels):
        d = (ch.direction or "").upper()
        axis = d.lstrip("+-")
        sign = -1.0 if d.startswith("-") else 1.0
        if ch.grid is None or not axis or axis.startswith("R") or axis in ("4", "5", "6"):
            skipped.append(ch.label)
            continue
        if axis in _AXES:
            vec = np.eye(3)[_AXES[axis]]
        else:
            vec = np.eye(3)[int(axis) - 1]
            if model is not None:
                row = int(model.node_index(ch.grid)[0])
                if row < 0 or not model.is_grid[row]:
                    raise ValueError(f"channel {ch.label}: no GRID {ch.grid} in the model")
                vec = model.cd_frames[row][:, int(axis) - 1]
        dirs.setdefault(int(ch.grid), []).append((i, sign * vec))
    if skipped:
        more = f" and {len(skipped) - 6} more" if len(skipped) > 6 else ""
        warnings.warn(FemcalWarning(
            f"{len(skipped)} channel(s) left out of the shapes (rotations or no GRID:DIRECTION "
            f"label; dataset 55 holds translations): {', '.join(skipped[:6])}{more}"),
            stacklevel=2)  # fmt: skip
    if not dirs:
        raise ValueError("no output channel names a grid and a translation; expected labels "
                         "GRID:+X, GRID:3 ...")  # fmt: skip
    if model is not None:
        _grid_rows(model, list(dirs))
    ids = np.array(sorted(dirs), dtype=np.int64)
    k = len(ident.frequency_hz)
    values = np.zeros((k, len(ids), 3), complex)
    for j, gid in enumerate(ids):
        rows = [i for i, _ in dirs[gid]]
        D = np.array([v for _, v in dirs[gid]])  # (c, 3): u . d = measured value
        values[:, j, :] = (np.linalg.pinv(D) @ ident.shapes[rows, :]).T
    if real:
        return ModeShapes(ids, values.real, ident.frequency_hz, "normal",
                          damping_ratio=ident.damping_ratio, title=title,
                          units="dimensionless (largest component 1)")  # fmt: skip
    return ModeShapes(ids, values, ident.frequency_hz, "complex",
                      damping_ratio=ident.damping_ratio, poles=ident.poles, title=title,
                      units="dimensionless (largest component 1)")  # fmt: skip


# ---------------------------------------------------------------------------- trace lines

#: Edges of meshio's cell types, as pairs of corner positions; (a, m, b) a side through a
#: midside node m (an omitted one, -1, makes the side a-b).
_EDGES = {
    "line": [(0, 1)],
    "triangle": [(0, 1), (1, 2), (2, 0)],
    "quad": [(0, 1), (1, 2), (2, 3), (3, 0)],
    "tetra": [(0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)],
    "pyramid": [(0, 1), (1, 2), (2, 3), (3, 0), (0, 4), (1, 4), (2, 4), (3, 4)],
    "wedge": [(0, 1), (1, 2), (2, 0), (3, 4), (4, 5), (5, 3), (0, 3), (1, 4), (2, 5)],
    "hexahedron": [(0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4),
                   (0, 4), (1, 5), (2, 6), (3, 7)],
}  # fmt: skip
_CORNERS = {"tetra10": "tetra", "pyramid13": "pyramid", "wedge15": "wedge",
            "hexahedron20": "hexahedron"}  # fmt: skip
_SIDES = {"triangle6": [(0, 3, 1), (1, 4, 2), (2, 5, 0)],
          "quad8": [(0, 4, 1), (1, 5, 2), (2, 6, 3), (3, 7, 0)]}  # fmt: skip


def mesh_edges(model: Model) -> np.ndarray:
    """(m, 2) grid ids of the model's element edges (the corner edges of solids; shell
    sides through their midside nodes) and of its rigid elements' legs (RBE2, RBAR, RBE3):
    each edge once, smaller id first, sorted."""
    pairs = []
    for kind, nodes in mesh_cells(model):
        if kind in _SIDES:
            for a, m, b in _SIDES[kind]:
                has = nodes[:, m] >= 0
                pairs += [nodes[has][:, [a, m]], nodes[has][:, [m, b]], nodes[~has][:, [a, b]]]
            continue
        for a, b in _EDGES.get(_CORNERS.get(kind, kind), []):
            pairs.append(nodes[:, [a, b]])
    c = model.constraints
    legs = [(r.independent, d) for r in c.rigid_links for d in r.dependent]
    legs += [tuple(r.nodes) for r in c.rigid_bars]
    legs += [(r.reference, n) for r in c.interpolations for g in r.groups for n in g.nodes]
    if legs:
        pairs.append(np.array(legs, dtype=np.int64).reshape(-1, 2))
    return _unique_grid_pairs(model, pairs)


def _unique_grid_pairs(model: Model, pairs: list[np.ndarray]) -> np.ndarray:
    """Node-index pairs as unique (smaller first) pairs of GRID ids, between two GRIDs."""
    if not pairs:
        return np.zeros((0, 2), np.int64)
    p = np.concatenate([np.asarray(x, dtype=np.int64).reshape(-1, 2) for x in pairs])
    p = p[(p >= 0).all(axis=1) & (p[:, 0] != p[:, 1])]
    p = p[model.is_grid[p].all(axis=1)]
    ids = np.sort(model.node_ids[p], axis=1)
    return np.unique(ids, axis=0) if len(ids) else np.zeros((0, 2), np.int64)


def sensor_wireframe(model: Model, grid_ids: Sequence[int] | np.ndarray) -> np.ndarray:
    """(m, 2) lines between the sensors' grids that follow the structure: every grid of the
    mesh (:func:`mesh_edges`) goes to its nearest sensor along the mesh (shortest path,
    edge lengths in basic), and two sensors are joined where their regions meet, so
    sensors along a rail are joined in a row and the rails through the cross members
    (the graph's Delaunay triangulation of the sensors). ValueError for an id that is not
    a GRID."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import dijkstra

    sensors = _grid_rows(model, grid_ids)
    edges = mesh_edges(model)
    if len(sensors) < 2 or not len(edges):
        return np.zeros((0, 2), np.int64)
    e = model.node_index(edges.ravel()).reshape(-1, 2)
    length = np.linalg.norm(model.xyz[e[:, 0]] - model.xyz[e[:, 1]], axis=1)
    scale = float(np.mean(length)) if length.size else 1.0
    w = length + 1e-9 * (scale or 1.0)  # coincident grids (CBUSH, RBE2) stay joined
    n = model.n_nodes
    graph = csr_matrix((np.r_[w, w], (np.r_[e[:, 0], e[:, 1]], np.r_[e[:, 1], e[:, 0]])),
                       shape=(n, n))  # fmt: skip
    _, _, source = dijkstra(graph, directed=False, indices=sensors, min_only=True,
                            return_predecessors=True)  # fmt: skip
    a, b = source[e[:, 0]], source[e[:, 1]]
    meet = (a >= 0) & (b >= 0) & (a != b)
    return _unique_grid_pairs(model, [np.column_stack([a[meet], b[meet]])])


def _polylines(pairs: np.ndarray) -> list[list[int]]:
    """Pairs of ids chained into polylines (each pair in exactly one, as one step)."""
    adj: dict[int, list[int]] = {}
    for a, b in pairs.tolist():
        adj.setdefault(a, []).append(b)
        adj.setdefault(b, []).append(a)
    used: set[tuple[int, int]] = set()
    left = {a: len(v) for a, v in adj.items()}
    lines = []
    # start at ends (odd degree) first, so that chains are long
    order = sorted(adj, key=lambda a: (len(adj[a]) % 2 == 0, a))
    for start in order:
        while left[start]:
            line, here = [start], start
            while left[here]:
                nxt = next(b for b in adj[here] if (min(here, b), max(here, b)) not in used)
                used.add((min(here, nxt), max(here, nxt)))
                left[here] -= 1
                left[nxt] -= 1
                line.append(nxt)
                here = nxt
            lines.append(line)
    return lines


def trace_line_nodes(pairs: np.ndarray, limit: int = MAX_TRACE_POINTS) -> list[np.ndarray]:
    """The node sequences of datasets 82 that draw ``pairs``: polylines joined by 0 (a move
    to the next node), each sequence at most ``limit`` entries."""
    out: list[np.ndarray] = []
    seq: list[int] = []
    for line in _polylines(np.asarray(pairs, dtype=np.int64).reshape(-1, 2)):
        for k in range(0, len(line) - 1, limit - 1):  # pieces of at most `limit` points
            piece = line[k:k + limit]
            if seq and len(seq) + 1 + len(piece) > limit:
                out.append(np.array(seq, dtype=np.int64))
                seq = []
            seq = [*seq, 0, *piece] if seq else list(piece)
    if seq:
        out.append(np.array(seq, dtype=np.int64))
    return out


def trace_line_pairs(nodes: Sequence[float] | np.ndarray) -> np.ndarray:
    """(m, 2) the lines a dataset 82's node sequence draws (0 lifts the pen), smaller id
    first, in the order drawn."""
    seq = np.asarray(nodes, dtype=float).astype(np.int64).reshape(-1)
    keep = (seq[:-1] > 0) & (seq[1:] > 0)
    pairs = np.column_stack([seq[:-1][keep], seq[1:][keep]])
    return np.sort(np.array(pairs, dtype=np.int64).reshape(-1, 2), axis=1)


# ---------------------------------------------------------------------------- the file


def _id_line(text: str) -> str:
    """An ID line: at most 80 characters, not blank ("NONE" then, as the format asks)."""
    text = " ".join(str(text).split())
    return text[:80] if text else "NONE"


def uff_datasets(grids: Grids | None = None, shapes: Sequence[ModeShapes] = (),
                 trace_lines: TraceLines | None = None) -> list[dict]:  # fmt: skip
    """The pyuff datasets (164, 15, 82 ..., 55 ...) of :func:`write_uff_shapes`.

    Raises
    ------
    ValueError
        For trace lines or shapes at grids that ``grids`` does not have.
    """
    import pyuff

    known = None if grids is None else set(grids.ids.tolist())
    sets = []
    if grids is not None:
        factor = LENGTH_UNITS.get(grids.units.strip().lower())
        if factor is not None:
            sets.append(pyuff.prepare_164(
                units_code=9, units_description=f"{grids.units.strip()} N"[:20], temp_mode=1,
                length=1.0 / factor, force=1.0, temp=1.0, temp_offset=273.15))  # fmt: skip
        n = len(grids.ids)
        sets.append(pyuff.prepare_15(
            node_nums=grids.ids.astype(int), def_cs=np.zeros(n, int), disp_cs=np.zeros(n, int),
            color=np.full(n, 8, int), x=grids.xyz[:, 0].astype(float),
            y=grids.xyz[:, 1].astype(float), z=grids.xyz[:, 2].astype(float)))  # fmt: skip
    if trace_lines is not None and len(trace_lines.pairs):
        if known is not None:
            _check_known(trace_lines.pairs.ravel(), known, "trace line")
        for k, nodes in enumerate(trace_line_nodes(trace_lines.pairs), start=1):
            sets.append(pyuff.prepare_82(trace_num=k, n_nodes=len(nodes), color=1,
                                         id=_id_line(trace_lines.name), nodes=nodes.astype(int)))
    for case, s in enumerate(shapes, start=1):
        if known is not None:
            _check_known(s.grid_ids, known, "shape")
        sets += _dataset55(s, case)
    return sets


def _check_known(ids: np.ndarray, known: set[int], what: str) -> None:
    missing = sorted(set(np.asarray(ids).tolist()) - known)
    if missing:
        more = f" and {len(missing) - 8} more" if len(missing) > 8 else ""
        raise ValueError(f"{what} grid(s) {', '.join(map(str, missing[:8]))}{more} are not "
                         "among the file's grids; expected grids of dataset 15")  # fmt: skip


def _dataset55(s: ModeShapes, case: int) -> list[dict]:
    import pyuff

    out = []
    ids = s.grid_ids.astype(int)
    for k in range(s.n_modes):
        f, zeta = float(s.frequency_hz[k]), float(s.damping_ratio[k])
        v = s.values[k]
        common = dict(
            id1=_id_line(s.title),
            id2=_id_line(f"mode {k + 1}: {f:.6g} Hz, damping {100 * zeta:.4g} %"),
            id3=_id_line("written by femcal"),
            id4=_id_line(f"translations in basic; {s.units}" if s.units
                         else "translations in basic"),
            id5="NONE", model_type=1, data_ch=2, spec_data_type=8, n_data_per_node=3,
            load_case=case, mode_n=k + 1, node_nums=ids,
            r1=v[:, 0].copy(), r2=v[:, 1].copy(), r3=v[:, 2].copy(),
        )  # fmt: skip
        if s.kind == "normal":
            out.append(pyuff.prepare_55(
                analysis_type=2, data_type=2, freq=f, modal_m=float(s.modal_mass[k]),
                modal_damp_vis=zeta, modal_damp_his=0.0, **common))  # fmt: skip
        else:
            assert s.poles is not None
            out.append(pyuff.prepare_55(
                analysis_type=3, data_type=5, eig=complex(s.poles[k]), modal_a=0j,
                modal_b=0j, **common))  # fmt: skip
    return out


def write_uff_shapes(path: str | os.PathLike[str], grids: Grids | None = None,
                     shapes: Sequence[ModeShapes] = (),
                     trace_lines: TraceLines | None = None) -> Path:  # fmt: skip
    """A universal file with the units (164, for a known length unit), the grids (15), the
    trace lines (82) and one dataset 55 per mode of each set of ``shapes`` (load case 1, 2,
    ... in their order), written atomically. ``grids`` may be None for a file of shapes only
    (a reader puts them on a geometry it has by grid id).

    Raises
    ------
    ValueError
        For nothing to write, or trace lines or shapes at grids that ``grids`` lacks.
    """
    sets = uff_datasets(grids, shapes, trace_lines)
    if not sets:
        raise ValueError(f"{path}: nothing to write (no grids, trace lines or shapes)")

    return write_uff_sets(path, sets)


@dataclass(frozen=True)
class ShapeFile:
    """What :func:`read_uff_shapes` finds: grids (dataset 15), trace lines (82, as pairs)
    and the datasets 55 as pyuff reads them."""

    grids: Grids | None
    trace_pairs: np.ndarray
    shapes: list[dict] = field(default_factory=list)


def read_uff_shapes(path: str | os.PathLike[str]) -> ShapeFile:
    """Read back a file :func:`write_uff_shapes` wrote (or any universal file with datasets
    15, 82 and 55) with pyuff."""
    import pyuff

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResourceWarning)
        sets = pyuff.UFF(str(path)).read_sets()
        gc.collect()
    if isinstance(sets, dict):
        sets = [sets]
    grids = None
    pairs = []
    shapes = []
    for s in sets:
        if s.get("type") == 15:
            grids = Grids(np.asarray(s["node_nums"], float).astype(np.int64),
                          np.column_stack([s["x"], s["y"], s["z"]]))  # fmt: skip
        elif s.get("type") == 82:
            pairs.append(trace_line_pairs(s["nodes"]))
        elif s.get("type") == 55:
            shapes.append(s)
    trace = np.concatenate(pairs) if pairs else np.zeros((0, 2), np.int64)
    return ShapeFile(grids, trace, shapes)
