"""Value checks of the cards a model is built from: the ranges the Quick Reference Guide sets
for ids, material constants, section properties and eigenvalue requests, so that a value no
structure can have is an error naming card, id, field and file:line instead of modes that
are silently wrong (a negative density gives a few modes and no word).

Each check cites the Guide's range. Where the Guide allows a value femcal cannot solve (a
negative density, area or thickness, which the Guide gives as any real), the check refuses
it and its message says that the limit is femcal's, not the Guide's."""

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
    pass); ``expected`` says what is allowed; ``name`` is the field's name in the Quick
    Reference Guide where it differs from the column's."""

    card: str
    field: str
    ok: Callable[[np.ndarray], np.ndarray]
    expected: str
    name: str = ""


def _blank(v: np.ndarray) -> np.ndarray:
    return np.isnan(v) if v.dtype.kind == "f" else v == INT_BLANK


def _at_least(lo: float) -> Callable[[np.ndarray], np.ndarray]:
    return lambda v: _blank(v) | (v >= lo)


def _above(lo: float) -> Callable[[np.ndarray], np.ndarray]:
    return lambda v: _blank(v) | (v > lo)


def _one_of(*allowed: object) -> Callable[[np.ndarray], np.ndarray]:
    return lambda v: _blank(v) | np.isin(v, list(allowed))


def _poisson(v: np.ndarray) -> np.ndarray:
    return _blank(v) | ((v > -1.0) & (v <= 0.5))


def _finite(v: np.ndarray) -> np.ndarray:
    return _blank(v) | np.isfinite(v)


_NON_NEGATIVE = "a real >= 0"
#: What femcal cannot solve where the Guide states no range: a negative mass or stiffness
#: (the eigensolution needs K and M positive semi-definite).
_NEGATIVE = "the Guide allows any real, but femcal does not solve the negative {} of a negative one"
_DENSITY = f"{_NON_NEGATIVE} (a mass density; {_NEGATIVE.format('mass')})"
_AREA = f"{_NON_NEGATIVE} (an area; {_NEGATIVE.format('stiffness and mass')})"
#: The shell connection cards and their thickness fields (QRG CQUAD4 ... CTRIA6: Ti).
SHELL_THICKNESS = {
    "CQUAD4": 4, "CQUADR": 4, "CQUAD8": 4, "CTRIA3": 3, "CTRIAR": 3, "CTRIA6": 3,
}  # fmt: skip
RANGE_CHECKS: tuple[RangeCheck, ...] = (
    # QRG MAT1: E, G >= 0.0 or blank; -1.0 < NU <= 0.5 or blank; RHO real
    RangeCheck("MAT1", "e", _at_least(0.0), _NON_NEGATIVE),
    RangeCheck("MAT1", "g", _at_least(0.0), _NON_NEGATIVE),
    RangeCheck("MAT1", "nu", _poisson, "a Poisson's ratio in (-1, 0.5]"),
    RangeCheck("MAT1", "rho", _at_least(0.0), _DENSITY),
    # QRG MAT2, MAT8, MAT9: RHO real; MAT8: E1, E2 other than 0.0
    RangeCheck("MAT2", "rho", _at_least(0.0), _DENSITY),
    RangeCheck("MAT8", "e1", lambda v: _blank(v) | (v != 0), "a real other than 0"),
    RangeCheck("MAT8", "e2", lambda v: _blank(v) | (v != 0), "a real other than 0"),
    RangeCheck("MAT8", "rho", _at_least(0.0), _DENSITY),
    RangeCheck("MAT9", "rho", _at_least(0.0), _DENSITY),
    # QRG PSHELL: T real or blank (12I/T**3 and TS/T: in _check_field_pairs)
    RangeCheck("PSHELL", "t", _at_least(0.0), f"{_NON_NEGATIVE} (a thickness; "
               f"{_NEGATIVE.format('stiffness and mass')})"),
    # QRG PSHEAR: T other than 0.0; F1, F2 >= 0.0 (default 0.0)
    RangeCheck("PSHEAR", "t", _above(0.0), "a real > 0 (a thickness; the Guide refuses 0, and "
               "femcal does not solve the negative stiffness and mass of a negative one)"),
    RangeCheck("PSHEAR", "f1", _at_least(0.0), _NON_NEGATIVE),
    RangeCheck("PSHEAR", "f2", _at_least(0.0), _NON_NEGATIVE),
    # QRG PROD, CONROD: A real; QRG PTUBE: OD > 0.0
    RangeCheck("PROD", "a", _at_least(0.0), _AREA),
    RangeCheck("CONROD", "a", _at_least(0.0), _AREA),
    RangeCheck("PTUBE", "od", _above(0.0), "a real > 0 (a diameter)"),
    # QRG PBAR: A real (default 0.0); I1, I2 >= 0.0 (default 0.0); J real (default 0.0)
    RangeCheck("PBAR", "a", _at_least(0.0), _AREA),
    RangeCheck("PBAR", "i1", _at_least(0.0), _NON_NEGATIVE + " (an area moment)"),
    RangeCheck("PBAR", "i2", _at_least(0.0), _NON_NEGATIVE + " (an area moment)"),
    RangeCheck("PBAR", "j", _at_least(0.0), f"{_NON_NEGATIVE} (a torsion constant; "
               f"{_NEGATIVE.format('stiffness')})"),
    # QRG CQUAD4 ... CTRIA6: Ti >= 0.0 or blank (not all zero); TFLAG 0, 1 or blank;
    # MCID >= 0 (blank: THETA)
    *(RangeCheck(card, f"t{i}", _at_least(0.0), f"{_NON_NEGATIVE} (a thickness) or blank")
      for card, k in SHELL_THICKNESS.items() for i in range(1, k + 1)),
    *(RangeCheck(card, "tflag", _one_of(0, 1), "0, 1 or blank") for card in SHELL_THICKNESS),
    *(RangeCheck(card, "mcid", _at_least(0), "a coordinate system id >= 0", "THETA/MCID")
      for card in SHELL_THICKNESS),
    # QRG CBUSH: OCID >= -1 (default -1); S1-S3 place the spring where OCID >= 0
    RangeCheck("CBUSH", "ocid", lambda v: _blank(v) | (v == -1),
               "-1 or blank (femcal does not model the spring offset S1, S2, S3 of an "
               "OCID >= 0)"),
    # QRG EIGR: ND > 0, or 0 (GIV, MGIV, HOU, MHOU: the roots between F1 and F2)
    RangeCheck("EIGR", "nd", _at_least(0), "an integer >= 0 or blank"),
)

#: The layouts' first fields that are the card's own id (NASTRAN: 1 to 99999999).
_ID_FIELDS = ("id", "eid", "pid", "mid", "sid", "cid")


def check_values(deck: Deck, add: Callable[[str, list[int], list[tuple[int, int]]], None],
                 limit: int = 20) -> None:  # fmt: skip
    """Report (through ``add(message, ids, [(file, line)])``) every card whose id is out of
    NASTRAN's range, every field outside :data:`RANGE_CHECKS` or the Guide's ranges that
    tie two fields or a record's repeated fields together, and any real that overflowed to
    infinity; at most ``limit`` per card and field."""
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
        _report(rc.card, t, rc.field, ~rc.ok(v), rc.expected, add, limit, rc.name)
    t = deck.tables.get("MAT1")
    if t is not None:
        _check_derived_poisson(t, add, limit)
    _check_field_pairs(deck, add, limit)
    _check_bush_axes(deck, add, limit)
    _check_records(deck, add, limit)


def _check_field_pairs(deck: Deck, add, limit: int) -> None:
    """The Guide's ranges that tie two fields of a fixed-format card together."""
    t = deck.tables.get("EIGR")
    if t is not None:  # QRG EIGR: F1 < F2
        f1, f2 = t.columns["f1"], t.columns["f2"]
        bad = ~np.isnan(f1) & ~np.isnan(f2) & (f1 >= f2)
        _report("EIGR", t, "f2", bad, "F2 above F1", add, limit)
    t = deck.tables.get("PSHELL")
    if t is not None:
        # QRG PSHELL: 12I/T**3 > 0.0 (default 1.0), TS/T > 0.0 (default .833333); checked
        # where the material they scale is given (MID2, MID3): a value in a field the shell
        # does not use changes nothing, and a membrane-only deck may hold a 0 there
        c = t.columns
        for col, mid, name in (("bk", "mid2", "12I/T**3"), ("tst", "mid3", "TS/T")):
            used = (c[mid] != INT_BLANK) & (c[mid] > 0)
            _report("PSHELL", t, col, used & ~(c[col] > 0), f"a real > 0 (MID{mid[-1]} is "
                    "given)", add, limit, name)  # fmt: skip
    t = deck.tables.get("PBAR")
    if t is not None:  # QRG PBAR: I1*I2 > I12**2, where I12 is given
        c = t.columns
        bad = (c["i12"] != 0) & ~(c["i1"] * c["i2"] > c["i12"] ** 2)
        _report("PBAR", t, "i12", bad & ~np.isnan(c["i12"]), "I1*I2 > I12^2 (I1, I2 and I12 "
                "of an area's moments)", add, limit)  # fmt: skip
        # QRG PBAR remark 5: K1 and K2 must be blank if A = 0.0
        for k in ("k1", "k2"):
            _report("PBAR", t, k, (c["a"] == 0) & ~np.isnan(c[k]), "blank where A is 0 (no "
                    "area, no shear stiffness K*A*G)", add, limit)  # fmt: skip
    t = deck.tables.get("PTUBE")
    if t is not None:  # QRG PTUBE: T <= OD/2 (T = 0 or blank: a solid rod)
        c = t.columns
        _report("PTUBE", t, "t", (c["t"] > c["od"] / 2.0) | (c["t"] < 0), "a thickness from 0 "
                "to OD/2 (0 or blank: a solid rod; the Guide sets no lower bound, but femcal "
                "does not solve the negative area of a negative one)", add, limit)  # fmt: skip
    for card in ("CBAR", "CBEAM", "CBUSH"):  # QRG CBAR, CBEAM: G0 other than GA and GB
        t = deck.tables.get(card)
        if t is not None:
            c = t.columns
            given = (c["g0"] != INT_BLANK) & (c["g0"] != 0)
            same = given & ((c["g0"] == c["ga"]) | (c["g0"] == c["gb"]))
            _report(card, t, "g0", same, "a grid other than GA and GB (the orientation "
                    "vector points from GA to G0)", add, limit, "G0")  # fmt: skip
    for card, k in SHELL_THICKNESS.items():  # QRG CQUAD4 ...: Ti not all zero
        t = deck.tables.get(card)
        if t is None:
            continue
        ti = np.column_stack([t.columns[f"t{i}"] for i in range(1, k + 1)])
        given = ~np.isnan(ti)
        bad = given.any(axis=1) & ~(np.where(given, ti, 1.0) != 0).any(axis=1)
        _report(card, t, "t1", bad, "T1 ... not all zero (blank ones take PSHELL T)", add,
                limit)  # fmt: skip


def _check_bush_axes(deck: Deck, add, limit: int) -> None:
    """QRG CBUSH remark 5: without GO, X1-X3 and CID the element x axis is GA-GB, and only K1,
    K4 (B1, B4) of the PBUSH may be given."""
    t = deck.tables.get("CBUSH")
    if t is None:
        return
    c = t.columns
    bare = (np.isnan(c["x1"]) & np.isnan(c["x2"]) & np.isnan(c["x3"])
            & np.isin(c["g0"], [INT_BLANK, 0]) & (c["cid"] == INT_BLANK))  # fmt: skip
    pbush = {r.pid: r for r in deck.records_of("PBUSH")}
    n = 0
    for i in np.flatnonzero(bare):
        r = pbush.get(int(c["pid"][i]))
        given = [f"{key}{j + 1}" for key, v in (("K", r.k), ("B", r.b)) if r is not None
                 for j in (1, 2, 4, 5) if v[j] != 0]  # fmt: skip
        n += bool(given)
        if given and n <= limit:
            eid = int(c["eid"][i])
            add(f"CBUSH {eid} has neither GO, X1-X3 nor CID, and its PBUSH {r.pid} gives "
                f"{', '.join(given)}: expected an orientation (GO or X1-X3) or a CID (without "
                "them the element x axis is GA-GB, and only K1, K4, B1 and B4 may be given)",
                [eid], [(int(t.file[i]), int(t.line[i]))])  # fmt: skip


class _Capped:
    """``add`` for at most ``limit`` errors of one card, then a count of the others."""

    def __init__(self, add, card: str, limit: int):
        self.add, self.card, self.limit, self.n = add, card, limit, 0

    def __call__(self, ident: int, field: str, value: float, expected: str,
                 at: tuple[int, int]) -> None:  # fmt: skip
        self.n += 1
        if self.n <= self.limit:
            self.add(f"{self.card} {ident} field {field} = {value:.15g}: expected {expected}",
                     [ident], [at])  # fmt: skip

    def close(self) -> None:
        if self.n > self.limit:
            self.add(f"{self.card}: {self.n - self.limit} more values outside the Guide's "
                     "ranges", [], [])  # fmt: skip


def _check_records(deck: Deck, add, limit: int) -> None:
    """The Guide's ranges of the variable-format property cards' values."""
    moment = f"{_NON_NEGATIVE} (an area moment; 0: no stiffness in that plane)"
    rl = deck.records_of("PBEAM")
    error = _Capped(add, "PBEAM", limit)
    for r, f, ln in zip(rl.items, rl.file, rl.line, strict=True):
        for k, s in enumerate(r.stations):
            # QRG PBEAM: at end A, A > 0.0, I1, I2 > 0.0 (taken as PBAR's >= 0.0: no
            # stiffness in that plane), J >= 0.0; at the stations A, I1, I2, J real (a
            # negative one is a negative stiffness femcal does not solve); I1*I2 > I12**2
            # where I12 is given; 0.0 < X/XB <= 1.0
            at = "(A)" if k == 0 else f" at X/XB = {s.x:g}"
            area = "a real > 0 (an area)" if k == 0 else _AREA
            for name, value, ok, expected in (
                ("A", s.a, s.a > 0 if k == 0 else s.a >= 0, area),
                ("I1", s.i1, s.i1 >= 0, moment),
                ("I2", s.i2, s.i2 >= 0, moment),
                ("J", s.j, s.j >= 0, f"{_NON_NEGATIVE} (a torsion constant)"),
                ("I12", s.i12, s.i12 == 0 or s.i1 * s.i2 > s.i12**2, "I1*I2 > I12^2"),
            ):
                if not ok:
                    error(r.pid, name + at, value, expected, (f, ln))
            if k and not 0.0 < s.x <= 1.0:
                error(r.pid, "X/XB", s.x, "a real in (0, 1]", (f, ln))
    error.close()
    for card in ("PBARL", "PBEAML"):
        # QRG PBARL, PBEAML: DIMi > 0.0 (GROUP MSCBML0); PBEAML: 0.0 < X(j)/XB <= 1.0
        rl = deck.records_of(card)
        error = _Capped(add, card, limit)
        for r, f, ln in zip(rl.items, rl.file, rl.line, strict=True):
            stations = r.stations if card == "PBEAML" else [r]
            for k, s in enumerate(stations):
                at = "" if card == "PBARL" else "(A)" if k == 0 else f"({k})"
                for i, d in enumerate(s.dims):
                    if not d > 0:
                        error(r.pid, f"DIM{i + 1}{at}", d,
                              f"a real > 0 (a dimension of the {r.type} section)", (f, ln))
                if k and not 0.0 < s.x <= 1.0:
                    error(r.pid, f"X({k})/XB", s.x, "a real in (0, 1]", (f, ln))
        error.close()


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
    """A value as the deck may have written it (enough digits to tell 0.5000001 from 0.5)."""
    return f"{float(v):.15g}" if isinstance(v, np.floating) else str(int(v))


def _report(card: str, t: Table, col: str, bad: np.ndarray, expected: str, add,
            limit: int, name: str = "") -> None:  # fmt: skip
    rows = np.flatnonzero(bad)
    if not len(rows):
        return
    key = next(iter(t.columns))
    name = name or col.upper()
    for i in rows[:limit]:
        ident = int(t.columns[key][i])
        add(f"{card} {ident} field {name} = {_show(t.columns[col][i])}: expected {expected}",
            [ident], [(int(t.file[i]), int(t.line[i]))])  # fmt: skip
    if len(rows) > limit:
        add(f"{card}: {len(rows) - limit} more with {name} outside {expected}", [], [])


def check_solid_poisson(deck: Deck, add, used: set[int], limit: int = 20) -> None:
    """MAT1 of NU = 0.5 (given, or from E and G) under a PSOLID that elements use: the Guide
    allows it (-1.0 < NU <= 0.5), femcal's solids cannot take it (their Lame constant
    E NU / ((1 + NU) (1 - 2 NU)) is infinite), so it is refused as femcal's limitation."""
    solids, mat1 = deck.tables.get("PSOLID"), deck.tables.get("MAT1")
    if solids is None or mat1 is None:
        return
    m = mat1.columns
    E, G, nu = m["e"], m["g"], m["nu"]
    with np.errstate(divide="ignore", invalid="ignore"):
        nu = np.where(np.isnan(nu) & ~np.isnan(E) & ~np.isnan(G), E / (2.0 * G) - 1.0, nu)
    pids = solids.columns["pid"]
    mids = {int(x) for x, p in zip(solids.columns["mid"], pids, strict=True) if int(p) in used}
    rows = np.flatnonzero(np.isin(m["mid"], list(mids)) & (nu == 0.5))
    for i in rows[:limit]:
        mid = int(m["mid"][i])
        add(f"MAT1 {mid} field NU = 0.5 (incompressible), used by solids (PSOLID): expected NU "
            "below 0.5; femcal's solid elements cannot take an incompressible material (the "
            "Guide allows NU up to 0.5)", [mid], [(int(mat1.file[i]), int(mat1.line[i]))])
