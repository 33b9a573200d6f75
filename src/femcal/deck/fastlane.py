"""The fast lane of the bulk-data reader: single-line small-field cards, read with NumPy.

Most lines of a large deck are one-line small-field cards (GRID, CQUAD4, CTRIA3, CBAR ...).
For a block of lines this module finds those cards, groups them by name, and reads each
field column of a group with the vectorised readers of :mod:`femcal.deck.vecfields`. It
never reports a problem itself: every line it does not take, and every card with a field it
cannot read, is handed back to the field-by-field reader, which reads it or says what is
wrong. So the fast lane changes speed, never results (the tests check both lanes agree).

A card qualifies when its line has no tab, comma or ``$``, is at most 80 characters, its
name is in columns 1-8 without ``*``, its layout is a fixed table layout, and the next
significant line (not blank, not a comment) starts a new card. A simple free-field line (one
line, at most 8 data fields of at most 8 characters, no ``*``, ``=`` or parentheses) is first
rewritten as the small-field line it stands for, so it qualifies too.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from .spec import Column, Layout
from .vecfields import SPACES, has_byte, read_ints, read_reals, texts

_W = 80
_SPACE, _PLUS, _STAR, _DOLLAR, _TAB, _COMMA = 32, 43, 42, 36, 9, 44


@dataclass
class FastGroup:
    """Cards of one name read in the fast lane.

    ``columns`` are the layout's columns in order (arrays of length n); ``lines`` the 0-based
    index of each card's line in the block.
    """

    name: str
    columns: list[np.ndarray]
    lines: np.ndarray


@dataclass
class Block:
    """A block split into fast groups and the lines left to the field-by-field reader.

    ``stop`` is the index of the first INCLUDE or ENDDATA line (None if there is none);
    ``groups`` and ``slow`` cover only the lines before it.
    """

    groups: list[FastGroup]
    slow: np.ndarray  # 0-based indices of lines to read one by one, ascending
    stop: int | None


_COLS = 88  # 11 words of 8 bytes: field 1 in word 0, fields 2-9 in words 1-8, 73-88 after
_INCLUDE = int.from_bytes(b"INCLUDE", "little")
_LOW7 = np.uint64(0x00FFFFFFFFFFFFFF)


def split_block(lines: list[str], at_end: bool, layouts: dict[str, Layout]) -> Block:
    """Read what can be read fast in ``lines`` (bulk data, comments included).

    Parameters
    ----------
    lines : the block's lines, without newlines.
    at_end : True when no line follows the block in this file (its last card is complete).
    layouts : fixed table layouts by card name (cards not listed go to the slow lane).
    """
    n = len(lines)
    if n == 0:
        return Block([], np.zeros(0, np.int64), None)
    lines = [_small_from_free(line) if "," in line else line for line in lines]
    lens = np.fromiter(map(len, lines), np.int64, n)
    text = "".join([line[:_COLS].ljust(_COLS) for line in lines])
    up = text.encode("latin-1", "replace").upper()
    U = np.frombuffer(up, np.uint64).reshape(n, _COLS // 8)
    stop = _first_stop(lines, U, up)
    if stop is not None:
        n = stop
        U, lens, lines = U[:n], lens[:n], lines[:n]
        at_end = True
        if n == 0:
            return Block([], np.zeros(0, np.int64), stop)

    w0 = U[:, 0]
    first = (w0 & np.uint64(0xFF)).astype(np.uint8)
    blank = (U == SPACES).all(axis=1) & (lens <= _W)
    comment = first == _DOLLAR
    odd = lens > _W
    for b in (_TAB, _COMMA, _DOLLAR):
        hit = has_byte(U[:, 0], b)
        for j in range(1, 10):
            hit |= has_byte(U[:, j], b)
        odd |= hit
    significant = ~(blank | comment)
    # A line continues the card before it when its first field is blank or starts with + or *.
    cont = (w0 == SPACES) | (first == _PLUS) | (first == _STAR)
    for j in np.flatnonzero(odd & significant).tolist():
        cont[j] = _continues(lines[j])
    sig = np.flatnonzero(significant)
    if len(sig) == 0:
        return Block([], np.zeros(0, np.int64), stop)
    pos = np.searchsorted(sig, np.arange(n), side="right")
    has_next = pos < len(sig)
    # The last card of a block may go on in the next block unless the block is final.
    next_cont = np.where(has_next, cont[sig[np.minimum(pos, len(sig) - 1)]], not at_end)
    candidate = significant & ~odd & ~cont & ~next_cont & ~has_byte(w0, _STAR)

    groups: list[FastGroup] = []
    taken = np.zeros(n, bool)
    cand = np.flatnonzero(candidate)
    if len(cand):
        uniq, inverse = np.unique(w0[cand], return_inverse=True)
        for u, word in enumerate(uniq.tolist()):
            name = word.to_bytes(8, "little").decode("latin-1").strip()
            layout = layouts.get(name)
            if layout is None:
                continue
            rows = cand[inverse == u]
            columns, ok = _read_group(layout, U[rows])
            if not ok.any():
                continue
            good = rows[ok]
            groups.append(FastGroup(name, [c[ok] for c in columns], good))
            taken[good] = True
    slow = np.flatnonzero(significant & ~taken)
    return Block(groups, slow, stop)


def _small_from_free(line: str) -> str:
    """The small-field line a simple one-line free-field card stands for, or the line itself
    (left to the field-by-field reader) when it is anything else."""
    if "$" in line or "\t" in line or "=" in line or "(" in line or ")" in line:
        return line
    parts = line.split(",")
    if len(parts) > 9:  # a continuation field, or more data than one line holds
        return line
    fields = [p.strip() for p in parts]
    head = fields[0]
    if not head or head[0] in "+*" or "*" in head or max(map(len, fields)) > 8:
        return line
    return "".join(f.ljust(8) for f in fields)


def _first_stop(lines: list[str], U: np.ndarray, up: bytes) -> int | None:
    """Index of the first INCLUDE (column 1) or ENDDATA (after blanks) line, or None."""
    found = []
    if b"INCLUDE" in up:
        hits = np.flatnonzero((U[:, 0] & _LOW7) == np.uint64(_INCLUDE))
        if len(hits):
            found.append(int(hits[0]))
    at = up.find(b"ENDDATA")
    while at >= 0:
        row = at // _COLS
        if not up[row * _COLS : at].strip(b" \t"):
            found.append(row)
            break
        at = up.find(b"ENDDATA", at + 1)
    return min(found) if found else None


def _continues(line: str) -> bool:
    """Whether a line with a tab, comma, $ or more than 80 columns continues a card."""
    s = line.split("$")[0].rstrip().expandtabs(8)
    if not s:
        return False
    if "," in s:
        head = s.split(",")[0].strip()
        return not head or head[0] in "+*"
    head = s[:8].strip()
    return not head or s[0] in "+*"


def _read_group(layout: Layout, U: np.ndarray) -> tuple[list[np.ndarray], np.ndarray]:
    """Read single-line cards of one layout. U: (n, 11) uint64 words of the padded lines."""
    n = len(U)
    nslots = len(layout.slots)
    # Fields past the layout's last must be blank (else the slow lane reports them).
    ok = np.ones(n, bool)
    for k in range(nslots, 8):
        ok &= U[:, 1 + k] == SPACES
    out: list[np.ndarray] = []
    for k, slot in enumerate(layout.slots):
        field = U[:, 1 + k] if k < 8 else None
        if not slot.columns:
            if field is not None:
                ok &= field == SPACES
            continue
        if field is None:  # fields past the first line: blank on a one-line card
            for c in slot.columns:
                if c.required:
                    ok[:] = False
                out.append(np.full(n, c.default, dtype=c.dtype))
            continue
        values, good = _read_slot(slot.columns, field)
        ok &= good
        out.extend(values)
    for i, j in layout.refs:  # '=@col' defaults, e.g. PID = EID
        c = layout.columns[i]
        blank = _blank_value(c, out[i])
        out[i] = np.where(blank, out[j], out[i]).astype(c.dtype)
    return out, ok


def _blank_value(c: Column, a: np.ndarray) -> np.ndarray:
    if c.kind in ("R", "N"):
        return np.isnan(a)
    if c.kind == "S":
        return a == ""
    return a == c.default


def _read_slot(
    columns: tuple[Column, ...], field: np.ndarray
) -> tuple[list[np.ndarray], np.ndarray]:
    """Values of one field for all rows (an array per column of the slot) and the ok mask."""
    n = len(field)
    blank = field == SPACES
    vals = [np.full(n, c.default, dtype=c.dtype) for c in columns]
    assigned = blank.copy()
    for j, c in enumerate(columns):
        if c.kind == "I":
            v, good, _ = read_ints(field)
        elif c.kind == "R":
            v, good, _ = read_reals(field)
        elif c.kind == "N":
            vi, gi, _ = read_ints(field)
            vr, gr, _ = read_reals(field)
            v, good = np.where(gi, vi.astype(np.float64), vr), gi | gr
        elif c.kind == "C":
            v, good = _components(field)
        else:  # words are left to the slow lane
            continue
        take = good & ~assigned
        vals[j] = np.where(take, v, vals[j]).astype(c.dtype)
        assigned |= take
    ok = assigned
    if columns[0].required:
        ok = ok & ~blank
    return vals, ok


def _components(field: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Component codes: a lone 0, or distinct digits 1-6 in ascending order."""
    v, good, blank = read_ints(field)
    ok = good & ~blank
    rows = np.flatnonzero(ok)
    for r, t in zip(rows.tolist(), texts(field[rows]), strict=True):
        digits = t.strip()
        if digits != b"0" and not (
            digits.isdigit()
            and all(49 <= c <= 54 for c in digits)
            and all(a < b for a, b in itertools.pairwise(digits))
        ):
            ok[r] = False
    return v, ok
