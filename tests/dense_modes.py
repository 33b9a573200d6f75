"""A test harness until the SOL 103 solver exists: single-point constraints by deletion and a
dense generalised eigensolution. Small decks only; no MPC or rigid elements."""

from __future__ import annotations

import numpy as np
import scipy.linalg as sl

from femcal.deck import Deck
from femcal.model import Model
from femcal.structure import assemble


def spc_dofs(deck: Deck, model: Model) -> set[int]:
    """g-set DOF fixed by GRID PS and the SPC set selected in case control (SPC, SPC1, SPCADD)."""
    fixed: set[int] = set()
    for i, ps in enumerate(model.ps):
        if ps:
            fixed.update(int(model.dof_start[i]) + int(c) - 1 for c in str(ps))
    sid = deck.case.value("SPC")
    if sid is None:
        return fixed
    sets = {int(sid)}
    for r in deck.records_of("SPCADD"):
        if r.sid in sets:
            sets |= set(r.sets)

    def fix(g: int, comps: int) -> None:
        n = int(model.node_index(g)[0])
        for c in str(comps):
            fixed.add(int(model.dof_start[n]) + max(int(c), 1) - 1)

    for r in deck.records_of("SPC1"):
        if r.sid in sets:
            for g in r.ids:
                fix(g, r.components)
    t = deck.tables.get("SPC")
    if t is not None:
        c = t.columns
        for s, g, comp in zip(c["sid"], c["g"], c["c"], strict=True):
            if s in sets:
                fix(int(g), int(comp))
    return fixed


def dense_frequencies(deck: Deck, model: Model) -> np.ndarray:
    """Natural frequencies (Hz), ascending, of the SPC-constrained model; DOF with neither
    stiffness nor mass are dropped (what AUTOSPC would constrain)."""
    mats = assemble(model)
    K, M = mats.K.toarray(), mats.M.toarray()
    keep = np.setdiff1d(np.arange(model.n_dof), sorted(spc_dofs(deck, model)))
    K, M = K[np.ix_(keep, keep)], M[np.ix_(keep, keep)]
    empty = (np.abs(K).sum(1) <= 1e-12 * np.abs(K).max()) & (np.abs(M).sum(1) == 0)
    K, M = K[np.ix_(~empty, ~empty)], M[np.ix_(~empty, ~empty)]
    w = sl.eig(K, M, right=False)
    w = np.real(w[np.isfinite(w)])
    w = np.sort(w[w > -1e-6 * np.abs(w).max()])
    return np.sqrt(np.abs(w)) / (2 * np.pi)
