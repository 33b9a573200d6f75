"""The constraints of a model, as data: fixed DOF, rigid elements and multipoint equations.

NASTRAN's sources, resolved when the model is built: single-point constraints (GRID and
GRDSET PS, and the SPC / SPC1 / SPCADD set that case control SPC selects) become the fixed
g-set DOF; RBE2, RBAR and RBE3 the rigid elements below; the MPC / MPCADD set that case
control MPC selects the linear equations. Nodes are 0-based indices into ``Model.node_ids``
and components 0-based (0-5 at a GRID: T1 T2 T3 R1 R2 R3), so that
:mod:`femcal.assembly.constraints` builds the transform u_g = T u_a from them without
knowing a card.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class RigidLink:
    """An RBE2: the ``components`` of every dependent node follow the independent node as a
    rigid body.

    Attributes
    ----------
    id : element id.
    independent : node index (NASTRAN's GN).
    dependent : node indices (GM1, GM2, ...).
    components : 0-based components of the dependent nodes (CM).
    """

    id: int
    independent: int
    dependent: tuple[int, ...]
    components: tuple[int, ...]


@dataclass(frozen=True)
class RigidBar:
    """An RBAR between nodes a and b. Its 12 DOF are numbered 0-5 at a and 6-11 at b.

    Attributes
    ----------
    id : element id.
    nodes : (a, b) node indices (GA, GB).
    independent : the DOF given as independent (CNA, CNB), 6 of them for a valid bar.
    dependent : the DOF given as dependent (CMA, CMB); empty: every DOF not independent.
    """

    id: int
    nodes: tuple[int, int]
    independent: tuple[int, ...]
    dependent: tuple[int, ...]


@dataclass(frozen=True)
class WeightedNodes:
    """One weighted group of an RBE3's independent nodes."""

    weight: float
    components: tuple[int, ...]
    nodes: tuple[int, ...]


@dataclass(frozen=True)
class Interpolation:
    """An RBE3: the reference node's ``reference_components`` move as the weighted
    least-squares rigid fit of the independent nodes' motion.

    Attributes
    ----------
    id : element id.
    reference : node index (REFGRID); reference_components : 0-based (REFC).
    groups : the weighted independent nodes.
    other_dependent : (node index, 0-based components) given as dependent instead (UM).
    """

    id: int
    reference: int
    reference_components: tuple[int, ...]
    groups: tuple[WeightedNodes, ...]
    other_dependent: tuple[tuple[int, tuple[int, ...]], ...] = ()


@dataclass(frozen=True)
class LinearEquation:
    """An MPC: ``sum coefficients[i] u(nodes[i], components[i]) = 0``, the first term's DOF
    dependent.

    Attributes
    ----------
    set_id : the MPC set it came from.
    nodes : (k,) node indices.
    components : (k,) components as written: 1-6 at a GRID, 0 at a scalar point.
    coefficients : (k,).
    """

    set_id: int
    nodes: np.ndarray
    components: np.ndarray
    coefficients: np.ndarray


@dataclass(frozen=True)
class Constraints:
    """Everything that constrains a model's g-set.

    Attributes
    ----------
    fixed : (n,) g-set DOF fixed by single-point constraints, ascending and unique.
    rigid_links, rigid_bars, interpolations : RBE2, RBAR and RBE3 elements, in the order of
        the deck.
    equations : the selected MPC equations.
    problems : what makes the constraints unusable, found when they were read (a case control
        SPC or MPC that is not a set id): building the transform raises them, so that a model
        with them can still be read and summarised.
    """

    fixed: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    rigid_links: tuple[RigidLink, ...] = ()
    rigid_bars: tuple[RigidBar, ...] = ()
    interpolations: tuple[Interpolation, ...] = ()
    equations: tuple[LinearEquation, ...] = ()
    problems: tuple[str, ...] = ()
