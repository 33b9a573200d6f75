"""Deck -> :class:`~femcal.model.constraints.Constraints`: the fixed DOF of PS and the selected
SPC set, the rigid elements, and the equations of the selected MPC set.

The node references were checked by :func:`femcal.model.build.build_model` before this runs;
whether the constraints fit together (a DOF made dependent twice, a rigid bar whose
independent DOF do not fix it) is decided where the transform is built
(:mod:`femcal.assembly.constraints`).
"""

from __future__ import annotations

import warnings

import numpy as np

from ..deck.deck import Deck
from ..errors import FemcalWarning, ModelError
from ..markers import INT_BLANK
from .constraints import (
    Constraints,
    Interpolation,
    LinearEquation,
    RigidBar,
    RigidLink,
    WeightedNodes,
)
from .model import Model


def components(code: int) -> tuple[int, ...]:
    """0-based components of a NASTRAN component code (``123`` -> (0, 1, 2)); () for blank
    or 0."""
    return () if code in (INT_BLANK, 0) else tuple(int(c) - 1 for c in str(code))


#: The cards that define the sets case control SPC and MPC select.
SET_CARDS = {"SPC": ("SPC", "SPC1", "SPCADD"), "MPC": ("MPC", "MPCADD")}


def _defined_sets(deck: Deck, key: str) -> set[int]:
    """Set ids that the deck's ``SET_CARDS[key]`` define."""
    ids: set[int] = set()
    for card in SET_CARDS[key]:
        t = deck.tables.get(card)
        if t is not None:
            ids.update(int(x) for x in t.columns["sid"])
        ids.update(int(r.sid) for r in deck.records_of(card))
    return ids


def selected_sets(deck: Deck, key: str, add_card: str) -> set[int]:
    """The set ids that case control ``key`` (SPC or MPC) selects, with the sets its
    ``add_card`` (SPCADD or MPCADD) unions bring in; empty without the command.

    A selected set that no card defines selects nothing, with a :class:`FemcalWarning`, as
    NASTRAN does (MSC Nastran's user warning 2053, "undefined single-point constraint set",
    and the solution goes on: reference deck ekm_cbar_suport).

    Raises
    ------
    ModelError
        For a value that is not a set id.
    """
    value = deck.case.value(key)
    if value is None:
        return set()
    loc = deck.case.location(key)
    at = f"{deck.where(*loc)}: " if loc else ""
    try:
        sid = int(value.split()[0])
    except (ValueError, IndexError):
        raise ModelError(f"{at}case control {key} = {value}: expected a set id") from None
    sets = {sid}
    grow = True
    while grow:
        grow = False
        for r in deck.records_of(add_card):
            if r.sid in sets and not set(r.sets) <= sets:
                sets |= set(r.sets)
                grow = True
    missing = sorted(sets - _defined_sets(deck, key))
    if missing:
        *first, last = SET_CARDS[key]
        via = "" if missing == [sid] else f" (through {add_card} {sid})"
        warnings.warn(FemcalWarning(
            f"{at}case control {key} = {sid}: no {', '.join(first)} or {last} card defines "
            f"set {', '.join(map(str, missing))}{via}; the model is solved without it, as "
            "NASTRAN does"), stacklevel=3)  # fmt: skip
    return sets


def constraints_of(deck: Deck, model: Model) -> Constraints:
    """The constraints of ``deck`` on ``model`` (its nodes and DOF map). A case control SPC
    or MPC that is not a set id selects nothing and is kept as a problem of the constraints
    (``Constraints.problems``), raised when they are used."""
    problems: list[str] = []

    def sets_of(key: str, add_card: str) -> set[int]:
        try:
            return selected_sets(deck, key, add_card)
        except ModelError as e:
            problems.append(str(e))
            return set()

    def node(gid: int) -> int:
        return int(model.node_index(gid)[0])

    def nodes(gids) -> tuple[int, ...]:
        return tuple(int(i) for i in model.node_index(list(gids)))

    links = tuple(RigidLink(r.eid, node(r.gn), nodes(r.gm), components(r.cm))
                  for r in deck.records_of("RBE2"))  # fmt: skip
    bars = []
    t = deck.tables.get("RBAR")
    if t is not None:
        c = t.columns
        for i in range(len(t)):
            ind = (*components(int(c["cna"][i])), *(6 + k for k in components(int(c["cnb"][i]))))
            dep = (*components(int(c["cma"][i])), *(6 + k for k in components(int(c["cmb"][i]))))
            if not dep:  # blank CMA and CMB: every DOF not independent is dependent
                dep = tuple(k for k in range(12) if k not in ind)
            bars.append(RigidBar(int(c["eid"][i]), (node(int(c["ga"][i])), node(int(c["gb"][i]))),
                                 ind, dep))  # fmt: skip
    interpolations = tuple(
        Interpolation(r.eid, node(r.refgrid), components(r.refc),
                      tuple(WeightedNodes(g.weight, components(g.components), nodes(g.grids))
                            for g in r.groups),
                      tuple((node(g), components(cm)) for g, cm in r.um))
        for r in deck.records_of("RBE3"))  # fmt: skip
    sets = sets_of("MPC", "MPCADD")
    equations = tuple(
        LinearEquation(r.sid, model.node_index([term[0] for term in r.terms]),
                       np.array([term[1] for term in r.terms], np.int64),
                       np.array([term[2] for term in r.terms], float))
        for r in deck.records_of("MPC") if r.sid in sets)  # fmt: skip
    fixed = _fixed_dofs(deck, model, sets_of("SPC", "SPCADD"))
    return Constraints(fixed, links, tuple(bars), interpolations, equations, tuple(problems))


def _fixed_dofs(deck: Deck, model: Model, sets: set[int]) -> np.ndarray:
    """g-set DOF fixed by GRID/GRDSET PS and the SPC ``sets`` selected in case control."""
    fixed: set[int] = set()
    for i in np.flatnonzero(model.ps):
        fixed.update(int(model.dof_start[i]) + c for c in components(int(model.ps[i])))

    def fix(g: int, code: int) -> None:
        i = int(model.node_index(g)[0])
        if not model.is_grid[i]:
            fixed.add(int(model.dof_start[i]))
        else:
            fixed.update(int(model.dof_start[i]) + c for c in components(code))

    for r in deck.records_of("SPC1"):
        if r.sid in sets:
            for g in r.ids:
                fix(g, r.components)
            for a, b in r.ranges:  # the THRU form: the grids of the range that exist
                lo, hi = np.searchsorted(model.node_ids, [a, b + 1])
                for g in model.node_ids[lo:hi]:
                    fix(int(g), r.components)
    t = deck.tables.get("SPC")
    if t is not None:
        c = t.columns
        for s, g, comp in zip(c["sid"], c["g"], c["c"], strict=True):
            if s in sets:
                fix(int(g), int(comp))
    return np.array(sorted(fixed), dtype=np.int64)
