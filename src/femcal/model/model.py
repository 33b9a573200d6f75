"""The Model: a structure as frozen arrays, built from a deck (:mod:`femcal.model.build`) or
in code (:mod:`femcal.model.builder`).

Below this layer nothing reads a card. NASTRAN ids stay here with one mapping each way:
nodes (GRID and SPOINT) are numbered 0..n-1 in ascending id order, as NASTRAN sequences
them; the DOF map gives 6 DOF per GRID and 1 per SPOINT in that order. Element, property and
material data keep NASTRAN's field names (lower case), so the property layer can say what
each one means; constraints, PARAMs and the eigenvalue request are typed values.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .analysis import EigenSetup, Params
from .constraints import Constraints
from .coords import CoordSystem
from .ids import IdIndex


@dataclass(frozen=True)
class ElementBlock:
    """All elements of one card type.

    Attributes
    ----------
    type : card name (``"CQUAD4"``).
    ids : (n,) element ids.
    pids : (n,) property ids, or -1 for elements without a property card.
    nodes : (n, k) node indices (0-based, into ``Model.node_ids``), -1 where a node is
        absent (ground, omitted midside node).
    components : (n, 2) component numbers for scalar elements (CELAS/CMASS 1-4), 0 for
        scalar points and ground; None for other types.
    data : the card's other columns, (n,) arrays keyed by QRG field name in lower case
        (``theta``, ``zoffs``, ``x1``, ``g0`` ...), with NaN / ``INT_BLANK`` for blank.
    file, line : (n,) source of each element (index into ``Model.files``, line).
    """

    type: str
    ids: np.ndarray
    pids: np.ndarray
    nodes: np.ndarray
    components: np.ndarray | None
    data: dict[str, np.ndarray]
    file: np.ndarray
    line: np.ndarray

    def __len__(self) -> int:
        return len(self.ids)


@dataclass(frozen=True)
class Model:
    """A structural model as arrays.

    Attributes
    ----------
    node_ids : (n_nodes,) GRID and SPOINT ids, ascending.
    is_grid : (n_nodes,) True for GRID, False for SPOINT.
    xyz : (n_nodes, 3) positions in the basic frame (mm or the deck's units); 0 for SPOINTs.
    cp, cd : (n_nodes,) input and displacement coordinate system ids (0 for SPOINTs).
    ps : (n_nodes,) permanent single-point constraint codes (0 for none), as read; the DOF
        they fix are among ``constraints.fixed``, which is what the solution uses.
    cd_frames : (n_nodes, 3, 3) columns = directions of components 1-3 (and 4-6) in basic.
    dof_start : (n_nodes,) index of each node's first DOF in the g-set.
    n_dof : g-set size (6 per GRID + 1 per SPOINT).
    coords : cid -> resolved :class:`CoordSystem` (0 is basic).
    elements : card name -> :class:`ElementBlock`, for every element type present.
    properties, materials : card name -> a table (dict of (n,) arrays keyed by field name)
        or a list of records, for the property and material cards present.
    params : the PARAMs that change the answer (:class:`~femcal.model.analysis.Params`).
    files : source files (the elements' ``file`` indexes into it).
    constraints : fixed DOF, rigid elements and multipoint equations.
    eigen : the eigenvalue requests and the one selected.
    unsupported : features of the deck that change the normal modes and that femcal does not
        model (a reduction to an a-set, component modes, direct matrix input); solving such
        a model is refused rather than answered differently.
    solution : the deck's SOL as written (``"103"``, ``"SEMODES"``), ``""`` for a bulk-data
        file or a model built in code.
    solution_number : the SOL's number (``SEMODES`` -> 103), None where there is none.
    """

    node_ids: np.ndarray
    is_grid: np.ndarray
    xyz: np.ndarray
    cp: np.ndarray
    cd: np.ndarray
    ps: np.ndarray
    cd_frames: np.ndarray
    dof_start: np.ndarray
    n_dof: int
    coords: dict[int, CoordSystem]
    elements: dict[str, ElementBlock]
    properties: dict[str, object]
    materials: dict[str, object]
    params: Params = field(default_factory=Params)
    files: list[str] = field(default_factory=list)
    constraints: Constraints = field(default_factory=Constraints)
    eigen: EigenSetup = field(default_factory=EigenSetup)
    unsupported: tuple[str, ...] = ()
    solution: str = ""
    solution_number: int | None = None

    @property
    def n_nodes(self) -> int:
        return len(self.node_ids)

    @property
    def n_grids(self) -> int:
        return int(self.is_grid.sum())

    @property
    def n_spoints(self) -> int:
        return int((~self.is_grid).sum())

    def node_index(self, ids: np.ndarray | list[int] | int) -> np.ndarray:
        """0-based node indices of NASTRAN ids; -1 where an id is not a node."""
        return IdIndex(self.node_ids, ascending=True).rows(ids)

    def dof_index(
        self, ids: np.ndarray | list[int], components: np.ndarray | list[int]
    ) -> np.ndarray:
        """g-set DOF indices of (node id, component) pairs (1-6 at a GRID, 0 at a SPOINT)."""
        return self.dofs(self.node_index(ids), components)

    def dofs(self, nodes: np.ndarray, components: np.ndarray | list[int]) -> np.ndarray:
        """g-set DOF indices of (node index, component) pairs (1-6 at a GRID, 0 at a
        SPOINT)."""
        nodes = np.asarray(nodes, dtype=np.int64)
        comp = np.asarray(components, dtype=np.int64)
        return self.dof_start[nodes] + np.where(self.is_grid[nodes], comp - 1, 0)

    def dof_owner(self, dofs: np.ndarray | list[int] | int) -> tuple[np.ndarray, np.ndarray]:
        """(node indices, components) of g-set DOF: components 1-6 at a GRID, 0 at a scalar
        point."""
        d = np.atleast_1d(np.asarray(dofs, dtype=np.int64))
        node = np.searchsorted(self.dof_start, d, side="right") - 1
        return node, d - self.dof_start[node] + np.where(self.is_grid[node], 1, 0)

    def dof_label(self, dof: int) -> str:
        """``GRID 12 C3`` or ``SPOINT 7 C0``: a g-set DOF as errors name it."""
        node, comp = self.dof_owner(dof)
        kind = "GRID" if self.is_grid[node[0]] else "SPOINT"
        return f"{kind} {self.node_ids[node[0]]} C{comp[0]}"
