"""Deck -> what the analysis is asked: :class:`~femcal.model.analysis.Params` from PARAM cards
and case control AUTOSPC, the :class:`~femcal.model.analysis.EigenSetup` from EIGRL, EIGR and
case control METHOD, and the deck's features that femcal does not model."""

from __future__ import annotations

import warnings

import numpy as np

from ..deck.deck import Deck
from ..errors import FemcalWarning
from ..markers import INT_BLANK
from .analysis import EigenRequest, EigenSetup, Params

#: Cards that make NASTRAN solve a reduced or different problem femcal does not solve.
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
CASE_REFUSED = {
    "K2GG": "direct matrix input (DMIG) added to K",
    "M2GG": "direct matrix input (DMIG) added to M",
    "EXTSEOUT": "external superelement creation",
}


def _warn_given_normals(deck: Deck) -> None:
    """SNORM bulk cards set a grid's normal in NASTRAN; femcal makes its own from the shells
    (PARAM SNORM), so it says so rather than pass them by."""
    at = [i for i, c in enumerate(deck.unused.items) if c.name == "SNORM"]
    if at:
        where = deck.where(deck.unused.file[at[0]], deck.unused.line[at[0]])
        warnings.warn(FemcalWarning(
            f"{where}: SNORM ({len(at)} card{'s' if len(at) > 1 else ''}): grid normals given "
            "are not used; femcal makes its own from the shells (PARAM SNORM), so the CQUAD4 "
            "/ CTRIA3 drilling rotation at those grids may differ from NASTRAN's"),
            stacklevel=3)  # fmt: skip


def params_of(deck: Deck) -> Params:
    """The PARAMs femcal honours (NASTRAN's defaults where the deck gives none or a value
    that is not a number) and every PARAM card as read."""
    cards = {r.name: r.values for r in deck.records_of("PARAM")}

    def number(name: str, default: float) -> float:
        v = cards.get(name)
        if not v:
            return default
        try:
            return float(v[0])
        except (TypeError, ValueError):
            return default

    case = deck.case.value("AUTOSPC")  # case control wins over the PARAM
    if case is not None:
        autospc = not case.strip().upper().startswith("NO")
    else:
        autospc = str(cards.get("AUTOSPC", ("YES",))[0]).upper() != "NO"
    _warn_given_normals(deck)
    g = cards.get("GRDPNT")
    grdpnt = int(g[0]) if g and isinstance(g[0], int) and g[0] >= 0 else None
    return Params(coupled_mass=number("COUPMASS", -1.0) > 0, wtmass=number("WTMASS", 1.0),
                  k6rot=number("K6ROT", 100.0), snorm=number("SNORM", 20.0), autospc=autospc,
                  grdpnt=grdpnt, cards=cards)  # fmt: skip


def _hz(v: float) -> float | None:
    return None if v is None or np.isnan(v) else float(v)


def eigen_of(deck: Deck) -> EigenSetup:
    """Every EIGRL and EIGR set (an EIGRL wins over an EIGR of the same SID, the first card
    over later ones) and case control METHOD."""
    sets: dict[int, EigenRequest] = {}
    for r in deck.records_of("EIGRL"):
        nd = None if r.nd == INT_BLANK else r.nd
        sets.setdefault(int(r.sid), EigenRequest(_hz(r.v1), _hz(r.v2), nd, r.norm))
    t = deck.tables.get("EIGR")
    if t is not None:
        c = t.columns
        for i in range(len(t)):
            # QRG EIGR: ND of 0 (GIV, MGIV, HOU, MHOU) asks for the roots between F1 and F2
            nd = int(c["nd"][i]) if c["nd"][i] not in (INT_BLANK, 0) else None
            f2 = _hz(c["f2"][i])
            if nd is None and f2 is None:
                nd = 10**9  # all roots (Givens/Householder)
            sets.setdefault(int(c["sid"][i]),
                            EigenRequest(_hz(c["f1"][i]), f2, nd, str(c["norm"][i] or "MASS")))
    loc = deck.case.location("METHOD")
    return EigenSetup(sets, deck.case.value("METHOD"), deck.where(*loc) if loc else "")


def unsupported_of(deck: Deck) -> tuple[str, ...]:
    """The deck's features that change the SOL 103 answer and that femcal does not model,
    each named with what it does (sorted)."""
    found = [f"{c} ({why})" for c, why in REDUCTION_CARDS.items() if c in deck.card_count]
    for _sid, cmds in deck.case.effective():
        found += [f"case control {k} ({why})" for k, why in CASE_REFUSED.items() if k in cmds]
    found += [
        f"case control {line.split()[0].upper()} ({CASE_REFUSED['EXTSEOUT']})"
        for line in deck.case.lines
        if line.strip().upper().startswith("EXTSEOUT")
    ]
    return tuple(sorted(set(found)))
