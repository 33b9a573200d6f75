"""Cards whose layout varies (lists, repeated groups, keywords): one record each.

Each record class has ``parse(fields, errors) -> record`` (a classmethod) and
``to_fields() -> list`` (data fields for writing, None for blank, 8 per line). Field indices
are 0-based data-field positions: index k is NASTRAN field ``k % 8 + 2`` of line ``k // 8``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from ..markers import INT_BLANK, REAL_BLANK
from .fields import (
    INT_LIMIT,
    BadField,
    is_int_text,
    parse_components,
    parse_int,
    parse_number,
    parse_real,
    parse_string,
)

ErrorList = list[tuple[int, str, str]]

#: The most ids one card's THRU ranges may list (``1 THRU 99999999`` would be a list of 1e8).
MAX_LISTED_IDS = 10_000_000


class Cursor:
    """Typed access to a card's data fields; problems go to ``errors``, defaults come back."""

    def __init__(self, fields: list[str], errors: ErrorList):
        self.f = fields
        self.errors = errors
        self.n = len(fields)

    def text(self, k: int) -> str:
        return self.f[k] if k < self.n else ""

    def _read(self, k: int, fn, default, required: bool, what: str):
        s = self.text(k)
        if not s:
            if required:
                self.errors.append((k, s, f"{what} in a required field"))
            return default
        try:
            return fn(s)
        except BadField as e:
            self.errors.append((k, s, e.expected))
            return default

    def int(self, k: int, default: int = INT_BLANK, required: bool = False) -> int:
        return self._read(k, parse_int, default, required, "an integer")

    def real(self, k: int, default: float = REAL_BLANK, required: bool = False) -> float:
        return self._read(k, parse_real, default, required, "a real")

    def number(self, k: int, default: float = REAL_BLANK, required: bool = False) -> float:
        return float(self._read(k, parse_number, default, required, "a number"))

    def comp(self, k: int, default: int = INT_BLANK, required: bool = False) -> int:
        return self._read(k, parse_components, default, required, "a component code")

    def word(self, k: int, default: str = "", required: bool = False) -> str:
        return self._read(k, parse_string, default, required, "a word")

    def blank(self, k: int) -> None:
        s = self.text(k)
        if s:
            self.errors.append((k, s, "a blank field"))

    def ids_from(self, k: int, stop: int | None = None) -> tuple[int, list[int]]:
        """Integers from field k on, with ``A THRU B`` ranges and blanks skipped.

        Stops at ``stop`` or at the first field that is not an integer or THRU; returns
        (index where it stopped, ids). An integer beyond 64 bits, or ranges of more than
        MAX_LISTED_IDS ids on one card, are errors.
        """
        end = self.n if stop is None else min(stop, self.n)
        out: list[int] = []
        while k < end:
            s = self.f[k]
            if not s:
                k += 1
                continue
            if s == "THRU":
                if not out or k + 1 >= end or not is_int_text(self.f[k + 1]):
                    self.errors.append((k, s, "THRU between two integers"))
                    return end, out
                a, b = out[-1], int(self.f[k + 1])
                if b < a:
                    self.errors.append((k + 1, self.f[k + 1], f"an id >= {a} after THRU"))
                    return end, out
                if len(out) + (b - a) > MAX_LISTED_IDS:
                    self.errors.append((k + 1, self.f[k + 1], f"a THRU range that, with the "
                                        f"card's other ids, lists at most {MAX_LISTED_IDS}"))
                    return end, out
                out.extend(range(a + 1, b + 1))
                k += 2
                continue
            if not is_int_text(s):
                return k, out
            v = int(s)
            if not -INT_LIMIT < v < INT_LIMIT:
                self.errors.append((k, s, f"an integer of magnitude below 2^63 ({INT_LIMIT})"))
                return end, out
            out.append(v)
            k += 1
        return k, out


def _real_or_none(x: float) -> float | None:
    return None if x != x else x


def _int_or_none(i: int) -> int | None:
    return None if i == INT_BLANK else i


def _pad_to_row(out: list) -> None:
    while len(out) % 8:
        out.append(None)


# ----------------------------------------------------------------------- id lists


@dataclass(frozen=True)
class SpointCard:
    """SPOINT ID1 ID2 ... (or ID1 THRU ID2)."""

    ids: tuple[int, ...]

    @classmethod
    def parse(cls, f: list[str], errors: ErrorList) -> SpointCard:
        c = Cursor(f, errors)
        k, ids = c.ids_from(0)
        if k < c.n:
            errors.append((k, c.text(k), "a scalar point id or THRU"))
        if not ids:
            errors.append((0, c.text(0), "at least one scalar point id"))
        return cls(tuple(ids))

    def to_fields(self) -> list:
        return list(self.ids)


@dataclass(frozen=True)
class Spc1Card:
    """SPC1 SID C G1 G2 ... or SID C G1 THRU G2: components C of the grids in set SID.

    ``ids`` are the grids listed one by one (each must exist); ``ranges`` the (G1, G2) of
    the THRU form, kept unexpanded: as in NASTRAN (QRG SPC1), the points of a THRU range
    need not exist, and those that do are the ones constrained.
    """

    sid: int
    components: int
    ids: tuple[int, ...]
    ranges: tuple[tuple[int, int], ...] = ()

    @classmethod
    def parse(cls, f: list[str], errors: ErrorList) -> Spc1Card:
        c = Cursor(f, errors)
        sid = c.int(0, required=True)
        # QRG SPC1: C 1-6 for grid points, 0, 1 or blank for scalar points (the model
        # refuses a 0 or blank C at a grid)
        comp = c.comp(1, 0)
        ranges = []
        body = f[2:]
        if len([x for x in body if x]) == 3 and body[1:2] == ["THRU"] and all(
                is_int_text(x) for x in (body[0], body[2])):  # fmt: skip
            a, b = int(body[0]), int(body[2])
            if not (0 < a <= b < INT_LIMIT):
                errors.append((4, body[2], f"G2 >= G1 = {a}, G1 > 0"))
            ranges.append((a, b))
            return cls(sid, comp, (), tuple(ranges))
        k, ids = c.ids_from(2)
        if k < c.n:
            errors.append((k, c.text(k), "a grid id or THRU"))
        if not ids:
            errors.append((2, c.text(2), "at least one grid id"))
        return cls(sid, comp, tuple(ids))

    def to_fields(self) -> list:
        out: list = [self.sid, self.components, *self.ids]
        for a, b in self.ranges:
            out += [a, "THRU", b]
        return out


@dataclass(frozen=True)
class Aset1Card:
    """ASET1 C G1 G2 ... (or G1 THRU G2)."""

    components: int
    ids: tuple[int, ...]

    @classmethod
    def parse(cls, f: list[str], errors: ErrorList) -> Aset1Card:
        c = Cursor(f, errors)
        comp = c.comp(0, required=True)
        k, ids = c.ids_from(1)
        if k < c.n:
            errors.append((k, c.text(k), "a grid id or THRU"))
        if not ids:
            errors.append((1, c.text(1), "at least one grid id"))
        return cls(comp, tuple(ids))

    def to_fields(self) -> list:
        return [self.components, *self.ids]


@dataclass(frozen=True)
class SetUnionCard:
    """SPCADD / MPCADD SID S1 S2 ...: set SID is the union of sets S1, S2, ..."""

    sid: int
    sets: tuple[int, ...]

    @classmethod
    def parse(cls, f: list[str], errors: ErrorList) -> SetUnionCard:
        c = Cursor(f, errors)
        sid = c.int(0, required=True)
        k, sets = c.ids_from(1)
        if k < c.n:
            errors.append((k, c.text(k), "a set id"))
        if not sets:
            errors.append((1, c.text(1), "at least one set id"))
        return cls(sid, tuple(sets))

    def to_fields(self) -> list:
        return [self.sid, *self.sets]


# ----------------------------------------------------------------------- rigid, MPC


@dataclass(frozen=True)
class Rbe2Card:
    """RBE2 EID GN CM GM1 GM2 ... [ALPHA [TREF]]: grids GMi follow GN rigidly in CM."""

    eid: int
    gn: int
    cm: int
    gm: tuple[int, ...]
    alpha: float = 0.0
    tref: float = 0.0

    @classmethod
    def parse(cls, f: list[str], errors: ErrorList) -> Rbe2Card:
        c = Cursor(f, errors)
        eid = c.int(0, required=True)
        gn = c.int(1, required=True)
        cm = c.comp(2, required=True)
        if cm == 0:  # QRG RBE2: CM integers 1 through 6
            errors.append((2, c.text(2), "component numbers of digits 1-6 (the dependent "
                           "DOF)"))  # fmt: skip
        k, gm = c.ids_from(3)
        alpha = tref = 0.0
        if k < c.n:
            alpha = c.real(k, 0.0)
            tref = c.real(k + 1, 0.0)
            for j in range(k + 2, c.n):
                if c.text(j):
                    errors.append((j, c.text(j), "nothing after TREF"))
        if not gm:
            errors.append((3, c.text(3), "at least one dependent grid GM1"))
        return cls(eid, gn, cm, tuple(gm), alpha, tref)

    def to_fields(self) -> list:
        out: list = [self.eid, self.gn, self.cm, *self.gm]
        if self.alpha or self.tref:
            out.append(self.alpha)
            if self.tref:
                out.append(self.tref)
        return out


@dataclass(frozen=True)
class Rbe3Group:
    """One weighted group of RBE3 independent grids."""

    weight: float
    components: int
    grids: tuple[int, ...]


@dataclass(frozen=True)
class Rbe3Card:
    """RBE3 EID _ REFGRID REFC WT1 C1 G1,1 ... [UM GM1 CM1 ...] [ALPHA a [TREF t]]."""

    eid: int
    refgrid: int
    refc: int
    groups: tuple[Rbe3Group, ...]
    um: tuple[tuple[int, int], ...] = ()
    alpha: float = 0.0
    tref: float = 0.0

    @classmethod
    def parse(cls, f: list[str], errors: ErrorList) -> Rbe3Card:
        c = Cursor(f, errors)
        eid = c.int(0, required=True)
        c.blank(1)
        refgrid = c.int(2, required=True)
        refc = c.comp(3, required=True)
        groups: list[Rbe3Group] = []
        k = 4
        keywords = ("UM", "ALPHA", "TREF")
        while k < c.n and c.text(k) not in keywords:
            if not c.text(k):
                k += 1
                continue
            wt = c.real(k, required=True)
            comp = c.comp(k + 1, required=True)
            k, grids = c.ids_from(k + 2)
            # The grid list ends at the next weight (a real) or a keyword.
            if not grids:
                errors.append((k, c.text(k), "at least one independent grid after the weight"))
                break
            groups.append(Rbe3Group(wt, comp, tuple(grids)))
        um: list[tuple[int, int]] = []
        alpha = tref = 0.0
        while k < c.n:
            key = c.text(k)
            if key == "UM":
                k += 1
                while k < c.n and c.text(k) not in keywords:
                    if not c.text(k):
                        k += 1
                        continue
                    um.append((c.int(k, required=True), c.comp(k + 1, required=True)))
                    k += 2
            elif key == "ALPHA":
                alpha = c.real(k + 1, required=True)
                k += 2
            elif key == "TREF":
                tref = c.real(k + 1, required=True)
                k += 2
            elif not key:
                k += 1
            else:
                errors.append((k, key, "UM, ALPHA or TREF"))
                break
        if not groups:
            errors.append((4, c.text(4), "at least one weight, component and grid group"))
        return cls(eid, refgrid, refc, tuple(groups), tuple(um), alpha, tref)

    def to_fields(self) -> list:
        out: list = [self.eid, None, self.refgrid, self.refc]
        for g in self.groups:
            out += [g.weight, g.components, *g.grids]
        if self.um:
            _pad_to_row(out)
            out += [None, "UM"]
            for i, (g, cm) in enumerate(self.um):
                if i and i % 3 == 0:
                    out += [None, None]  # each UM line holds 3 pairs after a blank field
                out += [g, cm]
        if self.alpha or self.tref:
            _pad_to_row(out)
            out += [None, "ALPHA", self.alpha]
            if self.tref:
                out += ["TREF", self.tref]
        return out


@dataclass(frozen=True)
class MpcCard:
    """MPC SID G1 C1 A1 G2 C2 A2 / _ G3 C3 A3 G4 C4 A4 ...: sum A_i u(G_i, C_i) = 0."""

    sid: int
    terms: tuple[tuple[int, int, float], ...]

    @classmethod
    def parse(cls, f: list[str], errors: ErrorList) -> MpcCard:
        c = Cursor(f, errors)
        sid = c.int(0, required=True)
        terms: list[tuple[int, int, float]] = []
        nrows = (c.n + 7) // 8
        for r in range(nrows):
            base = 8 * r
            if r:
                c.blank(base)
            c.blank(base + 7)
            for start in (base + 1, base + 4):
                if not any(c.text(start + j) for j in range(3)):
                    continue
                g = c.int(start, required=True)
                comp = c.comp(start + 1, default=0)
                if comp > 6:
                    errors.append((start + 1, c.text(start + 1), "a single component 0-6"))
                # QRG MPC: Aj real, default 0.0, except A1 must be nonzero
                first = not terms
                a = c.real(start + 2, REAL_BLANK if first else 0.0, required=first)
                if first and a == 0.0:
                    errors.append((start + 2, c.text(start + 2), "a coefficient A1 other than "
                                   "0 (the dependent DOF's)"))  # fmt: skip
                terms.append((g, comp, a))
        if not terms:
            errors.append((1, c.text(1), "at least one term G C A"))
        return cls(sid, tuple(terms))

    def to_fields(self) -> list:
        out: list = [self.sid]
        for i, (g, comp, a) in enumerate(self.terms):
            if i >= 2 and i % 2 == 0:
                out += [None, None]  # field 9 of this line, field 2 of the next
            out += [g, comp, a]
        return out


# ----------------------------------------------------------------------- properties


@dataclass(frozen=True)
class Ply:
    """One PCOMP/PCOMPG ply: material, thickness, orientation (deg), stress output, ply id."""

    mid: int
    t: float
    theta: float
    sout: str
    gplyid: int = INT_BLANK


@dataclass(frozen=True)
class PcompCard:
    """PCOMP PID Z0 NSM SB FT TREF GE LAM / MID1 T1 THETA1 SOUT1 ... (blank MID, T: as before)."""

    pid: int
    z0: float
    nsm: float
    sb: float
    ft: str
    tref: float
    ge: float
    lam: str
    plies: tuple[Ply, ...]
    global_ids: bool = False  # PCOMPG

    @classmethod
    def parse(cls, f: list[str], errors: ErrorList, global_ids: bool = False) -> PcompCard:
        c = Cursor(f, errors)
        pid = c.int(0, required=True)
        z0 = c.real(1)
        nsm = c.real(2, 0.0)
        sb = c.real(3)
        ft = c.word(4)
        if ft not in ("", "HILL", "HOFF", "TSAI", "STRN", "STRS", "TS"):
            errors.append((4, ft, "HILL, HOFF, TSAI, STRN or blank"))
        tref = c.real(5, 0.0)
        ge = c.real(6, 0.0)
        lam = c.word(7)
        if lam not in ("", "SYM", "MEM", "BEND", "SMEAR", "SMCORE"):
            errors.append((7, lam, "SYM, MEM, BEND, SMEAR, SMCORE or blank"))
        plies: list[Ply] = []
        step = 8 if global_ids else 4
        k = 8
        mid, t = INT_BLANK, REAL_BLANK
        while k < c.n:
            if not any(c.text(k + j) for j in range(step)):
                k += step
                continue
            if global_ids:
                gply = c.int(k, required=True)
                k0 = k + 1
                for j in range(k + 5, k + 8):
                    c.blank(j)
            else:
                gply, k0 = INT_BLANK, k
            mid = c.int(k0, mid)
            t = c.real(k0 + 1, t)
            if mid == INT_BLANK:
                errors.append(
                    (k0, c.text(k0), "a material id (blank only after a ply that has one)")
                )
            if t != t:
                errors.append(
                    (k0 + 1, c.text(k0 + 1), "a thickness (blank only after a ply that has one)")
                )
            elif not t >= 0:  # QRG PCOMP: Ti real (0: a ply of no stiffness or mass)
                errors.append((k0 + 1, c.text(k0 + 1), "a ply thickness >= 0 (the Guide allows "
                               "any real, but femcal does not solve the negative stiffness and "
                               "mass of a negative one)"))
            theta = c.real(k0 + 2, 0.0)
            sout = c.word(k0 + 3, "NO")
            if sout not in ("YES", "NO"):
                errors.append((k0 + 3, sout, "YES or NO"))
            plies.append(Ply(mid, t, theta, sout, gply))
            k += step
        if not plies:
            errors.append((8, c.text(8), "at least one ply"))
        return cls(pid, z0, nsm, sb, ft, tref, ge, lam, tuple(plies), global_ids)

    def to_fields(self) -> list:
        out: list = [
            self.pid,
            _real_or_none(self.z0),
            self.nsm,
            _real_or_none(self.sb),
            self.ft or None,
            self.tref,
            self.ge,
            self.lam or None,
        ]
        for p in self.plies:
            if self.global_ids:
                out += [p.gplyid, p.mid, p.t, p.theta, p.sout, None, None, None]
            else:
                out += [p.mid, p.t, p.theta, p.sout]
        return out


#: Number of dimensions of each PBARL/PBEAML section type (MSC/NX section library).
SECTION_DIMS: dict[str, int] = {
    "ROD": 1, "TUBE": 2, "TUBE2": 2, "I": 6, "CHAN": 4, "T": 4, "BOX": 4, "BAR": 2,
    "CROSS": 4, "H": 4, "T1": 4, "I1": 4, "CHAN1": 4, "Z": 4, "CHAN2": 4, "T2": 4,
    "BOX1": 6, "HEXA": 3, "HAT": 4, "HAT1": 5, "DBOX": 10, "L": 4,
}  # fmt: skip


@dataclass(frozen=True)
class PbarlCard:
    """PBARL PID MID GROUP TYPE / DIM1 ... DIMn NSM: bar section from the section library."""

    pid: int
    mid: int
    group: str
    type: str
    dims: tuple[float, ...]
    nsm: float

    @classmethod
    def parse(cls, f: list[str], errors: ErrorList) -> PbarlCard:
        c = Cursor(f, errors)
        pid = c.int(0, required=True)
        mid = c.int(1, required=True)
        group = c.word(2, "MSCBML0")
        typ = c.word(3, required=True)
        for k in range(4, 8):
            c.blank(k)
        ndim = SECTION_DIMS.get(typ)
        if ndim is None:
            errors.append((3, typ, "a section type: " + ", ".join(SECTION_DIMS)))
            return cls(pid, mid, group, typ, (), 0.0)
        dims = tuple(c.real(8 + i, required=True) for i in range(ndim))
        nsm = c.real(8 + ndim, 0.0)
        for k in range(9 + ndim, c.n):
            if c.text(k):
                errors.append((k, c.text(k), f"nothing after NSM ({typ} has {ndim} dimensions)"))
        return cls(pid, mid, group, typ, dims, nsm)

    def to_fields(self) -> list:
        return [
            self.pid,
            self.mid,
            self.group,
            self.type,
            None,
            None,
            None,
            None,
            *self.dims,
            self.nsm,
        ]


@dataclass(frozen=True)
class BeamlStation:
    """One PBEAML station: stress output flag, x/L, dimensions, NSM."""

    so: str
    x: float
    dims: tuple[float, ...]
    nsm: float


@dataclass(frozen=True)
class PbeamlCard:
    """PBEAML PID MID GROUP TYPE / DIMs(A) NSM(A) SO(1) X(1) DIMs NSM ... (last station B)."""

    pid: int
    mid: int
    group: str
    type: str
    stations: tuple[BeamlStation, ...]

    @classmethod
    def parse(cls, f: list[str], errors: ErrorList) -> PbeamlCard:
        c = Cursor(f, errors)
        pid = c.int(0, required=True)
        mid = c.int(1, required=True)
        group = c.word(2, "MSCBML0")
        typ = c.word(3, required=True)
        for k in range(4, 8):
            c.blank(k)
        ndim = SECTION_DIMS.get(typ)
        if ndim is None:
            errors.append((3, typ, "a section type: " + ", ".join(SECTION_DIMS)))
            return cls(pid, mid, group, typ, ())
        stations = []
        dims = tuple(c.real(8 + i, required=True) for i in range(ndim))
        nsm = c.real(8 + ndim, 0.0)
        stations.append(BeamlStation("YES", 0.0, dims, nsm))
        k = 9 + ndim
        while k < c.n:
            if not any(c.text(k + j) for j in range(ndim + 3)):
                break
            so = c.word(k, "YES")
            if so not in ("YES", "NO"):
                errors.append((k, so, "YES or NO"))
            x = c.real(k + 1, 1.0)  # QRG PBEAML: X(j)/XB default 1.0
            sdims = tuple(c.real(k + 2 + i, dims[i]) for i in range(ndim))
            snsm = c.real(k + 2 + ndim, 0.0)
            stations.append(BeamlStation(so, x, sdims, snsm))
            k += ndim + 3
        for j in range(k, c.n):
            if c.text(j):
                errors.append((j, c.text(j), "nothing more"))
        return cls(pid, mid, group, typ, tuple(stations))

    def to_fields(self) -> list:
        out: list = [self.pid, self.mid, self.group, self.type, None, None, None, None]
        a = self.stations[0]
        out += [*a.dims, a.nsm]
        for s in self.stations[1:]:
            out += [s.so, s.x, *s.dims, s.nsm]
        return out


@dataclass(frozen=True)
class BeamStation:
    """One PBEAM station: section properties and stress recovery points at x/L."""

    so: str
    x: float
    a: float
    i1: float
    i2: float
    i12: float
    j: float
    nsm: float
    stress_points: tuple[float, ...]  # C1 C2 D1 D2 E1 E2 F1 F2


_PBEAM_TAIL = (
    "k1", "k2", "s1", "s2", "nsi_a", "nsi_b", "cw_a", "cw_b",
    "m1_a", "m2_a", "m1_b", "m2_b", "n1_a", "n2_a", "n1_b", "n2_b",
)  # fmt: skip
_PBEAM_TAIL_DEFAULTS = (1.0, 1.0, 0.0, 0.0, 0.0, REAL_BLANK, 0.0, REAL_BLANK) + (0.0,) * 8


@dataclass(frozen=True)
class PbeamCard:
    """PBEAM: end A, its stress points, stations (SO X/XB ...), then the K/S and M/N lines.

    ``tail`` holds K1 K2 S1 S2 NSI(A) NSI(B) CW(A) CW(B) M1(A) M2(A) M1(B) M2(B) N1(A) N2(A)
    N1(B) N2(B) with the QRG defaults (NaN for "same as end A").
    """

    pid: int
    mid: int
    stations: tuple[BeamStation, ...]
    tail: tuple[float, ...] = field(default=_PBEAM_TAIL_DEFAULTS)
    has_tail: int = 0  # how many tail lines were written (0, 1 or 2), for writing back

    def tail_value(self, name: str) -> float:
        return self.tail[_PBEAM_TAIL.index(name)]

    @classmethod
    def parse(cls, f: list[str], errors: ErrorList) -> PbeamCard:
        c = Cursor(f, errors)
        pid = c.int(0, required=True)
        mid = c.int(1, required=True)
        a = c.real(2, 0.0)
        i1 = c.real(3, 0.0)
        i2 = c.real(4, 0.0)
        i12 = c.real(5, 0.0)
        j = c.real(6, 0.0)
        nsm = c.real(7, 0.0)
        nrows = (c.n + 7) // 8
        sp_a = tuple(c.real(8 + i, 0.0) for i in range(8)) if nrows > 1 else (0.0,) * 8
        stations = [BeamStation("YES", 0.0, a, i1, i2, i12, j, nsm, sp_a)]
        r = 2
        while r < nrows and c.text(8 * r) in ("YES", "YESA", "NO"):
            k = 8 * r
            so = c.text(k)
            x = c.real(k + 1, required=True)
            prev = stations[-1]
            sa = c.real(k + 2, prev.a)
            si1 = c.real(k + 3, prev.i1)
            si2 = c.real(k + 4, prev.i2)
            si12 = c.real(k + 5, prev.i12)
            sj = c.real(k + 6, prev.j)
            snsm = c.real(k + 7, prev.nsm)
            r += 1
            sp: tuple[float, ...] = (0.0,) * 8
            if so == "YES" and r < nrows and c.text(8 * r) not in ("YES", "YESA", "NO"):
                # The stress-point line is there when SO is YES; it is absent for YESA and NO.
                sp = tuple(c.real(8 * r + i, 0.0) for i in range(8))
                r += 1
            stations.append(BeamStation(so, x, sa, si1, si2, si12, sj, snsm, sp))
        tail = list(_PBEAM_TAIL_DEFAULTS)
        has_tail = 0
        for t in range(2):
            if r >= nrows:
                break
            for i in range(8):
                tail[8 * t + i] = c.real(8 * r + i, tail[8 * t + i])
            has_tail = t + 1
            r += 1
        if r < nrows:
            errors.append(
                (8 * r, c.text(8 * r), "no more PBEAM lines (SO must be YES, YESA or NO)")
            )
        return cls(pid, mid, tuple(stations), tuple(tail), has_tail)

    def to_fields(self) -> list:
        s0 = self.stations[0]
        out: list = [
            self.pid,
            self.mid,
            s0.a,
            s0.i1,
            s0.i2,
            s0.i12,
            s0.j,
            s0.nsm,
            *s0.stress_points,
        ]
        for s in self.stations[1:]:
            out += [s.so, s.x, s.a, s.i1, s.i2, s.i12, s.j, s.nsm]
            if s.so == "YES":
                out += list(s.stress_points)
        if self.has_tail:
            out += [_real_or_none(v) for v in self.tail[: 8 * self.has_tail]]
        return out


@dataclass(frozen=True)
class PbushCard:
    """PBUSH PID K K1..K6 / B B1..B6 / GE GE1..GE6 / RCV SA ST EA ET / M MASS.

    Each of ``k``, ``b``, ``ge`` holds six values (0.0 where blank); ``rcv`` four (1.0).
    """

    pid: int
    k: tuple[float, ...]
    b: tuple[float, ...]
    ge: tuple[float, ...]
    rcv: tuple[float, ...]
    mass: float
    given: tuple[str, ...]  # keywords present, in order, for writing back

    @classmethod
    def parse(cls, f: list[str], errors: ErrorList) -> PbushCard:
        c = Cursor(f, errors)
        pid = c.int(0, required=True)
        vals = {"K": (0.0,) * 6, "B": (0.0,) * 6, "GE": (0.0,) * 6, "RCV": (1.0,) * 4, "M": (0.0,)}
        given = []
        nrows = (c.n + 7) // 8
        for r in range(nrows):
            k = 8 * r
            if r:
                c.blank(k)
            key = c.text(k + 1)
            if not key and not any(c.text(k + j) for j in range(8)):
                continue
            if key not in vals:
                errors.append((k + 1, key, "K, B, GE, RCV or M"))
                continue
            n = len(vals[key])
            vals[key] = tuple(c.number(k + 2 + i, vals[key][i]) for i in range(n))
            for j in range(k + 2 + n, k + 8):
                c.blank(j)
            given.append(key)
        return cls(pid, vals["K"], vals["B"], vals["GE"], vals["RCV"], vals["M"][0], tuple(given))

    def to_fields(self) -> list:
        out: list = []
        data = {"K": self.k, "B": self.b, "GE": self.ge, "RCV": self.rcv, "M": (self.mass,)}
        for i, key in enumerate(self.given):
            out += [self.pid if i == 0 else None, key, *data[key]]
            _pad_to_row(out)
        if not self.given:
            out = [self.pid]
        return out


# ----------------------------------------------------------------------- control cards


@dataclass(frozen=True)
class ParamCard:
    """PARAM N V1 V2: a named parameter with one or two values (int, real or word)."""

    name: str
    values: tuple[int | float | str, ...]

    @classmethod
    def parse(cls, f: list[str], errors: ErrorList) -> ParamCard:
        c = Cursor(f, errors)
        name = c.word(0, required=True)
        vals: list[int | float | str] = []
        for k in range(1, c.n):
            s = c.text(k)
            if not s:
                if k < c.n - 1:
                    vals.append("")
                continue
            try:
                vals.append(parse_number(s))
            except BadField:
                try:
                    vals.append(parse_string(s))
                except BadField:
                    errors.append((k, s, "an integer, real or word"))
        if not vals:
            errors.append((1, c.text(1), "a value"))
        return cls(name, tuple(vals))

    @property
    def value(self) -> int | float | str:
        return self.values[0]

    def to_fields(self) -> list:
        return [self.name, *[None if v == "" else v for v in self.values]]


@dataclass(frozen=True)
class EigrlCard:
    """EIGRL SID V1 V2 ND MSGLVL MAXSET SHFSCL NORM / option=value ... (Lanczos request).

    V1, V2 in Hz (NaN if blank), ND number of roots (INT_BLANK if blank).
    """

    sid: int
    v1: float
    v2: float
    nd: int
    msglvl: int
    maxset: int
    shfscl: float
    norm: str
    options: tuple[str, ...] = ()

    @classmethod
    def parse(cls, f: list[str], errors: ErrorList) -> EigrlCard:
        c = Cursor(f, errors)
        sid = c.int(0, required=True)
        v1 = c.real(1)
        v2 = c.real(2)
        nd = c.int(3)
        msglvl = c.int(4, 0)
        maxset = c.int(5)
        shfscl = c.real(6)
        norm = c.word(7, "MASS")
        if norm not in ("MASS", "MAX"):
            errors.append((7, norm, "MASS or MAX"))
        # QRG EIGRL: ND > 0 or blank; V1 < V2, either may be negative (remark 5: a negative
        # V1 searches the negative roots too)
        if nd != INT_BLANK and nd < 1:
            errors.append((3, f[3], "an integer > 0 (the number of roots) or blank"))
        if not (math.isnan(v1) or math.isnan(v2)) and v1 >= v2:
            errors.append((2, f[2], f"a frequency above V1 = {f[1].strip()}"))
        opts = tuple(s for s in f[8:] if s)
        return cls(sid, v1, v2, nd, msglvl, maxset, shfscl, norm, opts)

    def to_fields(self) -> list:
        out = [
            self.sid, _real_or_none(self.v1), _real_or_none(self.v2), _int_or_none(self.nd),
            self.msglvl, _int_or_none(self.maxset), _real_or_none(self.shfscl), self.norm,
        ]  # fmt: skip
        return out + list(self.options)


@dataclass(frozen=True)
class RawCard:
    """A card femcal does not use, kept as its field texts for counting and writing back."""

    name: str
    fields: tuple[str, ...]

    def to_fields(self) -> list:
        return [s or None for s in self.fields]
