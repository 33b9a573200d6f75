"""The Deck: everything read from a NASTRAN input file, still in NASTRAN's terms."""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass, field

from .records import ParamCard, RawCard
from .spec import Layout, Table

#: SOL names and the numbers they stand for.
SOL_NAMES: dict[str, int] = {
    "SESTATIC": 101, "STATICS": 101, "SEMODES": 103, "MODES": 103, "SEBUCKL": 105,
    "NLSTATIC": 106, "SEDCEIG": 107, "SEDFREQ": 108, "SEDTRAN": 109, "SEMCEIG": 110,
    "SEMFREQ": 111, "SEMTRAN": 112, "DBTRANS": 190, "SEAERO": 146, "SENLHEAT": 153,
    "NLTRAN": 129, "NLSCSH": 159, "DESOPT": 200, "DESIGN": 200, "AESTAT": 144,
    "SEFLUTTR": 145, "SEFLUTTER": 145, "SENLTRAN": 129,
}  # fmt: skip

#: Case-control commands femcal reads or stores (recognised by their first four or more
#: letters, as NASTRAN does).
CASE_COMMANDS = (
    "METHOD", "SPC", "MPC", "TITLE", "SUBTITLE", "LABEL", "SUBCASE", "ECHO", "DISPLACEMENT",
    "VECTOR", "SUPORT1", "K2GG", "M2GG", "B2GG", "K2PP", "M2PP", "B2PP", "SDAMPING",
    "FREQUENCY", "DLOAD", "LOAD", "TEMPERATURE", "STRESS", "STRAIN", "FORCE", "SPCFORCES",
    "MPCFORCES", "ACCELERATION", "VELOCITY", "ESE", "EKE", "GPFORCE", "OUTPUT", "SET",
    "PARAM", "RESVEC", "TSTEP", "GUST", "TRIM", "FLUTTER", "SUBSEQ", "SYMSEQ", "ANALYSIS",
    "AUTOSPC", "EXTSEOUT",
)  # fmt: skip

#: Every other case-control command of MSC and Simcenter Nastran (Quick Reference Guides):
#: read and left alone, as they do not change the normal modes. A command in neither list is
#: an error when it looks like one that changes them (:data:`MODAL_COMMANDS`: a misspelt
#: ``SCP = 1`` would otherwise drop the constraints without a word) and a warning otherwise
#: (no hand-kept list of two vendors' commands is ever complete).
OTHER_CASE_COMMANDS = (
    "A2GG", "ACFPMRESULT", "ACINTENSITY", "ACORDCHK", "ACPOWER", "ACTIVAT", "ADACT", "ADAMSMNF",
    "ADAPT", "ADMRECVR", "AECONFIG", "AEROF", "AESYMXY", "AESYMXZ", "AEUXREF", "ALOAD", "APRES",
    "APRESSURE", "ASPCFRC", "ATVOUT", "AUXCASE", "AUXMODEL", "AXISYMMETRIC", "BC", "BCHANGE",
    "BCMOVE", "BCONTACT", "BCRESULTS", "BCSET", "BEGIN", "BGRESULTS", "BGSET", "BOLTID", "BOLTLD",
    "BOLTRESULTS", "BOUTPUT", "CAMPBELL", "CKGAP", "CLOAD", "CMETHOD", "CMSENERGY", "CRSTRN",
    "CSMSET", "CSSCHD", "CYCLIC", "CZRESULTS", "DATAREC", "DEACTEL", "DEFORM", "DESGLB", "DESMOD",
    "DESOBJ", "DESSUB", "DESVAR", "DIVERG", "DMIGNAME", "DRSPAN", "DSAPRT", "DSCOEFFICIENT", "DSYM",
    "DTEMP", "EBDSET", "ECHOOFF", "ECHOON", "EDE", "EFFMASS", "EFLUX", "ELAR", "ELFORCE", "ELSDCON",
    "ELSENS", "ELSTRESS", "ELSTRN", "ELSUM", "ENDSTEP", "ENDSUBCASE", "ENTHALPY", "EQUILIBRIUM",
    "ERP", "ERPREF", "EXCLUDE", "EXPORTLID", "FATIGUE", "FLSFSEL", "FLSPOUT", "FLSTCNT", "FLUX",
    "FMETHOD", "FRF", "GCRSLT", "GCRSTRN", "GELSTRN", "GKRESULTS", "GLOBAL", "GPKE", "GPLSTRN",
    "GPRSORT", "GPSDCON", "GPSTRAIN", "GPSTRESS", "GROUNDCHECK", "GSTRAIN", "GSTRESS", "GTHSTRN",
    "HADAPART", "HARMONICS", "HDOT", "HOUTPUT", "HTFLOW", "IC", "INCLUDE", "INITS", "INPOWER",
    "INTENSITY", "IRLOAD", "JINTEG", "K42GG", "KPR", "LINE", "LOADSET", "MASSSET", "MASTER",
    "MAXLINES", "MAXMIN", "MBDEXPORT", "MBDRECVR", "MCFRACTION", "MEFFMASS", "MFLUID", "MODALEKE",
    "MODALKE", "MODALSE", "MODCON", "MODES", "MODESELECT", "MODSEL", "MODTRAK", "MONITOR", "MONVAR",
    "MPRES", "NLARCL", "NLCNTL", "NLIC", "NLLOAD", "NLOPRM", "NLPARM", "NLRESTART", "NLSTRESS",
    "NONLINEAR", "NOUTPUT", "NSM", "OFREQUENCY", "OLOAD", "OMODES", "OPRESSURE", "OSTNINI", "OTEMP",
    "OTIME", "OUTRCV", "P2G", "PAGE", "PARTN", "PEAKOUT", "PFGRID", "PFMODE", "PFPANEL", "PLOTID",
    "PLSTRN", "POST", "PRESSURE", "PRETENSION", "PSDF", "RANDOM", "RANDVAR", "RCROSS", "REPCASE",
    "RGYRO", "RIGID", "RMAXMIN", "RMETHOD", "RSMETHOD", "RSVCOMP", "SACCELERATION", "SDISPLACEMENT",
    "SEALL", "SEDR", "SEDV", "SEEXCLUDE", "SEFINAL", "SEKREDUCE", "SELGENERATE", "SELOAD",
    "SELREDUCE", "SEMGENERATE", "SEMREDUCE", "SEQDEP", "SERESP", "SETMC", "SETMCNAME", "SETS",
    "SHELLTHK", "SKIP", "SKIPOFF", "SKIPON", "SMETHOD", "SOLUTION", "STATSUB", "STEP", "STRFIELD",
    "SUBCOM", "SUBSTEP", "SUPER", "SURFACE", "SVECTOR", "SVELOCITY", "SYM", "SYMCOM", "TFL",
    "THERMAL", "THSTRN", "TSTEPNL", "TSTRU", "VATV", "VOLUME", "VUGRID", "WEIGHTCHECK", "XTITLE",
    "YTITLE",
)  # fmt: skip


def is_case_command(word: str) -> bool:
    """Whether ``word`` names a case-control command: one of them in full, or the first four
    or more letters of one (NASTRAN reads a command by its first four letters)."""
    word = word.upper()
    for full in (*CASE_COMMANDS, *OTHER_CASE_COMMANDS):
        if word == full or (len(word) >= 4 and len(full) >= 4 and word[:4] == full[:4]):
            return True
    return False


#: The case-control commands that change the normal modes femcal computes.
MODAL_COMMANDS = ("METHOD", "SPC", "MPC", "SUPORT1", "AUTOSPC", "K2GG", "M2GG", "B2GG",
                  "K2PP", "M2PP", "B2PP", "K42GG", "SUBCASE", "EXTSEOUT")  # fmt: skip


def nearest_case_command(word: str, among: tuple[str, ...] | None = None) -> str | None:
    """The command a misspelt ``word`` most likely meant (difflib), among ``among`` (default
    every known command), or None."""
    import difflib

    choices = among if among is not None else (*CASE_COMMANDS, *OTHER_CASE_COMMANDS)
    got = difflib.get_close_matches(word.upper(), choices, n=1, cutoff=0.6)
    return got[0] if got else None


def canonical_case_key(key: str) -> str:
    """Full name of a case-control command from its (possibly abbreviated) spelling."""
    key = key.upper()
    if key in CASE_COMMANDS:
        return key
    if len(key) >= 4:
        for full in CASE_COMMANDS:
            if full.startswith(key):
                return full
    return key


@dataclass
class CaseControl:
    """Case control: global commands, subcases, and the raw lines.

    ``global_`` and each ``subcases[id]`` map a command (full name, e.g. ``"METHOD"``) to
    its value text as written (``"1"``, ``"Random Gust"``); ``where`` maps (subcase id or
    None for the global part, command) to the (file index, line) it was read from.
    """

    lines: list[str] = field(default_factory=list)
    global_: dict[str, str] = field(default_factory=dict)
    subcases: dict[int, dict[str, str]] = field(default_factory=dict)
    where: dict[tuple[int | None, str], tuple[int, int]] = field(default_factory=dict)

    def effective(self) -> list[tuple[int, dict[str, str]]]:
        """(subcase id, commands) for each subcase with the global ones inherited.

        A deck without SUBCASE gives one entry with id 0.
        """
        if not self.subcases:
            return [(0, dict(self.global_))]
        return [(sid, {**self.global_, **cmds}) for sid, cmds in self.subcases.items()]

    def value(self, key: str) -> str | None:
        """The command's value in the first subcase (global if no subcase), or None."""
        return self.effective()[0][1].get(canonical_case_key(key))

    def location(self, key: str) -> tuple[int, int] | None:
        """(file index, line) of the command :meth:`value` returns, or None."""
        key = canonical_case_key(key)
        first = next(iter(self.subcases), None)
        if first is not None and (first, key) in self.where:
            return self.where[(first, key)]
        return self.where.get((None, key))


@dataclass
class RecordList:
    """Records of one card name with their source locations (file index, line)."""

    items: list = field(default_factory=list)
    file: list[int] = field(default_factory=list)
    line: list[int] = field(default_factory=list)

    def append(self, item: object, file: int, line: int) -> None:
        self.items.append(item)
        self.file.append(file)
        self.line.append(line)

    def __len__(self) -> int:
        return len(self.items)

    def __iter__(self) -> Iterator:
        return iter(self.items)

    def __getitem__(self, i: int):
        return self.items[i]


_SOL_RE = re.compile(r"^\s*SOL\s*[=,]?\s*([A-Z0-9]+)", re.IGNORECASE)


@dataclass
class Deck:
    """A NASTRAN deck as read.

    Attributes
    ----------
    path : the main file.
    files : every file read (main first, then INCLUDEs); locations index into it.
    executive : executive-control lines (without comments).
    sol : solution number (``SOL SEMODES`` -> 103), or None for a bulk-only file.
    sol_text : SOL as written (``"SEMODES"``).
    case : case control.
    tables : card name -> :class:`Table` of fixed-format cards (one row per entry).
    records : card name -> :class:`RecordList` of variable-format cards.
    unused : cards femcal does not use for SOL 103, as :class:`RawCard` records.
    card_count : every bulk card as it appears in the deck (name -> count), in first-seen order.
    """

    path: str
    files: list[str] = field(default_factory=list)
    executive: list[str] = field(default_factory=list)
    sol: int | None = None
    sol_text: str = ""
    case: CaseControl = field(default_factory=CaseControl)
    tables: dict[str, Table] = field(default_factory=dict)
    records: dict[str, RecordList] = field(default_factory=dict)
    unused: RecordList = field(default_factory=RecordList)
    card_count: dict[str, int] = field(default_factory=dict)
    has_bulk_section: bool = False

    def table(self, name: str) -> Table:
        """The table of a fixed-format card (an empty one if the deck has none)."""
        t = self.tables.get(name)
        if t is None:
            from .cards import CARDS

            layout = CARDS[name].layout
            if layout is None:
                raise KeyError(f"{name} is a record card; use Deck.records_of({name!r})")
            t = Table(layout)
            t.finish()
        return t

    def records_of(self, name: str) -> RecordList:
        """Records of a variable-format card (an empty list if the deck has none)."""
        return self.records.get(name) or RecordList()

    def where(self, file: int, line: int) -> str:
        """``"path:line"`` for a stored location."""
        return f"{self.files[file]}:{line}"

    @property
    def unused_count(self) -> dict[str, int]:
        """Cards not used by SOL 103, name -> count."""
        out: dict[str, int] = {}
        for c in self.unused.items:
            out[c.name] = out.get(c.name, 0) + 1
        return out

    @property
    def params(self) -> dict[str, ParamCard]:
        """PARAM cards by name (bulk data)."""
        return {p.name: p for p in self.records_of("PARAM")}

    def param(self, name: str, default: object = None) -> object:
        """First value of PARAM ``name``, or ``default``."""
        p = self.params.get(name.upper())
        return default if p is None else p.value

    def set_sol(self, text: str) -> None:
        m = _SOL_RE.match(text)
        if m:
            self.sol_text = m.group(1).upper()
            self.sol = (
                int(self.sol_text) if self.sol_text.isdigit() else SOL_NAMES.get(self.sol_text)
            )

    @staticmethod
    def layout_of(name: str) -> Layout | None:
        from .cards import CARDS

        d = CARDS.get(name)
        return None if d is None else d.layout


__all__ = ["CaseControl", "Deck", "RawCard", "RecordList"]
