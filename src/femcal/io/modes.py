"""Writing normal-mode results: the f06-style eigenvalue table, NPZ results, VTU for ParaView.

All files are written to a temporary name and renamed, so a failed run leaves no half file.
meshio is imported only when a VTU is written.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..atomic import write_atomic
from ..model.model import Model
from ..solve.normal_modes import Modes

#: NASTRAN element -> (meshio cell type, node order from NASTRAN's to VTK's).
_CELLS = {
    "CQUAD4": ("quad", None), "CQUADR": ("quad", None), "CTRIA3": ("triangle", None),
    "CTRIAR": ("triangle", None), "CSHEAR": ("quad", None),
    "CQUAD8": ("quad8", None), "CTRIA6": ("triangle6", None),
    "CBAR": ("line", None), "CBEAM": ("line", None), "CROD": ("line", None),
    "CONROD": ("line", None), "CTUBE": ("line", None), "CBUSH": ("line", None),
    "CONM2": ("vertex", None), "CONM1": ("vertex", None),
}  # fmt: skip
_SOLID_CELLS = {
    ("CHEXA", 8): ("hexahedron", None),
    ("CHEXA", 20): ("hexahedron20", [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 16, 17, 18, 19,
                                     12, 13, 14, 15]),
    ("CPENTA", 6): ("wedge", None),
    ("CPENTA", 15): ("wedge15", [0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 13, 14, 9, 10, 11]),
    ("CTETRA", 4): ("tetra", None),
    ("CTETRA", 10): ("tetra10", None),
    ("CPYRAM", 5): ("pyramid", None),
    ("CPYRAM", 13): ("pyramid13", None),
}  # fmt: skip


def eigen_table(modes: Modes) -> Iterator[str]:
    """Lines of NASTRAN's REAL EIGENVALUES table."""
    yield "                                              R E A L   E I G E N V A L U E S"
    yield ("   MODE    EXTRACTION      EIGENVALUE            RADIANS             CYCLES"
           "            GENERALIZED         GENERALIZED")  # fmt: skip
    yield ("    NO.       ORDER                                                         "
           "              MASS              STIFFNESS")  # fmt: skip
    for i, (lam, rad, hz, gm, gk) in enumerate(
        zip(modes.eigenvalues, modes.radians, modes.frequencies_hz, modes.generalized_mass,
            modes.generalized_stiffness, strict=True), start=1):  # fmt: skip
        yield (f"{i:9d}{i:10d}        {lam:13.6E}       {rad:13.6E}       {hz:13.6E}"
               f"       {gm:13.6E}       {gk:13.6E}")  # fmt: skip


def modes_json(modes: Modes, model: Model) -> dict:
    """JSON-ready summary of a modal solution."""
    return {
        "modes": [
            {"mode": i + 1, "eigenvalue": float(lam), "radians": float(r),
             "frequency_hz": float(f), "generalized_mass": float(gm),
             "generalized_stiffness": float(gk)}
            for i, (lam, r, f, gm, gk) in enumerate(zip(
                modes.eigenvalues, modes.radians, modes.frequencies_hz, modes.generalized_mass,
                modes.generalized_stiffness, strict=True))
        ],
        "n_dof": int(model.n_dof),
        "n_a": int(modes.n_a),
        "solver": modes.backend,
        "autospc": [[int(g), int(c)] for g, c in modes.autospc],
    }  # fmt: skip


def write_json(path: Path, data: dict) -> Path:
    def w(tmp: str) -> None:
        Path(tmp).write_text(json.dumps(data, indent=1))

    return write_atomic(path, w)


def write_npz(path: Path, modes: Modes, model: Model) -> Path:
    """NPZ with frequencies_hz, eigenvalues, generalized_mass, shapes (n_g, k), node_ids,
    dof_start, is_grid, xyz (n_nodes, 3) and cd_frames (n_nodes, 3, 3). Not compressed:
    mode shapes' float64 digits compress by a few per cent, at ten times the writing time."""

    def w(tmp: str) -> None:
        with open(tmp, "wb") as fh:
            np.savez(
                fh, frequencies_hz=modes.frequencies_hz, eigenvalues=modes.eigenvalues,
                generalized_mass=modes.generalized_mass, shapes=modes.shapes,
                node_ids=model.node_ids, dof_start=model.dof_start, is_grid=model.is_grid,
                xyz=model.xyz, cd_frames=model.cd_frames,
            )  # fmt: skip

    return write_atomic(path, w)


def basic_translations(modes: Modes, model: Model) -> np.ndarray:
    """(n_nodes, 3, k) translations of every node in basic for every mode (0 at SPOINTs)."""
    return _basic(modes, model, 0)


def basic_rotations(modes: Modes, model: Model) -> np.ndarray:
    """(n_nodes, 3, k) rotations (components 4-6) of every node in basic for every mode (0 at
    SPOINTs): each grid's CD frame turns them as it turns its translations."""
    return _basic(modes, model, 3)


def grid_motions(shapes: np.ndarray, is_grid: np.ndarray, dof_start: np.ndarray,
                 cd_frames: np.ndarray, first: int = 0) -> np.ndarray:
    """(n_grids, 3, k) the components ``first`` + 1..3 (translations from 0, rotations from
    3) of g-set ``shapes`` (n_dof, k) at every grid, turned from each grid's displacement
    frame to basic; the grids in node order. The layout arrays are a model's (or a modes
    file's without its model): ``is_grid`` (n_nodes,), ``dof_start`` (n_nodes,), ``cd_frames``
    (n_nodes, 3, 3)."""
    g = np.flatnonzero(is_grid)
    local = shapes[dof_start[g][:, None] + first + np.arange(3)]  # (n_g, 3, k)
    return np.einsum("nij,njk->nik", cd_frames[g], local)


def _basic(modes: Modes, model: Model, first: int) -> np.ndarray:
    out = np.zeros((model.n_nodes, 3, modes.shapes.shape[1]))
    out[model.is_grid] = grid_motions(modes.shapes, model.is_grid, model.dof_start,
                                      model.cd_frames, first)  # fmt: skip
    return out


#: The VTU's cell data ``element_type``: a code per card (stable: new cards get new codes).
#: The file's field data repeats it as ``element_type_<CARD>`` = [code] for the cards present.
ELEMENT_TYPE_CODES: dict[str, int] = {
    "CQUAD4": 1, "CQUADR": 2, "CQUAD8": 3, "CTRIA3": 4, "CTRIAR": 5, "CTRIA6": 6,
    "CSHEAR": 7, "CHEXA": 8, "CPENTA": 9, "CTETRA": 10, "CPYRAM": 11,
    "CBAR": 12, "CBEAM": 13, "CROD": 14, "CONROD": 15, "CTUBE": 16, "CBUSH": 17,
    "CELAS1": 18, "CELAS2": 19, "CONM2": 20, "CONM1": 21,
    "RBE2": 22, "RBAR": 23, "RBE3": 24,
}  # fmt: skip
#: Spring cards drawn as a line between their two grids (a point where one end is ground).
_SPRINGS = ("CELAS1", "CELAS2")
#: Rigid elements (model constraints) drawn as lines from their independent grid.
RIGID_TYPES = ("RBE2", "RBAR", "RBE3")


@dataclass(frozen=True)
class CellBlock:
    """Cells of one element card and one cell shape: ``kind`` the meshio cell type,
    ``element_type`` the card (``"CQUAD4"``, ``"RBE2"``), ``nodes`` (n, k) node indices in
    VTK order, ``ids`` (n,) element ids and ``pids`` (n,) property ids (-1 for none). A rigid
    element has one line cell per leg (independent grid to dependent grid), each with the
    element's id."""

    kind: str
    element_type: str
    nodes: np.ndarray
    ids: np.ndarray
    pids: np.ndarray


def element_cells(model: Model, *, springs: bool = True, rigid: bool = True) -> list[CellBlock]:
    """The model's elements as cell blocks with their ids: those of :func:`mesh_cells`, and
    with ``springs`` CELAS1/CELAS2 between two grids as lines (to ground as points), with
    ``rigid`` the legs of RBE2, RBAR and RBE3 as lines."""
    out: list[CellBlock] = []
    for etype, b in model.elements.items():
        if etype in _CELLS:
            kind, order = _CELLS[etype]
            keep = (b.nodes >= 0).all(axis=1) if kind == "line" else slice(None)
            nodes = b.nodes[keep]
            if len(nodes):
                out.append(CellBlock(kind, etype, nodes if order is None else nodes[:, order],
                                     b.ids[keep], b.pids[keep]))  # fmt: skip
            continue
        if springs and etype in _SPRINGS:
            nodes = b.nodes[:, :2]
            on_grid = (nodes >= 0) & model.is_grid[np.maximum(nodes, 0)]
            both = on_grid.all(axis=1)
            one = on_grid.any(axis=1) & ~both
            if both.any():
                out.append(CellBlock("line", etype, nodes[both], b.ids[both], b.pids[both]))
            if one.any():
                end = np.where(on_grid[one, 0], nodes[one, 0], nodes[one, 1])
                out.append(CellBlock("vertex", etype, end[:, None], b.ids[one], b.pids[one]))
            continue
        for (name, nn), (kind, order) in _SOLID_CELLS.items():
            if name != etype:
                continue
            present = (b.nodes >= 0).sum(axis=1) == nn
            if present.any():
                nodes = b.nodes[present, :nn]
                out.append(CellBlock(kind, etype, nodes if order is None else nodes[:, order],
                                     b.ids[present], b.pids[present]))  # fmt: skip
    if rigid:
        c = model.constraints
        legs = {
            "RBE2": [(r.id, r.independent, d) for r in c.rigid_links for d in r.dependent],
            "RBAR": [(r.id, *r.nodes) for r in c.rigid_bars],
            "RBE3": [(r.id, r.reference, n) for r in c.interpolations for g in r.groups
                     for n in g.nodes],
        }  # fmt: skip
        for etype, rows in legs.items():
            a = np.array(rows, dtype=np.int64).reshape(-1, 3)
            a = a[(a[:, 1] != a[:, 2]) & model.is_grid[a[:, 1]] & model.is_grid[a[:, 2]]]
            if len(a):
                out.append(CellBlock("line", etype, a[:, 1:], a[:, 0], np.full(len(a), -1)))
    return out


def mesh_cells(model: Model) -> list[tuple[str, np.ndarray]]:
    """meshio cell blocks (type, node indices) of the model's elements (no springs or rigid
    elements: :func:`element_cells` has those and the ids)."""
    return [(b.kind, b.nodes) for b in element_cells(model, springs=False, rigid=False)]


def _vtu_point_data(modes: Modes, model: Model) -> dict[str, np.ndarray]:
    t = basic_translations(modes, model)
    r = basic_rotations(modes, model)
    data: dict[str, np.ndarray] = {"grid_id": np.asarray(model.node_ids, dtype=np.int32)}
    for i, f in enumerate(modes.frequencies_hz):
        name = f"mode_{i + 1:03d}_{f:.4g}Hz"
        data[name] = t[:, :, i]
        data[f"{name}_rotation"] = r[:, :, i]
    return data


def write_vtu(path: Path, modes: Modes, model: Model) -> Path:
    """VTU (ParaView) with the mesh, its springs and rigid elements' legs, and per mode the
    translations and rotations in the basic frame.

    Point data: ``grid_id`` (the GRID or SPOINT id; SPOINTs sit at the origin) and per mode
    ``mode_NNN_<f>Hz`` (translations: Warp By Vector animates it) and
    ``mode_NNN_<f>Hz_rotation``, as solved (EIGRL normalisation). Cell data: ``element_id``,
    ``property_id`` (-1 where the card has none: CONM2, CELAS2, rigid elements) and
    ``element_type`` (:data:`ELEMENT_TYPE_CODES`). Field data: ``frequencies_hz`` and
    ``element_type_<CARD>`` = [code] for each card present (ParaView's Information panel
    lists them). Rigid elements have one line cell per leg.
    """
    import meshio

    blocks = element_cells(model)
    cell_data = {
        "element_id": [b.ids.astype(np.int32) for b in blocks],
        "property_id": [b.pids.astype(np.int32) for b in blocks],
        "element_type": [np.full(len(b.ids), ELEMENT_TYPE_CODES[b.element_type], np.int32)
                         for b in blocks],
    }  # fmt: skip
    mesh = meshio.Mesh(model.xyz, [(b.kind, b.nodes) for b in blocks],
                       point_data=_vtu_point_data(modes, model), cell_data=cell_data)  # fmt: skip
    field = {"frequencies_hz": np.asarray(modes.frequencies_hz, dtype=float)}
    for etype in dict.fromkeys(b.element_type for b in blocks):
        field[f"element_type_{etype}"] = np.array([ELEMENT_TYPE_CODES[etype]], np.int32)

    def w(tmp: str) -> None:
        # binary, not compressed: zlib takes most of the writing time for a few per cent
        meshio.write(tmp, mesh, file_format="vtu", compression=None)
        _add_field_data(Path(tmp), field)

    return write_atomic(path, w)


def _add_field_data(path: Path, field: dict[str, np.ndarray]) -> None:
    """Put ``field`` into the VTU file as its ``<FieldData>`` (meshio 5.3 reads field data but
    does not write it): ASCII arrays, float64 to 17 digits, before the ``<Piece>``."""
    rows = []
    for name, a in field.items():
        kind = "Float64" if a.dtype.kind == "f" else "Int32"
        text = " ".join(format(x, ".17g") if kind == "Float64" else str(int(x)) for x in a)
        rows.append(f'<DataArray type="{kind}" Name="{name}" NumberOfTuples="{len(a)}" '
                    f'format="ascii">{text}</DataArray>')  # fmt: skip
    if not rows:
        return
    xml = path.read_bytes()
    tag = b"<UnstructuredGrid>"
    at = xml.find(tag)
    if at < 0:
        raise RuntimeError(f"{path}: meshio wrote no <UnstructuredGrid> element")
    block = ("<FieldData>" + "".join(rows) + "</FieldData>").encode()
    path.write_bytes(xml[: at + len(tag)] + block + xml[at + len(tag) :])
