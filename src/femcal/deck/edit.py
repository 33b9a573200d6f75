"""Change a few fields of a NASTRAN deck in its own text, keeping every other byte.

A calibrated deck is the engineer's deck with the calibrated fields changed and nothing else:
comments, INCLUDE files, field formats, tabs, blank lines and line endings stay as they were.
:func:`edit_deck` finds each field and works out its new text; :func:`write_edited_deck`
writes the deck, the INCLUDE files it had to change and, if asked, a file of the changed
cards alone.

Finding a field
    :func:`~femcal.deck.read_deck` keeps, for every table row and record, the file and line
    of its card's first line. From there the card is walked as the reader walks it: comment
    lines, blank lines and comments after data are skipped; a line whose first field is blank
    or starts with ``+`` or ``*`` continues the card; an INCLUDE line or any other line ends
    it. A line gives 8 data fields (small field: 8 columns each, from column 9; free field:
    between commas) or 4 (large field: 16 columns each, on a ``NAME*`` line or a ``*``
    continuation; ``NAME*,`` in free field), and a line of 8 after an odd number of large-field
    half lines starts a new logical line, so data field k of the card (QRG field ``k % 8 + 2``
    of logical line ``k // 8``) is on the physical line that holds it. The card's name, its id
    and the field's current text are checked against what the reader read: any difference, a
    field on a line the card does not have, or a value that does not fit is a
    :class:`DeckEditError` naming file:line, card, id and field.

Changing a field
    Only the field's own characters change. Fixed format: the new text takes the field's
    columns, aligned as the old text was (left, or right; right in a blank field) and padded
    to the field's width, except at the end of a line's data, where it is not padded past the
    old text. Free field: the text between the field's two commas is replaced, the spaces
    around it kept (commas are added when the field lies past the line's last one). Tabs:
    NASTRAN expands them to 8-column stops, and every field boundary of small and large field
    (columns 9, 17, 25, ...) is such a stop, so a tab never straddles one and the field's
    columns are whole characters of the line as written. Those characters (tabs among them)
    are replaced by the new text, padded to the field's width with tabs where the old text
    was (left-aligned and followed by a tab), else with spaces; the tabs before and after the
    field stay and expand to the same columns as before. A comment after the data
    stays after it. A line whose data would pass column 80 is refused.

Numbers
    NASTRAN's real forms, with as many significant digits as fit (:func:`format_real`). A
    fixed-format field keeps one column blank, so that a value never runs into the
    right-aligned field before it (``MAT1  1223809.2`` reads as one number): 7 characters,
    at most 6 significant digits, in small field (``7.78816``, ``223809.``, ``2.0457+5``,
    ``-1.235-4``), 15 characters and at most 10 digits in large field. A free field takes its
    whole width between the commas: 8 characters (NASTRAN refuses a small free-field value of
    more than 8) and at most 7 digits, 16 and 10 in large free field.
    A field whose new text reads as the value the deck already holds is left as written and
    is not a change.

INCLUDE files
    Every file holding a changed card is written, and so is every file that INCLUDEs a
    written file (directly or through others), since its INCLUDE must name the new copy. The
    main deck goes to ``out``; another written file to ``out``'s folder, at its path relative
    to the main deck's folder when it lies below that folder, else under its own name. A name
    already taken (by another written file, or by one of the deck's own files, which are never
    overwritten) gets ``_<tag>``, then a number, before its suffix. An INCLUDE statement in a
    written file that names a file the deck read is kept as written when it still reaches,
    from the written file's folder, the file it must name now (the written copy, or else the
    unchanged original); otherwise it is rewritten to name it by a path relative to the
    written file's folder (absolute where there is none, e.g. another drive), in the quotes it
    had (none, ``'`` or ``"``), a long quoted name continued over lines of at most 72
    characters.

Writing
    Each file is written whole or not at all (:func:`femcal.atomic.write_atomic`): the
    INCLUDE copies first, then the file of changed cards, the main deck last, so that a
    written deck's INCLUDEs are there. Files are read and written as Latin-1, line by line,
    so every byte outside the changed fields is copied as it was.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..atomic import write_atomic, write_lines
from ..errors import FemcalError
from .cards import CARDS
from .deck import Deck
from .fields import BadField, parse_int, parse_number, parse_real
from .reader import read_deck
from .spec import Column, Layout

#: The most significant digits written in a field of this many characters.
DIGITS = {7: 6, 8: 7, 15: 10, 16: 10}
#: The last column of a bulk data line; an edit that would push data past it is refused.
LINE_COLUMNS = 80
#: The longest line an INCLUDE statement this module writes may have, where it can be split.
INCLUDE_COLUMNS = 72

_ASCII_UPPER = str.maketrans("abcdefghijklmnopqrstuvwxyz", "ABCDEFGHIJKLMNOPQRSTUVWXYZ")
#: Record cards whose fields can be changed: card -> keyword of a row -> values on the row.
_KEYED_ROWS = {"PBUSH": {"K": ("k", 6), "B": ("b", 6), "GE": ("ge", 6)}}


class DeckEditError(FemcalError, ValueError):
    """A field to change that is not where the deck says, or a value that does not fit it;
    the message names file:line, card, id and field."""


@dataclass(frozen=True)
class FieldEdit:
    """One field to change: the card's name, its id (the card's first field: PID, MID, EID,
    or an entry's first field on cards of several entries such as PELAS), the field's name
    in the Quick Reference Guide (``"T"``, ``"E"``, ``"K3"``), the new value, and a note
    shown with the change (e.g. the parameter's name)."""

    card: str
    id: int
    field: str
    value: float
    note: str = ""


@dataclass(frozen=True)
class FieldChange:
    """A field that changed: where (file and 1-based line of the field's text), its text
    before and after, and the edit it came from."""

    edit: FieldEdit
    file: str
    line: int
    old: str
    new: str

    def describe(self) -> str:
        """``PSHELL 1 T: 8. -> 7.78816 (p1)`` (``(blank)`` for a blank field)."""
        e = self.edit
        note = f" ({e.note})" if e.note else ""
        return f"{e.card} {e.id} {e.field}: {self.old or '(blank)'} -> {self.new}{note}"


@dataclass(frozen=True)
class CardChange:
    """A card with changed fields: its file and first line, its lines after the change
    (data only: comment lines, blank lines and comments after data dropped; no line ends)
    and the changes."""

    card: str
    id: int
    file: str
    line: int
    lines: tuple[str, ...]
    changes: tuple[FieldChange, ...]


@dataclass(frozen=True)
class EditedDeck:
    """The changes :func:`edit_deck` worked out, ready for :func:`write_edited_deck`.

    Attributes
    ----------
    path : the main deck.
    files : every file the deck read, once each (absolute paths; the main deck first).
    cards : the changed cards, in file and line order.
    lines : per file (index into ``files``), line number -> the line's new text (with its
        line ending).
    includes : per file, its INCLUDE statements.
    """

    path: Path
    files: tuple[str, ...]
    cards: tuple[CardChange, ...]
    lines: dict[int, dict[int, str]]
    includes: tuple[tuple[Include, ...], ...]

    @property
    def changes(self) -> tuple[FieldChange, ...]:
        """Every changed field."""
        return tuple(c for card in self.cards for c in card.changes)


# ------------------------------------------------------------------------------ numbers


def format_real(value: float, width: int) -> str:
    """``value`` in NASTRAN's real form with the most significant digits that fit ``width``
    characters, at most ``DIGITS[width]`` (6 for 7, 7 for 8, 10 for 15 and 16; ``width - 1``
    otherwise):
    positional where it keeps as many digits as the exponent form, else the exponent form
    without ``E`` (``2.0457+5``, ``-1.235-4``); leading and trailing zeros dropped (``.5``,
    ``8.``).

    Raises
    ------
    ValueError
        For a value that is not finite, or does not fit (less than one digit).
    """
    x = float(value)
    if not math.isfinite(x):
        raise ValueError(f"{value!r} is not a number a NASTRAN field can hold")
    if x == 0.0:
        return "0."
    most = DIGITS.get(width, width - 1)
    mantissa, _, exp = repr(x).upper().partition("E")  # the shortest text that reads back
    if sum(c.isdigit() for c in mantissa.lstrip("-0.")) <= most:
        text = _short(mantissa) if not exp else f"{_short(mantissa)}{int(exp):+d}"
        if len(text) <= width:
            return text
    for digits in range(min(most, 17), 0, -1):
        mantissa, _, exp = f"{x:.{digits - 1}E}".partition("E")
        e = int(exp)
        texts = []
        if digits - 1 - e >= 0:  # positional: the same digits with the point placed
            texts.append(_short(f"{x:.{digits - 1 - e}f}"))
        texts.append(_short(mantissa) if e == 0 else f"{_short(mantissa)}{e:+d}")
        fits = [t for t in texts if len(t) <= width]
        if fits:
            return min(fits, key=len)  # positional first on a tie
    raise ValueError(f"{value!r} does not fit a field of {width} characters")


def _text_width(d: _Data) -> int:
    """Characters a new value may take in a field of line ``d``: a fixed-format field's width
    less one, so that it never runs into a right-aligned neighbour (``1223809.2`` would read as
    one number: six significant digits in small field, nine in large), a free field's whole
    width (its commas separate it)."""
    width = 16 if d.width == 4 else 8
    return width if d.free else width - 1


def _short(s: str) -> str:
    """``'7.500000'`` -> ``'7.5'``, ``'8'`` -> ``'8.'``, ``'0.50'`` -> ``'.5'``."""
    if "." not in s:
        s += "."
    s = s.rstrip("0")
    if s.startswith("0.") and len(s) > 2:
        return s[1:]
    if s.startswith("-0.") and len(s) > 3:
        return "-" + s[2:]
    return s


# ------------------------------------------------------------------------------ lines


@dataclass(frozen=True)
class _Data:
    """A bulk data line as the reader splits it: whether it continues a card, the card's name
    (on a first line), its number of data fields (8, or 4 in large field), free field or not,
    and the data fields (stripped; upper case unless asked otherwise)."""

    cont: bool
    name: str
    width: int
    free: bool
    fields: list[str]


def _split_end(line: str) -> tuple[str, str]:
    """A line as read with ``newline=''``: its text and its line ending."""
    if line.endswith("\r\n"):
        return line[:-2], "\r\n"
    if line.endswith(("\n", "\r")):
        return line[:-1], line[-1]
    return line, ""


def _read_line(text: str, *, upper: bool = True) -> _Data | None:
    """The data of a line (without its ending) as :mod:`femcal.deck.reader` reads it, or
    None for a blank or comment line."""
    s = text.split("$", 1)[0].rstrip()
    if not s:
        return None
    if "\t" in s:
        s = s.expandtabs(8)
    up = s.upper() if s.isascii() else s.translate(_ASCII_UPPER)
    if upper:
        s = up
    if "," in s:
        parts, heads = s.split(","), up.split(",")
        head = heads[0].strip()
        cont = not head or head[0] in "+*"
        width = 4 if head.endswith("*") or (cont and head.startswith("*")) else 8
        data = [p.strip() for p in parts[1 : width + 1]]
        data += [""] * (width - len(data))
        return _Data(cont, "" if cont else head.rstrip("*"), width, True, data)
    head = up[:8].strip()
    cont = not head or s[0] in "+*"
    large = s[0] == "*" if cont else head.endswith("*")
    width, w = (4, 16) if large else (8, 8)
    data = [s[8 + w * j : 8 + w * (j + 1)].strip() for j in range(width)]
    return _Data(cont, "" if cont else head.rstrip("*"), width, False, data)


def _is_include(text: str) -> bool:
    return text[:1] in "Ii" and text[:7].upper() == "INCLUDE"


def _columns(data: str) -> list[int]:
    """The column (0-based, tabs expanded to 8-column stops) before each character of
    ``data``, and after its last one."""
    cols = [0]
    c = 0
    for ch in data:
        c = (c // 8 + 1) * 8 if ch == "\t" else c + 1
        cols.append(c)
    return cols


def _edit_fixed(data: str, a: int, b: int, text: str) -> str:
    """``data`` (a line's text before its comment) with columns ``a:b`` (multiples of 8, so
    whole characters even where tabs are) holding ``text``: aligned as the old text was, padded
    to the field's width, or at the end of the data only as far as the old text went."""
    cols = _columns(data)
    end = cols[-1]
    if end < a:  # the line stops before the field: spaces up to it
        data += " " * (a - end)
        ra = rb = len(data)
    else:
        ra = cols.index(a)
        rb = cols.index(b) if end >= b else len(data)
    old = data[ra:rb].expandtabs(8)  # a is a tab stop: the substring expands as in the line
    if not old.strip():
        new = text.rjust(b - a)
    else:
        room = len(old) if rb == len(data) else b - a
        if old[0].isspace():
            new = text.rjust(room)
        elif "\t" in data[ra:rb] and rb < len(data) and len(text) < b - a:
            new = text + _tabs(a + len(text), b)  # padded with tabs, as the line was
        else:
            new = text.ljust(room)
    return data[:ra] + new + data[rb:]


def _tabs(col: int, stop: int) -> str:
    """The tabs that take column ``col`` to ``stop`` (a tab stop)."""
    out = ""
    while col < stop:
        out += "\t"
        col = (col // 8 + 1) * 8
    return out


def _edit_free(data: str, j: int, text: str) -> str:
    """``data`` (a free-field line's text before its comment) with data field ``j`` (the text
    after comma ``j + 1``) holding ``text``, the spaces around it kept; commas are added for a
    field past the line's last one."""
    parts = data.split(",")
    tail = ""
    if len(parts) <= 1 + j:
        last = parts[-1].rstrip()
        tail = parts[-1][len(last) :]
        parts[-1] = last
        parts += [""] * (2 + j - len(parts))
    part = parts[1 + j]
    lead = part[: len(part) - len(part.lstrip())]
    trail = part[len(part.rstrip()) :] if part.strip() else ""
    parts[1 + j] = lead + text + trail
    return ",".join(parts) + tail


def _edit_line(text: str, d: _Data, j: int, new: str) -> str:
    """A data line (without its ending) with data field ``j`` holding ``new``. Checks that it
    reads back with that field changed and nothing else.

    Raises
    ------
    ValueError
        When the edited data would pass column 80.
    """
    data, dollar, comment = text.partition("$")
    if d.free:
        edited = _edit_free(data, j, new)
    else:
        w = 16 if d.width == 4 else 8
        edited = _edit_fixed(data, 8 + w * j, 8 + w * (j + 1), new)
    if dollar and data[-1:].isspace() and not edited[-1:].isspace():
        edited += " "  # keep the comment apart from the data
    cols = len(edited.rstrip().expandtabs(8))
    if cols > LINE_COLUMNS and cols > len(data.rstrip().expandtabs(8)):
        raise ValueError(f"the line's data would reach column {cols}, past {LINE_COLUMNS}")
    out = edited + dollar + comment
    back = _read_line(out)
    want = list(d.fields)
    want[j] = new.upper()
    if back is None or (back.cont, back.name, back.width, back.free, back.fields) != (
            d.cont, d.name, d.width, d.free, want):  # fmt: skip
        raise AssertionError(f"editing {text!r} gave {out!r}")  # a bug here, not in the deck
    return out


# ------------------------------------------------------------------------------ targets


@dataclass(frozen=True)
class _Target:
    """One field to change in one card: the deck's file index and the card's first line,
    how to find the field among the card's data fields, the value the deck holds there and
    how the field's text reads."""

    edit: FieldEdit
    file: int
    line: int
    find: Callable[[list[str]], int]
    value: float
    read: Callable[[str], float]


def _int(text: str) -> int | None:
    try:
        return parse_int(text)
    except BadField:
        return None


def _real_slot(layout: Layout, name: str) -> tuple[int, Column] | None:
    """Index and real column of the layout's field named ``name`` in the QRG, or None."""
    for k, slot in enumerate(layout.slots):
        if name == slot.label or name in slot.label.split("/"):
            real = [c for c in slot.columns if c.kind in "RN"]
            return (k, real[0]) if real else None
    return None


def _finder(ident: int, slot: int, entries: tuple[int, int] | None
            ) -> Callable[[list[str]], int]:  # fmt: skip
    """Where field ``slot`` of the card is among its data fields: checks the card's id, or
    finds its entry with this id on cards of ``entries`` = (entry width, entries per card)."""

    def find(fields: list[str]) -> int:
        if entries is None:
            if not fields or _int(fields[0]) != ident:
                raise LookupError(f"its id field reads {fields[0] if fields else ''!r}")
            return slot
        width, count = entries
        for n in range(count):
            if n * width < len(fields) and _int(fields[n * width]) == ident:
                return n * width + slot
        raise LookupError("no entry of the card has this id")

    return find


def _keyed_finder(ident: int, key: str, i: int) -> Callable[[list[str]], int]:
    """Where value ``i`` of the card's row with keyword ``key`` is (PBUSH ``K`` ...)."""

    def find(fields: list[str]) -> int:
        if not fields or _int(fields[0]) != ident:
            raise LookupError(f"its id field reads {fields[0] if fields else ''!r}")
        for r in range(0, len(fields), 8):
            if r + 1 < len(fields) and fields[r + 1] == key:
                return r + 2 + i
        raise LookupError(f"the card has no {key} row")

    return find


def _read_number(text: str) -> float:
    return float(parse_number(text))


def _targets(deck: Deck, e: FieldEdit) -> list[_Target]:
    """Every card of the deck that holds the field of ``e`` (one, unless the id repeats).

    Raises
    ------
    DeckEditError
        For a card the deck lacks, an id it does not have, or a field that is not a real
        field of the card (or of a card whose fields this module cannot change).
    """
    what = f"{deck.path}: {e.card} {e.id} {e.field}"
    table = deck.tables.get(e.card)
    if table is not None:
        layout = table.layout
        found = _real_slot(layout, e.field)
        if found is None:
            raise DeckEditError(f"{what}: {e.card} has no real field {e.field}")
        slot, col = found
        multi = CARDS[e.card].multi
        if multi is not None and multi[0]:
            raise DeckEditError(f"{what}: the fields of {e.card} cannot be changed here (its "
                                "entries share their first field)")  # fmt: skip
        cols = table.columns
        rows = np.flatnonzero(cols[layout.columns[0].name] == e.id)
        values = cols[col.name][rows].astype(float)
        read = parse_real if col.kind == "R" else _read_number
        find = _finder(e.id, slot, multi[1:] if multi else None)
        out = [_Target(e, int(f), int(n), find, float(v), read)
               for f, n, v in zip(table.file[rows], table.line[rows], values, strict=True)]
    elif e.card in _KEYED_ROWS:
        keyed = _KEYED_ROWS[e.card]
        m = re.fullmatch(r"([A-Z]+)([1-9])", e.field)
        if m is None or m.group(1) not in keyed or int(m.group(2)) > keyed[m.group(1)][1]:
            raise DeckEditError(f"{what}: {e.card} has no real field {e.field}")
        key, i = m.group(1), int(m.group(2)) - 1
        recs = deck.records_of(e.card)
        find = _keyed_finder(e.id, key, i)
        out = [_Target(e, f, n, find, float(getattr(r, keyed[key][0])[i]), parse_real)
               for r, f, n in zip(recs.items, recs.file, recs.line, strict=True) if r.pid == e.id]
    elif e.card in deck.records:
        raise DeckEditError(f"{what}: the fields of {e.card} cannot be changed here")
    else:
        raise DeckEditError(f"{what}: the deck has no {e.card} card")
    if not out:
        raise DeckEditError(f"{what}: {e.card} {e.id} is not in the deck")
    return out


# ------------------------------------------------------------------------------ files


@dataclass(frozen=True)
class Include:
    """An INCLUDE statement: its first and last line and their line endings, its quote
    (``'``, ``"`` or none), the name as written, the text before the name on the first line
    (``INCLUDE '``) and after it on the last line (after the closing quote: a comment, say),
    and the file it names (absolute, resolved as the reader resolves it)."""

    first: int
    last: int
    ends: tuple[str, str]
    quote: str
    name: str
    before: str
    after: str
    target: str


def _include(n: int, line: str, numbered: Iterator[tuple[int, str]],
             folder: str) -> Include | None:  # fmt: skip
    """The INCLUDE statement starting on line ``n`` (taking its continuation lines from
    ``numbered``), or None for one the reader refuses (no name, no closing quote)."""
    text, end = _split_end(line)
    data = text.split("$", 1)[0]
    rest = data[7:].strip()
    last, last_end = n, end
    if rest[:1] in ("'", '"'):
        quote = rest[0]
        start = text.index(quote, 7)
        body = rest[1:]
        close_text, offset = text, start + 1
        while quote not in body:
            more = next(numbered, None)
            if more is None:
                return None
            last = more[0]
            close_text, last_end = _split_end(more[1])
            offset = 0
            body += close_text.split("$", 1)[0].strip()
        name = body[: body.index(quote)]
        before = text[: start + 1]
        after = close_text[close_text.index(quote, offset) + 1 :]
    else:
        quote, name = "", rest
        kept = data.rstrip()
        before, after = kept[: len(kept) - len(name)], text[len(kept) :]
    if not name:
        return None
    target = os.path.abspath(os.path.join(folder, name))
    return Include(n, last, (end, last_end), quote, name, before, after, target)


def _scan(path: str, wanted: set[int]) -> tuple[list[Include], dict[int, list[tuple[int, str]]]]:
    """One pass over a file: its INCLUDE statements, and for each line in ``wanted`` the
    data lines of the card starting there (comment and blank lines left out)."""
    includes: list[Include] = []
    cards: dict[int, list[tuple[int, str]]] = {}
    card: list[tuple[int, str]] | None = None
    folder = os.path.dirname(path)
    with open(path, encoding="latin-1", newline="") as fh:
        numbered = enumerate(fh, 1)
        for n, line in numbered:
            if _is_include(line):
                card = None
                inc = _include(n, line, numbered, folder)
                if inc is not None:
                    includes.append(inc)
                continue
            if card is not None:
                d = _read_line(_split_end(line)[0])
                if d is not None:
                    if d.cont:
                        card.append((n, line))
                    else:
                        card = None
            if n in wanted:
                card = cards[n] = [(n, line)]
    return includes, cards


def _card_fields(data: list[_Data]) -> tuple[list[str], list[tuple[int, int] | None]]:
    """A card's data fields as the reader joins its lines, and where each is: (line index,
    field on the line), None for the blanks a small-field line after an odd number of
    large-field half lines adds."""
    fields: list[str] = []
    where: list[tuple[int, int] | None] = []
    for i, d in enumerate(data):
        if i and d.width == 8 and len(fields) % 8:
            pad = 8 - len(fields) % 8
            fields += [""] * pad
            where += [None] * pad
        fields += d.fields
        where += [(i, j) for j in range(d.width)]
    return fields, where


def _edit_card(file: str, line0: int, lines: list[tuple[int, str]], targets: list[_Target]
               ) -> tuple[CardChange | None, dict[int, str]]:  # fmt: skip
    """Apply ``targets`` to the card whose data lines are ``lines``: the change (None if no
    field's text changes) and the new text of each changed line (with its ending)."""
    e0 = targets[0].edit

    def fail(n: int, e: FieldEdit, why: str) -> DeckEditError:
        return DeckEditError(f"{file}:{n}: {e.card} {e.id} field {e.field}: {why}")

    split = [_split_end(line) for _, line in lines]
    data = [_read_line(t) for t, _ in split]
    first = data[0] if data else None
    if first is None or first.cont or first.name != e0.card:
        found = split[0][0].strip() if split else ""
        raise fail(line0, e0, f"no {e0.card} card starts on this line (found {found!r})")
    texts = [t for t, _ in split]
    fields, where = _card_fields(data)  # type: ignore[arg-type]  # every line is data
    changes: list[FieldChange] = []
    done: set[int] = set()
    for t in targets:
        e = t.edit
        try:
            k = t.find(fields)
        except LookupError as err:
            raise fail(line0, e, str(err)) from None
        if k >= len(where) or where[k] is None:
            raise fail(line0, e, f"the card has no line for it (field {k % 8 + 2} of "
                                 f"logical line {k // 8 + 1})")  # fmt: skip
        if k in done:
            raise fail(line0, e, "changed twice")
        done.add(k)
        i, j = where[k]  # type: ignore[misc]
        n = lines[i][0]
        d = data[i]
        assert d is not None
        old = fields[k]
        try:
            now = t.read(old) if old else None
        except BadField as err:
            raise fail(n, e, f"found {old!r}, expected {err.expected}") from None
        if now is not None and now != t.value:
            raise fail(n, e, f"found {old!r} where the deck read {t.value!r}")
        if float(e.value) == t.value:
            continue
        try:
            new = format_real(e.value, _text_width(d))
        except ValueError as err:
            raise fail(n, e, str(err)) from None
        if t.read(new) == t.value:
            continue  # the change is below the field's precision
        try:
            texts[i] = _edit_line(texts[i], d, j, new)
        except ValueError as err:
            raise fail(n, e, f"{new} does not fit: {err}") from None
        data[i] = _read_line(texts[i])
        fields[k] = new
        as_written = _read_line(split[i][0], upper=False)
        assert as_written is not None
        changes.append(FieldChange(e, file, n, as_written.fields[j], new))
    if not changes:
        return None, {}
    new_lines = {lines[i][0]: texts[i] + split[i][1] for i in range(len(lines))
                 if texts[i] != split[i][0]}  # fmt: skip
    kept = tuple(t.split("$", 1)[0].rstrip() for t in texts)
    return CardChange(e0.card, e0.id, file, line0, kept, tuple(changes)), new_lines


def edit_deck(path: str | os.PathLike[str], edits: Sequence[FieldEdit], *,
              deck: Deck | None = None) -> EditedDeck:  # fmt: skip
    """Find the fields of ``edits`` in the deck at ``path`` and work out their new text (see
    the module docstring); nothing is written. ``deck`` is the deck as read from ``path``
    (read here when not given).

    Raises
    ------
    DeckEditError
        Naming file:line, card, id and field, for a card or field that is not where the deck
        says, a field changed twice, or a value that does not fit its field.
    DeckError
        For a deck that does not read.
    """
    path = Path(path)
    if deck is None:
        deck = read_deck(path)
    files: list[str] = []
    unique: dict[str, int] = {}
    index = []
    for f in deck.files:
        key = os.path.realpath(f)
        if key not in unique:
            unique[key] = len(files)
            files.append(os.path.abspath(f))
        index.append(unique[key])
    wanted: dict[int, dict[int, list[_Target]]] = {}
    for e in edits:
        for t in _targets(deck, e):
            wanted.setdefault(index[t.file], {}).setdefault(t.line, []).append(t)
    includes, lines, cards = [], {}, []
    for s, f in enumerate(files):
        at = wanted.get(s, {})
        incs, found = _scan(f, set(at))
        includes.append(tuple(incs))
        for line0 in sorted(at):
            card, new = _edit_card(f, line0, found.get(line0, []), at[line0])
            if card is not None:
                cards.append(card)
                lines.setdefault(s, {}).update(new)
    return EditedDeck(path, tuple(files), tuple(cards), lines, tuple(includes))


# ------------------------------------------------------------------------------ writing

#: The line that ends the bulk data (added cards go before it).
_ENDDATA = re.compile(r"\s*ENDDATA(?![A-Z0-9])", re.IGNORECASE)


def _include_text(inc: Include, name: str) -> str:
    """The INCLUDE statement ``inc`` naming ``name`` instead, with its lines' endings; a
    quoted name that would pass column 72 is continued on the next lines (the reader joins
    them, each stripped, so a name with spaces stays on one line)."""
    q = inc.quote
    first_end, last_end = inc.ends
    head = inc.before + name + q
    if not q or len(head) <= INCLUDE_COLUMNS or any(c.isspace() for c in name):
        return head + inc.after + last_end
    rest = name + q
    room = INCLUDE_COLUMNS - len(inc.before)
    pieces = [inc.before + rest[:room]] if room > 0 else [inc.before.rstrip()]
    rest = rest[max(room, 0) :]
    while rest:
        pieces.append(rest[:INCLUDE_COLUMNS])
        rest = rest[INCLUDE_COLUMNS:]
    pieces[-1] += inc.after
    return (first_end or "\n").join(pieces) + last_end


def _name_for(written: Path, want: str) -> str:
    """How a file written at ``written`` names ``want`` in an INCLUDE: relative to its
    folder, or absolute where there is no relative path."""
    folder = os.path.dirname(os.path.abspath(written))
    try:
        return os.path.relpath(want, folder)
    except ValueError:  # another drive
        return os.path.abspath(want)


def _free_name(path: Path, tag: str, taken: set[str]) -> Path:
    """``path``, or ``<stem>_<tag>[_<n>]<suffix>`` beside it when ``path`` is taken."""
    cand, n = path, 1
    while os.path.realpath(cand) in taken:
        cand = path.with_name(f"{path.stem}_{tag}{'' if n == 1 else f'_{n}'}{path.suffix}")
        n += 1
    return cand


def _latin1(text: str) -> str:
    """``text`` as Latin-1 can write it (anything else as ``?``)."""
    return text.encode("latin-1", "replace").decode("latin-1")


def changed_card_lines(edited: EditedDeck, header: Sequence[str] = ()) -> list[str]:
    """The file of changed cards: ``header``, then per card a comment per changed field
    (``$ PSHELL 1 T: 8. -> 7.78816 (p1)``) and the card's lines as changed (data only)."""
    out = [_latin1(h) for h in header]
    for card in edited.cards:
        out += [f"$ {c.describe()}" for c in card.changes]
        out += list(card.lines)
    return out


def write_edited_deck(edited: EditedDeck, out: str | os.PathLike[str], *,
                      header: Sequence[str] = (), changes: str | os.PathLike[str] | None = None,
                      tag: str = "edited",
                      keep: Iterable[str | os.PathLike[str]] = (),
                      added: Sequence[str] = ()) -> list[Path]:  # fmt: skip
    """Write the edited deck to ``out``, the INCLUDE files it needs written beside it, and,
    when ``changes`` is given, the changed cards alone (:func:`changed_card_lines`) to
    ``changes``; returns the files written, the deck first. ``added`` are bulk data lines
    (new cards) written into the main deck before its ENDDATA (at its end if it has none;
    whether they were read is the caller's to check, as a bulk section ended in an INCLUDE
    file ends before them). ``header`` (comment lines, each
    starting with ``$``) goes at the top of the deck and of the changes file. Where files
    go, how INCLUDEs are kept or rewritten, and the order of writing: see the module
    docstring. ``keep`` are files not to write over besides the deck's own (those another
    deck's writing wrote into the same folder): an INCLUDE copy takes another name instead.

    Raises
    ------
    DeckEditError
        When ``out`` or ``changes`` would replace one of the deck's own files or one in
        ``keep``, or an INCLUDE cannot name a written file (a name with ``$``, or with its own
        quote character).
    """
    out = Path(out)
    header = [_latin1(h) for h in header]
    if any(not h.startswith("$") for h in header):
        raise ValueError("every header line must be a comment (start with '$')")
    files = edited.files
    own = {os.path.realpath(f): s for s, f in enumerate(files)}
    kept = {os.path.realpath(p) for p in keep}
    fixed = [out] + ([Path(changes)] if changes is not None else [])
    for p in fixed:
        if os.path.realpath(p) in own:
            raise DeckEditError(f"{p}: writing it would replace the deck's own file "
                                f"{files[own[os.path.realpath(p)]]}")  # fmt: skip
        if os.path.realpath(p) in kept:
            raise DeckEditError(f"{p}: writing it would replace a file to keep")
    if changes is not None and os.path.realpath(changes) == os.path.realpath(out):
        raise DeckEditError(f"{out}: the deck and its changed cards cannot share a file")
    parents: dict[int, set[int]] = {}
    for s, incs in enumerate(edited.includes):
        for inc in incs:
            child = own.get(os.path.realpath(inc.target))
            if child is not None:
                parents.setdefault(child, set()).add(s)
    write, todo = {0}, list(edited.lines)
    while todo:  # the changed files and every file that INCLUDEs one
        s = todo.pop()
        write.add(s)
        todo += [p for p in parents.get(s, ()) if p not in write]
    dest = {0: out}
    taken = set(own) | kept | {os.path.realpath(p) for p in fixed}
    main_folder = os.path.dirname(files[0])
    for s in sorted(write - {0}):
        try:
            rel = os.path.relpath(files[s], main_folder)
        except ValueError:  # another drive
            rel = os.pardir
        if rel == os.pardir or rel.startswith(os.pardir + os.sep) or os.path.isabs(rel):
            rel = os.path.basename(files[s])
        dest[s] = _free_name(out.parent / rel, tag, taken)
        taken.add(os.path.realpath(dest[s]))
    plans = {s: _plan_file(edited, s, dest, own) for s in write}
    written = []
    for s in sorted(write - {0}):
        written.append(_write_file(files[s], dest[s], *plans[s], header=()))
    if changes is not None:
        written.append(write_lines(changes, changed_card_lines(edited, header),
                                   encoding="latin-1"))  # fmt: skip
    written.insert(0, _write_file(files[0], out, *plans[0], header=header,
                                  added=[_latin1(a) for a in added]))  # fmt: skip
    return written


def _plan_file(edited: EditedDeck, s: int, dest: dict[int, Path], own: dict[str, int]
               ) -> tuple[dict[int, str], set[int]]:  # fmt: skip
    """The lines of file ``s`` to replace (line -> text with ending) and to drop when it is
    written to ``dest[s]``: its changed cards' lines, and the INCLUDEs that must name another
    file from there."""
    replace = dict(edited.lines.get(s, {}))
    drop: set[int] = set()
    written = dest[s]
    folder = os.path.dirname(os.path.abspath(written))
    for inc in edited.includes[s]:
        child = own.get(os.path.realpath(inc.target))
        if child is None:
            continue  # a file the deck did not read (after ENDDATA): left as written
        want = str(dest[child]) if child in dest else edited.files[child]
        now = os.path.join(folder, inc.name)
        if os.path.realpath(now) == os.path.realpath(want):
            continue
        name = _name_for(written, want)
        if "$" in name or (inc.quote and inc.quote in name):
            raise DeckEditError(f"{edited.files[s]}:{inc.first}: INCLUDE cannot name {name!r} "
                                f"(it holds '$'{' or ' + inc.quote if inc.quote else ''})")
        if name != _latin1(name):
            raise DeckEditError(f"{edited.files[s]}:{inc.first}: INCLUDE cannot name {name!r} "
                                "in a Latin-1 deck")  # fmt: skip
        replace[inc.first] = _include_text(inc, name)
        drop.update(range(inc.first + 1, inc.last + 1))
    return replace, drop


def _write_file(src: str, dst: Path, replace: dict[int, str], drop: set[int], *,
                header: Sequence[str], added: Sequence[str] = ()) -> Path:  # fmt: skip
    """Copy ``src`` to ``dst`` (atomically) line by line, with ``replace``d lines, without
    ``drop``ped ones, ``header`` first (after a UTF-8 byte order mark, if any) and the
    ``added`` lines before the first ENDDATA (else at the end), in the first line's line
    ending."""

    def copy(tmp: str) -> None:
        with (open(src, encoding="latin-1", newline="") as fin,
              open(tmp, "w", encoding="latin-1", newline="") as fout):  # fmt: skip
            head, tail, end, text = list(header), list(added), "\n", ""
            for n, line in enumerate(fin, 1):
                if n in drop:
                    continue
                text = replace.get(n, line)
                if n == 1:
                    end = _split_end(line)[1] or "\n"
                if head:
                    if text.startswith("\xef\xbb\xbf"):
                        fout.write(text[:3])
                        text = text[3:]
                    fout.write("".join(h + end for h in head))
                    head = []
                if tail and _ENDDATA.match(text):
                    fout.write("".join(a + end for a in tail))
                    tail = []
                fout.write(text)
            if head:
                fout.write("".join(h + "\n" for h in head))
            if tail:
                if fout.tell() and not text.endswith(("\n", "\r")):
                    fout.write(end)
                fout.write("".join(a + end for a in tail))

    return write_atomic(dst, copy)
