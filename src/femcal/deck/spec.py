"""Declarative layouts of fixed-format cards, and the column tables they fill.

A layout is a string of tokens, one per data field in order (8 data fields per line, so
token k is NASTRAN field ``k % 8 + 2`` on line ``k // 8``)::

    "eid:I! pid:I=@eid g1:I! g2:I! theta|mcid:RI zoffs:R"

Token grammar ``name:TYPE[=default][!]``:

* TYPE ``I`` integer, ``R`` real, ``N`` integer-or-real (stored as real), ``C`` component
  code (digits 1-6 or 0, stored as int), ``S`` word; ``_`` (no name) a field that must be blank;
* two names with two types, ``theta|mcid:RI``, for a field that is one *or* the other:
  the value goes to the column whose type its text fits, the other column gets its blank;
* ``=value`` the Quick Reference Guide's default for a blank field; ``=@col`` defaults to
  another column's value (``pid:I=@eid``); without a default a blank stays blank
  (:data:`INT_BLANK`, NaN, or ``''``);
* ``!`` the field is required.

A :class:`Table` collects the rows of one card type and turns them into typed NumPy columns
in chunks, so that a deck of millions of cards never holds millions of Python tuples.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np

from ..markers import INT_BLANK, REAL_BLANK
from .fields import (
    BadField,
    is_int_text,
    is_real_text,
    parse_components,
    parse_int,
    parse_number,
    parse_real,
    parse_string,
)

_PARSERS: dict[str, Callable[[str], object]] = {
    "I": parse_int,
    "R": parse_real,
    "N": lambda s: float(parse_number(s)),
    "C": parse_components,
    "S": parse_string,
}
_BLANKS: dict[str, object] = {
    "I": INT_BLANK,
    "R": REAL_BLANK,
    "N": REAL_BLANK,
    "C": INT_BLANK,
    "S": "",
}
_DTYPES = {"I": np.int64, "R": np.float64, "N": np.float64, "C": np.int64, "S": object}
_EXPECT = {
    "I": "an integer",
    "R": "a real",
    "N": "a number",
    "C": "a component code (digits 1-6, or 0)",
    "S": "a word",
}


def _fits(kind: str, s: str) -> bool:
    if kind in ("I", "C"):
        return is_int_text(s)
    if kind == "R":
        return is_real_text(s)
    if kind == "S":
        return bool(s) and s[0].isalpha()
    return is_int_text(s) or is_real_text(s)


@dataclass(frozen=True)
class Column:
    """One typed column of a card table."""

    name: str
    kind: str  # I R N C S
    default: object  # blank value when no default
    ref: str | None  # '@col' default
    required: bool

    @property
    def dtype(self) -> type:
        return _DTYPES[self.kind]


@dataclass(frozen=True)
class Slot:
    """One data field of a layout: zero columns (must be blank), one, or two alternatives."""

    label: str  # QRG name, e.g. 'THETA/MCID'
    columns: tuple[Column, ...]


class Layout:
    """A parsed layout string (see module docstring)."""

    def __init__(self, card: str, text: str):
        self.card = card
        slots: list[Slot] = []
        for tok in text.split():
            if tok == "_":
                slots.append(Slot("(blank)", ()))
                continue
            names, _, rest = tok.partition(":")
            required = rest.endswith("!")
            rest = rest.rstrip("!")
            kinds, _, default = rest.partition("=")
            cols = []
            for name, kind in zip(names.split("|"), kinds, strict=True):
                ref = None
                if default.startswith("@"):
                    ref, value = default[1:], _BLANKS[kind]
                elif default:
                    value = _PARSERS[kind](default) if len(kinds) == 1 else _BLANKS[kind]
                else:
                    value = _BLANKS[kind]
                cols.append(Column(name, kind, value, ref, required))
            slots.append(Slot(names.upper().replace("|", "/"), tuple(cols)))
        self.slots: tuple[Slot, ...] = tuple(slots)
        self.columns: tuple[Column, ...] = tuple(c for s in slots for c in s.columns)
        self.names: tuple[str, ...] = tuple(c.name for c in self.columns)
        self._index = {n: i for i, n in enumerate(self.names)}
        self.refs = tuple(
            (i, self._index[c.ref]) for i, c in enumerate(self.columns) if c.ref is not None
        )
        self._defaults = tuple(c.default for c in self.columns)
        #: fast(fields, file, line, seq) -> row + (file, line, seq); raises one of FAST_FAILURES on
        #: anything unusual (then use parse_checked, which names the problem).
        self.fast: Callable[[list[str], int, int, int], tuple] = self._compile()

    def _compile(self) -> Callable[[list[str], int, int, int], tuple]:
        """Straight-line code for this layout that reads a valid card fast.

        It raises on anything unusual (bad text, a blank required field, extra fields); the
        caller then re-reads the card with :meth:`parse_checked`, which names the problem.
        """
        n = len(self.slots)
        env: dict[str, object] = {"INT_BLANK": INT_BLANK, "_Slow": _Slow, "_alt": _alternative}
        body = [
            "def fast(f, file, line, seq):",
            "    n = len(f)",
            f"    if n < {n}:",
            f"        f = f + [''] * ({n} - n)",
            f"    elif n > {n}:",
            "        raise _Slow",
        ]
        col = 0
        names: list[str] = []
        for k, slot in enumerate(self.slots):
            cols = slot.columns
            if not cols:
                body.append(f"    if f[{k}]: raise _Slow")
                continue
            body.append(f"    s = f[{k}]")
            if len(cols) == 1:
                c = cols[0]
                env[f"p{col}"] = _PARSERS[c.kind]
                env[f"d{col}"] = c.default
                # Integers: int() directly when the text is all digits and short enough for
                # int64 (int() rejects the non-ASCII digits that isdigit() accepts, which
                # sends them to the slow path, as it does longer ones).
                # Reals: float() when the text has a point and no '_' (float() accepts '1_0.'
                # and NASTRAN does not); '1.-3' and other forms make float() raise, and the
                # card is then read by parse_checked.
                if c.kind == "I":
                    read = f"(int(s) if s.isdigit() and len(s) < 19 else p{col}(s))"
                elif c.kind == "R":
                    read = f"(float(s) if '.' in s and '_' not in s else p{col}(s))"
                else:
                    read = f"p{col}(s)"
                fallback = "_Slow.fail()" if c.required else f"d{col}"
                body.append(f"    v{col} = {read} if s else {fallback}")
                names.append(f"v{col}")
                col += 1
            else:
                env[f"k{col}"] = tuple(c.kind for c in cols)
                env[f"d{col}"] = tuple(c.default for c in cols)
                vs = ", ".join(f"v{col + j}" for j in range(len(cols)))
                body.append(f"    {vs} = _alt(s, k{col}) if s else d{col}")
                if cols[0].required:
                    body.append("    if not s: raise _Slow")
                names.extend(f"v{col + j}" for j in range(len(cols)))
                col += len(cols)
        for i, j in self.refs:
            c = self.columns[i]
            blank = "INT_BLANK" if c.kind in ("I", "C") else ("''" if c.kind == "S" else None)
            test = f"v{i} == {blank}" if blank else f"v{i} != v{i}"
            body.append(f"    if {test}: v{i} = v{j}")
        body.append(f"    return ({', '.join(names)}, file, line, seq)")
        exec("\n".join(body), env)
        return env["fast"]  # type: ignore[return-value]

    def parse(self, fields: list[str], errors: list[tuple[int, str, str]]) -> tuple | None:
        """Typed row from ``fields`` (data fields, '' for blank).

        Problems are appended to ``errors`` as (field index, text, expected); the row is
        None when any occurred.
        """
        try:
            return self.fast(fields, 0, 0, 0)[:-3]
        except FAST_FAILURES:
            return self.parse_checked(fields, errors)

    def parse_checked(self, fields: list[str], errors: list[tuple[int, str, str]]) -> tuple | None:
        """Field-by-field reading that reports every problem."""
        slots = self.slots
        for k in range(len(slots), len(fields)):
            if fields[k]:
                errors.append((k, fields[k], f"at most {len(slots)} data fields"))
                return None
        row = list(self._defaults)
        n0 = len(errors)
        col = 0
        for k, slot in enumerate(slots):
            s = fields[k] if k < len(fields) else ""
            cols = slot.columns
            if not cols:
                if s:
                    errors.append((k, s, "a blank field"))
                continue
            if not s:
                if cols[0].required:
                    errors.append((k, s, f"a value ({_EXPECT[cols[0].kind]}) in a required field"))
                col += len(cols)
                continue
            if len(cols) == 1:
                try:
                    row[col] = _PARSERS[cols[0].kind](s)
                except BadField as e:
                    errors.append((k, s, e.expected))
                col += 1
                continue
            for j, c in enumerate(cols):
                if _fits(c.kind, s):
                    try:
                        row[col + j] = _PARSERS[c.kind](s)
                    except BadField as e:  # pragma: no cover - _fits guards this
                        errors.append((k, s, e.expected))
                    break
            else:
                errors.append((k, s, " or ".join(_EXPECT[c.kind] for c in cols)))
            col += len(cols)
        if len(errors) > n0:
            return None
        blank_int = INT_BLANK
        for i, j in self.refs:
            v = row[i]
            if v == blank_int or v != v or v == "":
                row[i] = row[j]
        return tuple(row)

    def unparse(self, row: dict[str, object] | tuple) -> list[object]:
        """Field values (None for blank) of a row, for writing."""
        if isinstance(row, tuple):
            row = dict(zip(self.names, row, strict=True))
        out: list[object] = []
        for slot in self.slots:
            value = None
            for c in slot.columns:
                v = row[c.name]
                if _is_blank(v):
                    continue
                value = v
                break
            out.append(value)
        while out and out[-1] is None:
            out.pop()
        return out


class _Slow(Exception):
    """Raised by compiled fast readers: read this card again, carefully."""

    @classmethod
    def fail(cls) -> object:
        raise cls


#: What a compiled fast reader may raise; the card is then read by ``parse_checked``.
FAST_FAILURES = (_Slow, BadField, ValueError)


def _alternative(s: str, kinds: tuple[str, ...]) -> tuple:
    """Values of a one-of-two field: the parsed value in the column whose type fits, blanks
    in the others."""
    out = [_BLANKS[k] for k in kinds]
    for j, k in enumerate(kinds):
        if _fits(k, s):
            out[j] = _PARSERS[k](s)
            return tuple(out)
    raise _Slow


def _is_blank(v: object) -> bool:
    if v is None:
        return True
    if isinstance(v, (int, np.integer)):
        return int(v) == INT_BLANK
    if isinstance(v, (float, np.floating)):
        return v != v
    return v == ""


#: Rows converted to arrays at a time (bounds the memory of pending Python tuples).
CHUNK = 65536


class Table:
    """Rows of one card type as typed NumPy columns, with each row's source location.

    Rows arrive in two ways: one at a time as tuples (``pending``, converted in chunks), and
    as ready column arrays from the reader's fast lane (:meth:`add_chunk`). Each row carries
    its place in the reading order (``seq``); :meth:`finish` puts the rows in that order.

    Attributes
    ----------
    layout : the card's layout.
    file : (n,) int32 index into ``Deck.files``.
    line : (n,) int32 1-based line number of the card's first line.
    """

    def __init__(self, layout: Layout):
        self.layout = layout
        #: rows not yet converted: the layout's column values, then file, line and seq.
        #: Cleared in place on each flush, so a reader may keep a reference to it.
        self.pending: list[tuple] = []
        self._chunks: list[tuple[list[np.ndarray], np.ndarray, np.ndarray, np.ndarray]] = []
        self._columns: dict[str, np.ndarray] | None = None
        self.file = np.zeros(0, np.int32)
        self.line = np.zeros(0, np.int32)

    def append(self, row: tuple, file: int, line: int, seq: int = -1) -> None:
        """Add a row (the layout's column values, without location)."""
        self.pending.append((*row, file, line, seq))
        if len(self.pending) >= CHUNK:
            self.flush()

    def add_chunk(
        self, columns: list[np.ndarray], file: int, lines: np.ndarray, seq: np.ndarray
    ) -> None:
        """Add rows given as column arrays (in layout order) with their lines and seq."""
        n = len(lines)
        self._chunks.append(
            (columns, np.full(n, file, np.int32), lines.astype(np.int32), seq.astype(np.int64))
        )
        self._columns = None

    def flush(self) -> None:
        """Convert the pending rows into a chunk of typed column arrays."""
        if not self.pending:
            return
        transposed = list(zip(*self.pending, strict=True))
        cols = []
        for j, c in enumerate(self.layout.columns):
            if c.kind == "S":
                a = np.empty(len(self.pending), dtype=object)
                a[:] = transposed[j]
            else:
                a = np.array(transposed[j], dtype=c.dtype)
            cols.append(a)
        self._chunks.append(
            (
                cols,
                np.array(transposed[-3], np.int32),
                np.array(transposed[-2], np.int32),
                np.array(transposed[-1], np.int64),
            )
        )
        self.pending.clear()
        self._columns = None

    def finish(self) -> None:
        """Merge everything into the column arrays, in reading order."""
        self.flush()
        if self._chunks and self._columns is None:
            names = self.layout.names
            cols = [np.concatenate([ch[0][j] for ch in self._chunks]) for j in range(len(names))]
            file = np.concatenate([ch[1] for ch in self._chunks])
            line = np.concatenate([ch[2] for ch in self._chunks])
            seq = np.concatenate([ch[3] for ch in self._chunks])
            if len(seq) > 1 and (np.diff(seq) < 0).any():
                order = np.argsort(seq, kind="stable")
                cols = [c[order] for c in cols]
                file, line, seq = file[order], line[order], seq[order]
            self._columns = dict(zip(names, cols, strict=True))
            self.file, self.line = file, line
            self._chunks = [(cols, file, line, seq)]
        elif not self._chunks:
            self._columns = {c.name: np.zeros(0, c.dtype) for c in self.layout.columns}

    @property
    def columns(self) -> dict[str, np.ndarray]:
        """Column name -> (n,) array (int64, float64, or object for words)."""
        if self._columns is None or self.pending:
            self.finish()
        assert self._columns is not None
        return self._columns

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def __len__(self) -> int:
        return sum(len(ch[1]) for ch in self._chunks) + len(self.pending)

    def rows(self) -> Iterator[tuple]:
        """Rows as tuples in column order (slow; for writing and small tables)."""
        cols = [self.columns[n] for n in self.layout.names]
        for i in range(len(self)):
            yield tuple(c[i].item() if hasattr(c[i], "item") else c[i] for c in cols)
