"""SOL 103 normal modes of a deck: model, matrices, constraints, eigensolution, g-set shapes."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..assembly.constraints import Reduction, autospc, build_reduction
from ..assembly.structure import Matrices, Options, assemble
from ..deck.deck import Deck
from ..deck.fields import INT_BLANK
from ..errors import ModelError
from ..model.model import Model
from .eigen import EigenRequest, EigenResult, solve_modes


@dataclass(frozen=True)
class Modes:
    """Normal modes on the g-set.

    Attributes
    ----------
    eigenvalues : (k,) rad^2/s^2; frequencies_hz, radians : (k,).
    generalized_mass, generalized_stiffness : (k,).
    shapes : (n_g, k) mode shapes in the nodes' displacement frames.
    node_ids, dof_start, is_grid : the g-set layout (see :class:`~femcal.model.Model`).
    autospc : (m, 2) (node id, component) fixed by AUTOSPC or as empty DOF.
    n_a : size of the solved set; backend : eigensolver backend.
    """

    eigenvalues: np.ndarray
    generalized_mass: np.ndarray
    generalized_stiffness: np.ndarray
    shapes: np.ndarray
    node_ids: np.ndarray
    dof_start: np.ndarray
    is_grid: np.ndarray
    autospc: np.ndarray
    n_a: int
    backend: str

    @property
    def radians(self) -> np.ndarray:
        return np.sign(self.eigenvalues) * np.sqrt(np.abs(self.eigenvalues))

    @property
    def frequencies_hz(self) -> np.ndarray:
        return self.radians / (2.0 * np.pi)

    def grid_displacements(self, mode: int) -> np.ndarray:
        """(n_grids, 6) displacement of each GRID in mode ``mode`` (0-based), CD frames."""
        starts = self.dof_start[self.is_grid]
        return self.shapes[starts[:, None] + np.arange(6), mode]


def eigen_request(deck: Deck) -> EigenRequest:
    """The EIGRL or EIGR selected by case control METHOD, as an :class:`EigenRequest`."""
    value = deck.case.value("METHOD")
    if value is None:
        raise ModelError("case control has no METHOD: SOL 103 needs an EIGRL (or EIGR) set")
    try:
        sid = int(value.split()[0])
    except ValueError as e:
        raise ModelError(f"case control METHOD = {value}: expected a set id") from e
    for r in deck.records_of("EIGRL"):
        if r.sid == sid:
            nd = None if r.nd == INT_BLANK else r.nd
            return EigenRequest(_hz(r.v1), _hz(r.v2), nd, r.norm)
    t = deck.tables.get("EIGR")
    if t is not None:
        c = t.columns
        for i in np.flatnonzero(c["sid"] == sid):
            nd = int(c["nd"][i]) if c["nd"][i] != INT_BLANK else None
            f2 = _hz(c["f2"][i])
            if nd is None and f2 is None:
                nd = 10**9  # all roots (Givens/Householder)
            return EigenRequest(_hz(c["f1"][i]), f2, nd, str(c["norm"][i] or "MASS"))
    raise ModelError(f"METHOD = {sid}: no EIGRL or EIGR with SID {sid} in the bulk data", [sid])


def _autospc_enabled(deck: Deck, model: Model) -> bool:
    """Case control AUTOSPC (YES/NO, with options) wins over PARAM AUTOSPC; default YES."""
    cc = deck.case.value("AUTOSPC")
    if cc is not None:
        return not cc.strip().upper().startswith("NO")
    return str(model.params.get("AUTOSPC", ("YES",))[0]).upper() != "NO"


def _hz(v: float) -> float | None:
    return None if v is None or np.isnan(v) else float(v)


#: Cards that make NASTRAN solve a reduced or different problem femcal does not solve yet.
REDUCTION_CARDS = {
    "ASET": "static (Guyan) reduction to an a-set",
    "ASET1": "static (Guyan) reduction to an a-set",
    "OMIT": "static (Guyan) reduction (omitted DOF)",
    "OMIT1": "static (Guyan) reduction (omitted DOF)",
    "BSET": "component modes with a fixed boundary set",
    "BSET1": "component modes with a fixed boundary set",
    "CSET": "component modes with a free boundary set",
    "CSET1": "component modes with a free boundary set",
    "QSET": "component mode synthesis (generalised coordinates)",
    "QSET1": "component mode synthesis (generalised coordinates)",
}
#: Case control commands that change the eigenproblem.
_CASE_REFUSED = {
    "K2GG": "direct matrix input (DMIG) added to K",
    "M2GG": "direct matrix input (DMIG) added to M",
    "EXTSEOUT": "external superelement creation",
}


def check_supported(deck: Deck) -> None:
    """Refuse decks whose SOL 103 answer depends on features femcal does not model, rather than
    silently solving a different problem."""
    found = [f"{c} ({why})" for c, why in REDUCTION_CARDS.items() if c in deck.card_count]
    for _sid, cmds in deck.case.effective():
        found += [f"case control {k} ({why})" for k, why in _CASE_REFUSED.items() if k in cmds]
    found += [
        f"case control {line.split()[0].upper()} ({_CASE_REFUSED['EXTSEOUT']})"
        for line in deck.case.lines
        if line.strip().upper().startswith("EXTSEOUT")
    ]
    if found:
        raise ModelError(
            "the deck uses features that change the SOL 103 answer and are not supported: "
            + "; ".join(sorted(set(found)))
            + " (femcal solves the full model)"
        )


def solve_sol103(
    deck: Deck,
    model: Model,
    *,
    matrices: Matrices | None = None,
    request: EigenRequest | None = None,
    progress: Callable[[str], None] | None = None,
    on_factor: Callable | None = None,
) -> tuple[Modes, Reduction]:
    """Normal modes of a deck's model, as NASTRAN SOL 103 computes them.

    PARAM AUTOSPC (default YES) is honoured; DOF with neither stiffness nor mass are always
    removed. Returns the modes and the constraint reduction used. ``on_factor`` receives the
    factor of the a-set's K - sigma M (see :func:`femcal.solve.eigen.solve_modes`).
    """
    say = progress or (lambda s: None)
    check_supported(deck)
    mats = matrices or assemble(model, Options())
    say(f"assembled K and M: {model.n_dof} DOF, {mats.K.nnz} nonzeros in K")
    red = build_reduction(deck, model)
    K_aa, M_aa = red.reduce(mats.K), red.reduce(mats.M)
    auto = _autospc_enabled(deck, model)
    red = autospc(model, red, K_aa, M_aa, enabled=auto)
    if len(red.autospc):
        K_aa, M_aa = red.reduce(mats.K), red.reduce(mats.M)
    req = request or eigen_request(deck)
    say(f"a-set {len(red.a_dofs)} DOF; solving for modes")
    res: EigenResult = solve_modes(K_aa, M_aa, req, progress=progress, on_factor=on_factor)
    shapes = red.expand(res.vectors)
    node = np.searchsorted(model.dof_start, red.autospc, side="right") - 1
    comp = red.autospc - model.dof_start[node] + np.where(model.is_grid[node], 1, 0)
    modes = Modes(
        res.eigenvalues, res.generalized_mass, res.generalized_stiffness, np.asarray(shapes),
        model.node_ids, model.dof_start, model.is_grid,
        np.column_stack([model.node_ids[node], comp]), len(red.a_dofs), res.backend,
    )  # fmt: skip
    return modes, red
