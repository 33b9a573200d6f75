"""Writing normal-mode results: the f06-style eigenvalue table, NPZ results, VTU for ParaView.

All files are written to a temporary name and renamed, so a failed run leaves no half file.
meshio is imported only when a VTU is written.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
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
    dof_start, is_grid, xyz (n_nodes, 3) and cd_frames (n_nodes, 3, 3)."""

    def w(tmp: str) -> None:
        with open(tmp, "wb") as fh:
            np.savez_compressed(
                fh, frequencies_hz=modes.frequencies_hz, eigenvalues=modes.eigenvalues,
                generalized_mass=modes.generalized_mass, shapes=modes.shapes,
                node_ids=model.node_ids, dof_start=model.dof_start, is_grid=model.is_grid,
                xyz=model.xyz, cd_frames=model.cd_frames,
            )  # fmt: skip

    return write_atomic(path, w)


def basic_translations(modes: Modes, model: Model) -> np.ndarray:
    """(n_nodes, 3, k) translations of every node in basic for every mode (0 at SPOINTs)."""
    n = model.n_nodes
    k = modes.shapes.shape[1]
    out = np.zeros((n, 3, k))
    g = np.flatnonzero(model.is_grid)
    local = modes.shapes[model.dof_start[g][:, None] + np.arange(3)]  # (n_g, 3, k)
    out[g] = np.einsum("nij,njk->nik", model.cd_frames[g], local)
    return out


def mesh_cells(model: Model) -> list[tuple[str, np.ndarray]]:
    """meshio cell blocks (type, node indices) of the model's elements."""
    cells: list[tuple[str, np.ndarray]] = []
    for etype, b in model.elements.items():
        if etype in _CELLS:
            kind, order = _CELLS[etype]
            nodes = b.nodes
            if kind == "line":
                nodes = nodes[(nodes >= 0).all(axis=1)]
            if len(nodes):
                cells.append((kind, nodes if order is None else nodes[:, order]))
            continue
        for (name, nn), (kind, order) in _SOLID_CELLS.items():
            if name != etype:
                continue
            present = (b.nodes >= 0).sum(axis=1) == nn
            if present.any():
                nodes = b.nodes[present, :nn]
                cells.append((kind, nodes if order is None else nodes[:, order]))
    return cells


def write_vtu(path: Path, modes: Modes, model: Model) -> Path:
    """VTU (ParaView) with the mesh and one displacement vector field per mode, basic frame."""
    import meshio

    disp = basic_translations(modes, model)
    point_data = {
        f"mode_{i + 1:03d}_{f:.4g}Hz": disp[:, :, i] for i, f in enumerate(modes.frequencies_hz)
    }
    mesh = meshio.Mesh(model.xyz, mesh_cells(model), point_data=point_data)
    mesh.field_data["frequencies_hz"] = np.asarray(modes.frequencies_hz)

    def w(tmp: str) -> None:
        meshio.write(tmp, mesh, file_format="vtu")

    return write_atomic(path, w)
