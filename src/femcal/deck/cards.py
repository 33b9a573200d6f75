"""The cards femcal reads, with their field layouts and Quick Reference Guide defaults.

Fixed-format cards are declared as layouts (see :mod:`femcal.deck.spec`) and stored as
column tables; cards with lists or repeated groups are records (:mod:`femcal.deck.records`).
Cards holding several entries per card (``SPC``, ``PELAS``, ``CORD1R`` ...) store one row
per entry.

Cards that would change a SOL 103 answer but femcal cannot yet model are listed in
:data:`UNSUPPORTED_STRUCTURAL`; reading a deck with one of them is an error.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from . import records as rec
from .legacy import FIELD_REWRITES
from .spec import Layout

# -------------------------------------------------------------------------- layouts

# the continuation: field 2 blank, TFLAG in field 3, T1-T4 (T1-T3) in fields 4-7 (QRG)
_SHELL_Q4 = (
    "eid:I! pid:I=@eid g1:I! g2:I! g3:I! g4:I! theta|mcid:RI zoffs:R "
    "_ tflag:I t1:R t2:R t3:R t4:R"
)
_SHELL_T3 = "eid:I! pid:I=@eid g1:I! g2:I! g3:I! theta|mcid:RI zoffs:R _ _ tflag:I t1:R t2:R t3:R"
_ORIENT = "x1|g0:RI x2:R x3:R"
_W = "w1a:R=0. w2a:R=0. w3a:R=0. w1b:R=0. w2b:R=0. w3b:R=0."

LAYOUTS: dict[str, str] = {
    # grids and coordinate systems
    "GRID": "id:I! cp:I x1:R=0. x2:R=0. x3:R=0. cd:I ps:C seid:I",
    "GRDSET": "_ cp:I _ _ _ cd:I ps:C seid:I",
    "CORD2R": "cid:I! rid:I=0 a1:R=0. a2:R=0. a3:R=0. b1:R=0. b2:R=0. b3:R=0. "
    "c1:R=0. c2:R=0. c3:R=0.",
    "CORD1R": "cid:I! g1:I! g2:I! g3:I!",
    # shells
    "CQUAD4": _SHELL_Q4,
    "CQUADR": _SHELL_Q4,
    "CTRIA3": _SHELL_T3,
    "CTRIAR": _SHELL_T3,
    "CQUAD8": "eid:I! pid:I=@eid g1:I! g2:I! g3:I! g4:I! g5:I g6:I g7:I g8:I t1:R t2:R t3:R t4:R "
    "theta|mcid:RI zoffs:R tflag:I",
    "CTRIA6": "eid:I! pid:I=@eid g1:I! g2:I! g3:I! g4:I g5:I g6:I theta|mcid:RI zoffs:R "
    "t1:R t2:R t3:R tflag:I",
    "CSHEAR": "eid:I! pid:I=@eid g1:I! g2:I! g3:I! g4:I!",
    # solids (linear node counts required, the rest optional midside nodes)
    "CHEXA": "eid:I! pid:I! "
    + " ".join(f"g{i}:I!" for i in range(1, 9))
    + " "
    + " ".join(f"g{i}:I" for i in range(9, 21)),
    "CPENTA": "eid:I! pid:I! "
    + " ".join(f"g{i}:I!" for i in range(1, 7))
    + " "
    + " ".join(f"g{i}:I" for i in range(7, 16)),
    "CTETRA": "eid:I! pid:I! "
    + " ".join(f"g{i}:I!" for i in range(1, 5))
    + " "
    + " ".join(f"g{i}:I" for i in range(5, 11)),
    "CPYRAM": "eid:I! pid:I! "
    + " ".join(f"g{i}:I!" for i in range(1, 6))
    + " "
    + " ".join(f"g{i}:I" for i in range(6, 14)),
    # line elements
    # CBAR/CBEAM PID: blank -> BAROR/BEAMOR PID, else EID (resolved in the model)
    "CBAR": f"eid:I! pid:I ga:I! gb:I! {_ORIENT} offt:S pa:C pb:C {_W}",
    "BAROR": f"_ pid:I _ _ {_ORIENT} offt:S",
    "CBEAM": f"eid:I! pid:I ga:I! gb:I! {_ORIENT} offt|bit:SR pa:C pb:C {_W} sa:I sb:I",
    "BEAMOR": f"_ pid:I _ _ {_ORIENT} offt:S",
    "CROD": "eid:I! pid:I=@eid g1:I! g2:I!",
    "CONROD": "eid:I! g1:I! g2:I! mid:I! a:R=0. j:R=0. c:R=0. nsm:R=0.",
    "CTUBE": "eid:I! pid:I=@eid g1:I! g2:I!",
    # springs, bushes, masses
    "CELAS1": "eid:I! pid:I=@eid g1:I c1:C g2:I c2:C",
    "CELAS2": "eid:I! k:R! g1:I c1:C g2:I c2:C ge:R=0. s:R=0.",
    "CELAS3": "eid:I! pid:I=@eid s1:I s2:I",
    "CELAS4": "eid:I! k:R! s1:I s2:I",
    "CBUSH": f"eid:I! pid:I=@eid ga:I! gb:I {_ORIENT} cid:I s:R=0.5 ocid:I=-1 s1:R s2:R s3:R",
    "CONM1": "eid:I! g:I! cid:I=0 "
    + " ".join(f"m{i}{j}:R=0." for i in range(1, 7) for j in range(1, i + 1)),
    "CONM2": "eid:I! g:I! cid:I=0 m:R=0. x1:R=0. x2:R=0. x3:R=0. _ "
    "i11:R=0. i21:R=0. i22:R=0. i31:R=0. i32:R=0. i33:R=0.",
    "CMASS1": "eid:I! pid:I=@eid g1:I c1:C g2:I c2:C",
    "CMASS2": "eid:I! m:R! g1:I c1:C g2:I c2:C",
    "CMASS3": "eid:I! pid:I=@eid s1:I s2:I",
    "CMASS4": "eid:I! m:R! s1:I s2:I",
    "PMASS": "pid:I! m:R!",
    "PELAS": "pid:I! k:R! ge:R=0. s:R=0.",
    # rigid
    "RBAR": "eid:I! ga:I! gb:I! cna:C cnb:C cma:C cmb:C alpha:R=0. tref:R=0.",
    # constraints
    "SPC": "sid:I! g:I! c:C! d:R=0.",
    "SUPORT": "id:I! c:C",
    "ASET": "id:I! c:C",
    # properties
    "PSHELL": "pid:I! mid1:I t:R mid2:I bk:R=1.0 mid3:I tst:R=0.833333 nsm:R=0. z1:R z2:R mid4:I",
    "PSHEAR": "pid:I! mid:I! t:R! nsm:R=0. f1:R=0. f2:R=0.",
    "PSOLID": "pid:I! mid:I! cordm:I=0 in|in_word:IS stress|stress_word:IS "
    "isop|isop_word:IS fctn:S=SMECH",
    "PBAR": "pid:I! mid:I! a:R=0. i1:R=0. i2:R=0. j:R=0. nsm:R=0. _ "
    "c1:R=0. c2:R=0. d1:R=0. d2:R=0. e1:R=0. e2:R=0. f1:R=0. f2:R=0. k1:R k2:R i12:R=0.",
    "PROD": "pid:I! mid:I! a:R! j:R=0. c:R=0. nsm:R=0.",
    "PTUBE": "pid:I! mid:I! od:R! t:R nsm:R=0. od2:R",
    # materials
    "MAT1": "mid:I! e:R g:R nu:R rho:R=0. a:R=0. tref:R=0. ge:R=0. "
    "st:R=0. sc:R=0. ss:R=0. mcsid:I=0",
    "MAT2": "mid:I! g11:R=0. g12:R=0. g13:R=0. g22:R=0. g23:R=0. g33:R=0. rho:R=0. "
    "a1:R=0. a2:R=0. a3:R=0. tref:R=0. ge:R=0. st:R=0. sc:R=0. ss:R=0. mcsid:I=0",
    "MAT8": "mid:I! e1:R! e2:R! nu12:R! g12:R=0. g1z:R g2z:R rho:R=0. "
    "a1:R=0. a2:R=0. tref:R=0. xt:R xc:R yt:R yc:R s:R ge:R=0. f12:R strn:R=0.",
    "MAT9": "mid:I! g11:R=0. g12:R=0. g13:R=0. g14:R=0. g15:R=0. g16:R=0. g22:R=0. "
    "g23:R=0. g24:R=0. g25:R=0. g26:R=0. g33:R=0. g34:R=0. g35:R=0. g36:R=0. "
    "g44:R=0. g45:R=0. g46:R=0. g55:R=0. g56:R=0. g66:R=0. rho:R=0. a1:R=0. "
    "a2:R=0. a3:R=0. a4:R=0. a5:R=0. a6:R=0. tref:R=0. ge:R=0.",
    # eigenvalue methods
    "EIGR": "sid:I! method:S=LAN f1:R f2:R ne:I nd:I _ _ norm:S=MASS g:I c:C",
}
for _kind in "CS":
    LAYOUTS[f"CORD2{_kind}"] = LAYOUTS["CORD2R"]
    LAYOUTS[f"CORD1{_kind}"] = LAYOUTS["CORD1R"]

#: Cards whose fields hold several entries: (shared leading fields, entry width, entries per
#: card). SPC's SID is shared by its two (G, C, D) entries.
MULTI_ENTRY: dict[str, tuple[int, int, int]] = {
    "CORD1R": (0, 4, 2), "CORD1C": (0, 4, 2), "CORD1S": (0, 4, 2),
    "PELAS": (0, 4, 2), "PMASS": (0, 2, 4), "SPC": (1, 3, 2), "SUPORT": (0, 2, 4),
    "ASET": (0, 2, 4),
}  # fmt: skip

RECORDS: dict[str, Callable[[list[str], list], object]] = {
    "SPOINT": rec.SpointCard.parse,
    "SPC1": rec.Spc1Card.parse,
    "ASET1": rec.Aset1Card.parse,
    "SPCADD": rec.SetUnionCard.parse,
    "MPCADD": rec.SetUnionCard.parse,
    "RBE2": rec.Rbe2Card.parse,
    "RBE3": rec.Rbe3Card.parse,
    "MPC": rec.MpcCard.parse,
    "PCOMP": rec.PcompCard.parse,
    "PCOMPG": lambda f, e: rec.PcompCard.parse(f, e, global_ids=True),
    "PBARL": rec.PbarlCard.parse,
    "PBEAML": rec.PbeamlCard.parse,
    "PBEAM": rec.PbeamCard.parse,
    "PBUSH": rec.PbushCard.parse,
    "PARAM": rec.ParamCard.parse,
    "EIGRL": rec.EigrlCard.parse,
}

def _unsupported(reason: str, names: tuple[str, ...]) -> dict[str, str]:
    return dict.fromkeys(names, reason)


#: Cards that change a SOL 103 answer and that femcal does not model yet.
UNSUPPORTED_STRUCTURAL: dict[str, str] = _unsupported("an element femcal cannot model yet", (
    "CGAP", "CBUSH1D", "CBUSH2D", "CFAST", "CWELD", "CSEAM", "CBEND", "GENEL",
    "CQUADX", "CTRIAX", "CTRIAX6", "CQUADX4", "CQUADX8", "CTRIAX3", "CTRAX3", "CTRAX6",
    "CQUAD", "CTRIA", "CCONEAX", "CRAC2D", "CRAC3D", "CHACAB", "CHACBR", "CIFHEX",
    "CIFPENT", "CIFQUAD", "CIFQDX", "CMASS5", "CELAS5", "CONM3",
))  # fmt: skip
UNSUPPORTED_STRUCTURAL.update(_unsupported("a rigid element femcal cannot model yet", (
    "RBE1", "RROD", "RSPLINE", "RTRPLT", "RBAR1", "RTRPLT1", "RJOINT", "RSSCON",
)))  # fmt: skip
# Elements of COSMIC NASTRAN (NASTRAN-95, the public NASTRAN of 1990s decks) gone from current
# NASTRAN, its hydroelastic fluid elements and the user-written dummy elements CDUMi: kept as
# unknown cards they would leave their stiffness and mass out of the model without a word.
# Names from NASTRAN-95's element table (mis/sdr2e.f).
UNSUPPORTED_STRUCTURAL.update(_unsupported("an element of older NASTRAN (COSMIC) femcal cannot "
                                           "model", (
    "CTWIST", "CTRIA1", "CTRIA2", "CTRBSC", "CTRPLT", "CTRPLT1", "CTRMEM", "CTRSHL",
    "CTRIM6", "CQDPLT", "CQDMEM", "CQDMEM1", "CQDMEM2", "CQUAD1", "CQUAD2", "CQUADTS",
    "CTRIATS", "CTRIARG", "CTRAPRG", "CTORDRG", "CTRIAAX", "CTRAPAX", "CWEDGE", "CHEXA1",
    "CHEXA2", "CIHEX1", "CIHEX2", "CIHEX3", "CIS2D8", "CELBOW",
)))  # fmt: skip
UNSUPPORTED_STRUCTURAL.update(_unsupported("a hydroelastic fluid element femcal cannot model", (
    "CFLUID2", "CFLUID3", "CFLUID4", "CFLMASS", "CAXIF2", "CAXIF3", "CAXIF4", "CSLOT3",
    "CSLOT4",
)))  # fmt: skip
UNSUPPORTED_STRUCTURAL.update(
    {f"CDUM{i}": "a user-written dummy element femcal cannot model" for i in range(1, 10)}
)
UNSUPPORTED_STRUCTURAL.update(
    {
        "MAT3": "an axisymmetric material (no axisymmetric elements in femcal)",
        "PCOMPLS": "a solid laminate property",
        "SEBULK": "superelements",
        "SESET": "superelements",
        "SECONCT": "superelements",
        "CSUPER": "superelements",
        "GRIDB": "axisymmetric fluid grids",
        "ACMODL": "fluid-structure coupling",
    }
)


@dataclass(frozen=True)
class CardDef:
    """How one card name is read: a fixed layout (table rows) or a record parser.

    ``rewrite(name, fields)``, where a card has one, turns older field conventions NASTRAN
    still reads into their current form before the layout types the fields
    (:mod:`femcal.deck.legacy`); it returns the problems it found.
    """

    name: str
    layout: Layout | None
    record: Callable[[list[str], list], object] | None
    multi: tuple[int, int, int] | None = None
    rewrite: Callable[[str, list[str]], list[tuple[int, str, str]]] | None = None


CARDS: dict[str, CardDef] = {}
for _name, _text in LAYOUTS.items():
    CARDS[_name] = CardDef(_name, Layout(_name, _text), None, MULTI_ENTRY.get(_name),
                           FIELD_REWRITES.get(_name))  # fmt: skip
for _name, _fn in RECORDS.items():
    CARDS[_name] = CardDef(_name, None, _fn)
SUPPORTED = frozenset(CARDS)
