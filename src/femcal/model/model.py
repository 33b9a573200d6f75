"""The Model: frozen arrays built from a Deck.

Below this layer nothing knows a card. NASTRAN ids stay here with one mapping each way:
nodes (GRID and SPOINT) are numbered 0..n-1 in ascending id order, as NASTRAN sequences
them; the DOF map gives 6 DOF per GRID and 1 per SPOINT in that order.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .coords import CoordSystem


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
    ps : (n_nodes,) permanent single-point constraint codes (0 for none).
    cd_frames : (n_nodes, 3, 3) columns = directions of components 1-3 (and 4-6) in basic.
    dof_start : (n_nodes,) index of each node's first DOF in the g-set.
    n_dof : g-set size (6 per GRID + 1 per SPOINT).
    coords : cid -> resolved :class:`CoordSystem` (0 is basic).
    elements : card name -> :class:`ElementBlock`, for every element type present.
    properties, materials : card name -> the deck's table (dict of (n,) arrays) or list of
        records, for property and material cards present.
    params : PARAM name -> value(s).
    files : source files (locations index into it).
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
    params: dict[str, tuple]
    files: list[str] = field(default_factory=list)

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
        ids = np.atleast_1d(np.asarray(ids, dtype=np.int64))
        pos = np.searchsorted(self.node_ids, ids)
        pos = np.clip(pos, 0, max(len(self.node_ids) - 1, 0))
        ok = len(self.node_ids) > 0
        found = (self.node_ids[pos] == ids) if ok else np.zeros(len(ids), bool)
        return np.where(found, pos, -1)

    def dof_index(
        self, ids: np.ndarray | list[int], components: np.ndarray | list[int]
    ) -> np.ndarray:
        """g-set DOF indices of (node id, component) pairs (1-6 at a GRID, 0 at a SPOINT)."""
        idx = self.node_index(ids)
        comp = np.asarray(components, dtype=np.int64)
        off = np.where(self.is_grid[idx], comp - 1, 0)
        return self.dof_start[idx] + off
