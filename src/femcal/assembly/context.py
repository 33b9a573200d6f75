"""What the element handlers of the assembly share: the model, the PARAM-derived options,
material lookups, and running a handler's kernels in chunks on worker threads."""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence

import numpy as np

from ..elements.shell import grid_normals
from ..model.model import Model
from ..parallel import executor, ordered
from ..properties.materials import MaterialTables
from .pattern import Assembler

#: Elements per kernel call. It bounds the kernels' temporaries to about 5 MB each, small
#: enough for the C library to reuse freed memory rather than map fresh pages per call (which
#: costs more than the arithmetic), large enough to amortise NumPy's per-call overhead, and
#: splits a group of a few thousand elements into enough calls to keep the threads busy.
KERNEL_CHUNK = 1024


def chunks(rows: np.ndarray) -> list[np.ndarray]:
    """``rows`` (element indices) in parts of at most :data:`KERNEL_CHUNK`."""
    return [rows[s : s + KERNEL_CHUNK] for s in range(0, len(rows), KERNEL_CHUNK)]


class Context:
    """The model being assembled and how: coupled or lumped mass, the shells' K6ROT, the
    threads the kernels may use."""

    def __init__(self, model: Model, coupled: bool, k6rot: float, threads: int = 1,
                 grid_normals: np.ndarray | None = None, kept: dict | None = None):  # fmt: skip
        """``grid_normals``: the shells' grid normals if known (a part of a model is
        assembled with the whole model's normals); computed from the model's shells if
        not. ``kept``: a dict in which kernels keep what depends on the elements' shape
        alone, per part of a block, for assemblies of the same elements again (None: not
        kept)."""
        self.model = model
        self.kept = kept
        self.coupled = coupled
        self.k6rot = k6rot
        self.threads = threads
        self.materials = MaterialTables(model.materials)
        self._grid_normals = grid_normals

    def grid_normals(self) -> np.ndarray:
        """(n_nodes, 3) NASTRAN's unique grid-point normals of the shells (PARAM SNORM), NaN
        where a grid has none; computed once (or given)."""
        if self._grid_normals is None:
            self._grid_normals = shell_grid_normals(self.model)
        return self._grid_normals

    def run_chunks(
        self,
        asm: Assembler,
        parts: Sequence[np.ndarray],
        compute: Callable[[np.ndarray], tuple[np.ndarray, int, np.ndarray, np.ndarray]],
    ) -> None:
        """Element matrices of each part (element indices) by ``compute(part) -> (nodes, dof
        per node, K, M)``, added to ``asm``.

        The kernels and the assembler's preparation run on ``threads`` worker threads, at most
        one part ahead of each; the scatter runs here, in part order, so the sums are the same
        whatever the thread count, and the first failing part (in order) raises.
        """

        def task(part: np.ndarray) -> list:
            nodes, d, K, M = compute(part)
            return asm.prepare(nodes, d, K, M)

        threads = self.threads if len(parts) > 1 else 1
        with executor("threads", threads, name="femcal-kernel") as pool:
            for prepared in ordered(pool, task, parts, ahead=threads + 1):
                asm.scatter(prepared)


#: Shell element types whose normals make the grid normals (NASTRAN: all shells with 3 or 4
#: corners, the quadratic ones by their corners).
_SHELLS = {"CQUAD4": 4, "CQUADR": 4, "CQUAD8": 4, "CTRIA3": 3, "CTRIAR": 3, "CTRIA6": 3}


def shell_grid_normals(model: Model) -> np.ndarray:
    """(n_nodes, 3) unique grid-point normals of the model's shells (PARAM SNORM), NaN where a
    grid has none. A degenerate shell (no normal) is left out here; its handler names it."""
    conn, normals = [], []
    for etype, corners in _SHELLS.items():
        block = model.elements.get(etype)
        if block is None:
            continue
        c = block.nodes[:, :corners]
        xyz = model.xyz[np.where(c < 0, 0, c)]
        if corners == 4:
            n = np.cross(xyz[:, 2] - xyz[:, 0], xyz[:, 3] - xyz[:, 1])
        else:
            n = np.cross(xyz[:, 1] - xyz[:, 0], xyz[:, 2] - xyz[:, 0])
        length = np.linalg.norm(n, axis=1)
        ok = (length > 0.0) & (c >= 0).all(axis=1)
        conn.append(c[ok])
        normals.append(n[ok] / length[ok, None])
    return grid_normals(model.n_nodes, conn, normals, model.params.snorm)


def name_positions(message: str, ids: np.ndarray) -> str:
    """Replace the element positions ``[i, j]`` of a kernel's message (``element index(es)
    [i, j]``, ``positions [i, j]`` or a bare list) by the element ids they stand for."""
    m = re.search(r"(?:element )?(?:index\(es\) |positions )?\[([\d, ]+)\]", message)
    if not m:
        return message
    pos = [int(x) for x in m.group(1).split(",") if x.strip()]
    named = [int(ids[p]) for p in pos if 0 <= p < len(ids)]
    return message[: m.start()] + f"element ids {named}" + message[m.end() :]
