"""Value checks of the cards a model is built from: the ranges the Quick Reference Guide sets
for ids, material constants, section properties and eigenvalue requests, so that a value no
structure can have is an error naming card, id, field and file:line instead of modes that
are silently wrong (a negative density gives a few modes and no word)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..deck.deck import Deck
from ..deck.spec import Table
from ..markers import INT_BLANK

#: NASTRAN's id range (8 digits in a small field).
MAX_ID = 99_999_999


@dataclass(frozen=True)
class RangeCheck:
    """One field's allowed values: ``ok(values)`` -> (n,) True where allowed (blank values
    arrive as NaN / ``INT_BLANK`` and are the layout's business, so ``ok`` lets them
    pass); ``expected`` says what is allowed."""

    card: str
    field: str
    ok: Callable[[np.ndarray], np.ndarray]
    expected: str


def _blank(v: np.ndarray) -> np.ndarray:
    return np.isnan(v) if v.dtype.kind == "f" else v == INT_BLANK


def _at_least(lo: float) -> Callable[[np.ndarray], np.ndarray]:
    return lambda v: _blank(v) | (v >= lo)


def _above(lo: float) -> Callable[[np.ndarray], np.ndarray]:
    return lambda v: _blank(v) | (v > lo)


def _poisson(v: np.ndarray) -> np.ndarray:
    return _blank(v) | ((v > -1.0) & (v <= 0.5))


def _finite(v: np.ndarray) -> np.ndarray:
    return _blank(v) | np.isfinite(v)


_NON_NEGATIVE = "a real >= 0"
RANGE_CHECKS: tuple[RangeCheck, ...] = (
    RangeCheck("MAT1", "e", _at_least(0.0), _NON_NEGATIVE),
    RangeCheck("MAT1", "g", _at_least(0.0), _NON_NEGATIVE),
    RangeCheck("MAT1", "nu", _poisson, "a Poisson's ratio in (-1, 0.5]"),
    RangeCheck("MAT1", "rho", _at_least(0.0), _NON_NEGATIVE + " (a mass density)"),
    RangeCheck("MAT2", "rho", _at_least(0.0), _NON_NEGATIVE + " (a mass density)"),
    RangeCheck("MAT8", "e1", lambda v: _blank(v) | (v != 0), "a real other than 0"),
    RangeCheck("MAT8", "e2", lambda v: _blank(v) | (v != 0), "a real other than 0"),
    RangeCheck("MAT8", "rho", _at_least(0.0), _NON_NEGATIVE + " (a mass density)"),
    RangeCheck("MAT9", "rho", _at_least(0.0), _NON_NEGATIVE + " (a mass density)"),
    RangeCheck("PSHELL", "t", _at_least(0.0), _NON_NEGATIVE + " (a thickness)"),
    RangeCheck("PSHEAR", "t", _above(0.0), "a real > 0 (a thickness)"),
    RangeCheck("PROD", "a", _at_least(0.0), _NON_NEGATIVE + " (an area)"),
    RangeCheck("PTUBE", "od", _above(0.0), "a real > 0 (a diameter)"),
    RangeCheck("PBAR", "a", _at_least(0.0), _NON_NEGATIVE + " (an area)"),
    RangeCheck("PBAR", "i1", _at_least(0.0), _NON_NEGATIVE + " (an area moment)"),
    RangeCheck("PBAR", "i2", _at_least(0.0), _NON_NEGATIVE + " (an area moment)"),
    RangeCheck("PBAR", "j", _at_least(0.0), _NON_NEGATIVE + " (a torsion constant)"),
    RangeCheck("CONROD", "a", _at_least(0.0), _NON_NEGATIVE + " (an area)"),
    RangeCheck("EIGR", "nd", _above(0), "an integer > 0 or blank"),
)

#: The layouts' first fields that are the card's own id (NASTRAN: 1 to 99999999).
_ID_FIELDS = ("id", "eid", "pid", "mid", "sid", "cid")


def check_values(deck: Deck, add: Callable[[str, list[int], list[tuple[int, int]]], None],
                 limit: int = 20) -> None:  # fmt: skip
    """Report (through ``add(message, ids, [(file, line)])``) every card whose id is out of
    NASTRAN's range, every field outside :data:`RANGE_CHECKS`, any real that overflowed to
    infinity, and every EIGR whose F1 is not below F2; at most ``limit`` per card and
    field."""
    for name, t in deck.tables.items():
        _check_ids(name, t, add, limit)
        for col, v in t.columns.items():
            if v.dtype.kind == "f":
                _report(name, t, col, ~_finite(v), "a finite real", add, limit)
    for rc in RANGE_CHECKS:
        t = deck.tables.get(rc.card)
        if t is None or rc.field not in t.columns:
            continue
        v = t.columns[rc.field]
        _report(rc.card, t, rc.field, ~rc.ok(v), rc.expected, add, limit)
    t = deck.tables.get("MAT1")
    if t is not None:
        _check_derived_poisson(t, add, limit)
    t = deck.tables.get("EIGR")
    if t is not None:
        f1, f2 = t.columns["f1"], t.columns["f2"]
        bad = ~np.isnan(f1) & ~np.isnan(f2) & (f1 >= f2)
        _report("EIGR", t, "f2", bad, "F2 above F1", add, limit)


def _check_derived_poisson(t: Table, add, limit: int) -> None:
    """MAT1 with E and G and no NU: NU = E / (2 G) - 1 must be a number (G = 0 gives an
    infinite one, and NaN stiffness in the shells and solids that use it). A finite NU
    outside (-1, 0.5] is left alone: rods, bars and beams use E and G as given, and stick
    models set them apart on purpose."""
    E, G, nu = t.columns["e"], t.columns["g"], t.columns["nu"]
    both = ~np.isnan(E) & ~np.isnan(G) & np.isnan(nu)
    with np.errstate(divide="ignore", invalid="ignore"):
        derived = np.where(both, E / (2.0 * G) - 1.0, 0.0)
    rows = np.flatnonzero(both & ~np.isfinite(derived))
    for i in rows[:limit]:
        add(f"MAT1 {int(t.columns['mid'][i])}: E = {E[i]:g} and G = {G[i]:g} without NU give "
            f"NU = E / (2 G) - 1 = {derived[i]:g}; expected G other than 0, or NU",
            [int(t.columns["mid"][i])], [(int(t.file[i]), int(t.line[i]))])  # fmt: skip


def _check_ids(name: str, t: Table, add, limit: int) -> None:
    first = next(iter(t.columns), None)
    if first not in _ID_FIELDS:
        return
    v = t.columns[first]
    bad = (v != INT_BLANK) & ((v < 1) | (v > MAX_ID))
    _report(name, t, first, bad, f"an id from 1 to {MAX_ID}", add, limit)


def _show(v: np.generic) -> str:
    return f"{float(v):g}" if isinstance(v, np.floating) else str(int(v))


def _report(card: str, t: Table, col: str, bad: np.ndarray, expected: str, add,
            limit: int) -> None:  # fmt: skip
    rows = np.flatnonzero(bad)
    if not len(rows):
        return
    key = next(iter(t.columns))
    for i in rows[:limit]:
        ident = int(t.columns[key][i])
        add(f"{card} {ident} field {col.upper()} = {_show(t.columns[col][i])}: expected "
            f"{expected}",
            [ident], [(int(t.file[i]), int(t.line[i]))])  # fmt: skip
    if len(rows) > limit:
        add(f"{card}: {len(rows) - limit} more with {col.upper()} outside {expected}", [], [])
