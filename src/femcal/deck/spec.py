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

from .fields import (
    INT_BLANK,
    REAL_BLANK,
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
_BLANKS: dict[str, object] = {"I": INT_BLANK, "R": REAL_BLANK, "N": REAL_BLANK, "C": INT_BLANK, "S": ""}
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
        self._refs = tuple(
            (i, self._index[c.ref]) for i, c in enumerate(self.columns) if c.ref is not None
        )
        self._defaults = tuple(c.default for c in self.columns)
        # Fast path: slots with exactly one column, in order.
        self._simple = all(len(s.columns) == 1 for s in slots)

    def parse(self, fields: list[str], errors: list[tuple[int, str, str]]) -> tuple | None:
        """Typed row from ``fields`` (data fields, '' for blank).

        Problems are appended to ``errors`` as (field index, text, expected); the row is
        None when any occurred.
        """
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
        for i, j in self._refs:
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


def _is_blank(v: object) -> bool:
    if v is None:
        return True
    if isinstance(v, (int, np.integer)):
        return int(v) == INT_BLANK
    if isinstance(v, (float, np.floating)):
        return v != v
    return v == ""


_CHUNK = 65536


class Table:
    """Rows of one card type as typed NumPy columns, with each row's source location.

    Attributes
    ----------
    layout : the card's layout.
    file : (n,) int32 index into ``Deck.files``.
    line : (n,) int32 1-based line number of the card's first line.
    """

    def __init__(self, layout: Layout):
        self.layout = layout
        self._rows: list[tuple] = []
        self._files: list[int] = []
        self._lines: list[int] = []
        self._chunks: list[tuple[list[np.ndarray], np.ndarray, np.ndarray]] = []
        self._columns: dict[str, np.ndarray] | None = None
        self.file = np.zeros(0, np.int32)
        self.line = np.zeros(0, np.int32)

    def append(self, row: tuple, file: int, line: int) -> None:
        self._rows.append(row)
        self._files.append(file)
        self._lines.append(line)
        if len(self._rows) >= _CHUNK:
            self._flush()

    def _flush(self) -> None:
        if not self._rows:
            return
        cols = []
        for j, c in enumerate(self.layout.columns):
            if c.kind == "S":
                a = np.empty(len(self._rows), dtype=object)
                a[:] = [r[j] for r in self._rows]
            else:
                a = np.fromiter((r[j] for r in self._rows), dtype=c.dtype, count=len(self._rows))
            cols.append(a)
        self._chunks.append(
            (cols, np.array(self._files, np.int32), np.array(self._lines, np.int32))
        )
        self._rows, self._files, self._lines = [], [], []
        self._columns = None

    def finish(self) -> None:
        """Merge the pending rows into the column arrays."""
        self._flush()
        if self._chunks and self._columns is None:
            names = self.layout.names
            self._columns = {
                n: np.concatenate([ch[0][j] for ch in self._chunks]) for j, n in enumerate(names)
            }
            self.file = np.concatenate([ch[1] for ch in self._chunks])
            self.line = np.concatenate([ch[2] for ch in self._chunks])
            self._chunks = [([self._columns[n] for n in names], self.file, self.line)]
        elif not self._chunks:
            self._columns = {c.name: np.zeros(0, c.dtype) for c in self.layout.columns}

    @property
    def columns(self) -> dict[str, np.ndarray]:
        """Column name -> (n,) array (int64, float64, or object for words)."""
        if self._columns is None or self._rows:
            self.finish()
        assert self._columns is not None
        return self._columns

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def __len__(self) -> int:
        return len(self.file) if self._columns is not None and not self._rows else sum(
            len(ch[1]) for ch in self._chunks
        ) + len(self._rows)

    def rows(self) -> Iterator[tuple]:
        """Rows as tuples in column order (slow; for writing and small tables)."""
        cols = [self.columns[n] for n in self.layout.names]
        for i in range(len(self)):
            yield tuple(c[i].item() if hasattr(c[i], "item") else c[i] for c in cols)
