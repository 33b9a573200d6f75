"""The fast lane of the bulk-data reader: single-line small-field cards, read with NumPy.

Most lines of a large deck are one-line small-field cards (GRID, CQUAD4, CTRIA3, CBAR ...).
For a block of lines this module finds those cards, groups them by name, and reads each
field column of a group with the vectorised readers of :mod:`femcal.deck.vecfields`. It
never reports a problem itself: every line it does not take, and every card with a field it
cannot read, is handed back to the field-by-field reader, which reads it or says what is
wrong. So the fast lane changes speed, never results (the tests check both lanes agree).

A card qualifies when its line has no tab, comma, NUL or ``$``, is at most 80 characters, its
name is in columns 1-8 without ``*``, its layout is a fixed table layout, and the next
significant line (not blank, not a comment) starts a new card. A simple free-field line (one
line, a name of at most 8 characters, at most 8 data fields of at most :data:`FREE_WIDTH`
characters, no ``*`` in the name, no ``$``, ``=``, parentheses or white space other than
spaces) qualifies too: the lines of a block are split into fields with NumPy
(:func:`_free_fields`), each field stripped as the field-by-field reader strips it, and read
from words of FREE_WIDTH bytes.
"""

from __future__ import annotations

import itertools
import string
from dataclasses import dataclass

import numpy as np

from .spec import Column, Layout
from .vecfields import SPACES, blank_fields, has_byte, read_ints, read_reals, texts

_W = 80
_SPACE, _PLUS, _STAR, _DOLLAR, _TAB, _COMMA, _NUL = 32, 43, 42, 36, 9, 44, 0


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
    lens = np.fromiter(map(len, lines), np.int64, n)
    text = "".join([line[:_COLS].ljust(_COLS) for line in lines])
    up = text.encode("latin-1", "replace").upper()
    U = np.frombuffer(bytearray(up), np.uint64).reshape(n, _COLS // 8)
    stop = _first_stop(lines, lens, U, up)
    if stop is not None:
        n = stop
        U, lens, lines = U[:n], lens[:n], lines[:n]
        at_end = True
        if n == 0:
            return Block([], np.zeros(0, np.int64), stop)
    # simple free-field lines: their name in word 0 (spaces after it), their data fields in
    # the wide words of ``free_data`` (row free_row[line])
    free_row = np.full(n, -1, np.int64)
    free_data = np.zeros((0, 8), np.uint64)
    free = np.flatnonzero(np.fromiter(("," in line for line in lines), bool, n))
    if len(free):
        simple, name, data = _free_fields([lines[i] for i in free.tolist()])
        rows = free[simple]
        U[rows] = SPACES
        U[rows, 0] = name[simple]
        lens[rows] = 8
        free_row[rows] = np.arange(len(rows))
        free_data = data[simple]

    w0 = U[:, 0]
    first = (w0 & np.uint64(0xFF)).astype(np.uint8)
    blank = (U == SPACES).all(axis=1) & (lens <= _W)
    comment = first == _DOLLAR
    odd = lens > _W
    # (a NUL: NumPy's byte strings drop one at a field's end, the field reader keeps it)
    for b in (_TAB, _COMMA, _DOLLAR, _NUL):
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
            columns, ok = _read_rows(layout, U, free_data, free_row, rows)
            if not ok.any():
                continue
            good = rows[ok]
            groups.append(FastGroup(name, [c[ok] for c in columns], good))
            taken[good] = True
    slow = np.flatnonzero(significant & ~taken)
    return Block(groups, slow, stop)


#: Bytes that leave a free-field line to the field-by-field reader: a comment, a tab, the
#: replication and parenthesis forms, and the white space other than spaces that its strip
#: would remove (so that a field's stripped extent is that of its spaces).
_NOT_FREE = np.frombuffer(b"\x00$\t=()\x0b\x0c\r\x1c\x1d\x1e\x1f\x85\xa0", np.uint8)
_NOT_FREE_BYTE = np.zeros(256, bool)
_NOT_FREE_BYTE[_NOT_FREE] = True
#: The longest free field the fast lane reads (a double's shortest repr takes up to 24
#: characters); longer ones are left to the field-by-field reader.
FREE_WIDTH = 32


def _free_fields(lines: list[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Simple one-line free-field cards split into their fields with NumPy.

    Returns (simple (m,) bool, name (m,) uint64: the card name's 8 bytes, data: fields 2-9,
    each stripped and left-aligned in w words of 8 bytes of spaces, w as the longest needs:
    (m, 8) uint64 for w = 1, else (m, 8, w)), upper case. A line is simple when it has no
    byte of :data:`_NOT_FREE`, at most 8 data fields (no continuation field), a name of at
    most 8 characters that is not empty, starts with neither ``+`` nor ``*`` and holds no
    ``*``, and no data field longer than FREE_WIDTH characters; the rows of other lines are
    not filled."""
    m = len(lines)
    b = np.frombuffer(("\n".join(lines) + "\n").encode("latin-1", "replace").upper(), np.uint8)
    sep = (b == 10) | (b == 44)
    seps = np.flatnonzero(sep)  # field f (over all lines) ends at seps[f]
    newline = b[seps] == 10
    # each field's line, and its place in the line (0: the name)
    f_line = np.cumsum(newline, dtype=np.int32) - newline
    line_first = np.r_[0, np.flatnonzero(newline)[:-1] + 1]  # each line's first field
    f_k = np.arange(len(seps), dtype=np.int32) - line_first[f_line]
    bad = np.zeros(m, bool)
    bad[f_line[f_k > 8]] = True  # more than 8 data fields
    # each field's stripped extent: its first and last byte that is not a space
    open_at = np.r_[0, seps[:-1] + 1]  # the field's first byte
    filled = ~sep & (b != 32)
    before = np.cumsum(filled, dtype=np.int32)  # filled bytes up to and including each
    count = before[seps] - np.r_[0, before[seps[:-1]]]  # filled bytes in each field
    at = np.flatnonzero(filled)
    if not len(at):  # (no field holds anything: every ``has`` below is False)
        at = np.zeros(1, np.int64)
    k0 = np.r_[0, before[seps[:-1]]]  # index in ``at`` of each field's first filled byte
    has = count > 0
    first = np.where(has, at[np.minimum(k0, len(at) - 1)], open_at)
    last = np.where(has, at[np.minimum(k0 + count - 1, len(at) - 1)], open_at - 1)
    length = last - first + 1
    bad[f_line[(length > FREE_WIDTH) | ((f_k == 0) & (length > 8))]] = True
    # the name: not empty, no + or * first, no * at all
    name = f_k == 0
    lead = b[first[name]]
    bad[(length[name] <= 0) | (lead == 43) | (lead == 42)] = True
    if 42 in b:
        in_field = np.searchsorted(seps, np.flatnonzero(b == 42))
        bad[f_line[in_field[f_k[in_field] == 0]]] = True
    odd = _NOT_FREE_BYTE[b]
    if odd.any():
        bad[f_line[np.searchsorted(seps, np.flatnonzero(odd))]] = True
    # the stripped fields of the simple lines, left-aligned in slots of the words the
    # longest needs
    take = ~bad[f_line] & (length > 0) & (f_k > 0)
    lo, size = first[take], length[take]
    width = 8 * max(1, -(-int(size.max()) // 8)) if len(size) else 8
    slot = f_line[take].astype(np.int64) * (8 * width) + (f_k[take] - 1) * width
    # byte j of a field: from lo + j to slot + j (fields are short: a loop over j)
    out = np.full(m * 8 * width, 32, np.uint8)
    for j in range(int(size.max()) if len(size) else 0):
        more = size > j
        if not more.all():
            slot, lo, size = slot[more], lo[more], size[more]
        out[slot + j] = b[lo + j]
    names = np.full(m * 8, 32, np.uint8)
    nk = np.flatnonzero(name)
    nl, nlo, nsize = f_line[nk].astype(np.int64) * 8, first[nk], np.maximum(length[nk], 0)
    for j in range(8):
        more = nsize > j
        names[nl[more] + j] = b[nlo[more] + j]
    data = out.view(np.uint64).reshape(m, 8, width // 8)
    return ~bad, names.view(np.uint64), data[:, :, 0] if width == 8 else data


def _first_stop(lines: list[str], lens: np.ndarray, U: np.ndarray, up: bytes) -> int | None:
    """Index of the first INCLUDE (column 1) or ENDDATA (after blanks) line, or None."""
    found = []
    if b"INCLUDE" in up:
        hits = np.flatnonzero((U[:, 0] & _LOW7) == np.uint64(_INCLUDE))
        if len(hits):
            found.append(int(hits[0]))
    rows = set()
    at = up.find(b"ENDDATA")
    while at >= 0:
        rows.add(at // _COLS)
        at = up.find(b"ENDDATA", at + 1)
    for i in np.flatnonzero(lens > _COLS).tolist():  # (text past the columns in ``up``)
        if "ENDDATA" in lines[i].upper():
            rows.add(i)
    for row in sorted(rows):
        if _ends_bulk(lines[row]):
            found.append(row)
            break
    return min(found) if found else None


_ASCII_UPPER = str.maketrans(string.ascii_lowercase, string.ascii_uppercase)


def _ends_bulk(line: str) -> bool:
    """Whether the field-by-field reader reads ``line`` as ENDDATA: its first field (free
    field: before the first comma; else columns 1-8), stripped, after the comment is cut,
    tabs expanded and ASCII letters upper-cased."""
    s = line.split("$", 1)[0].rstrip().expandtabs(8).translate(_ASCII_UPPER)
    head = s.split(",", 1)[0].strip() if "," in s else s[:8].strip()
    return head.rstrip("*") == "ENDDATA"


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


def _read_rows(layout: Layout, U: np.ndarray, free_data: np.ndarray, free_row: np.ndarray,
               rows: np.ndarray) -> tuple[list[np.ndarray], np.ndarray]:  # fmt: skip
    """Read the cards of one layout on lines ``rows``: small-field lines from their words in
    U (n, 11), free-field ones from theirs in ``free_data`` (row ``free_row[line]``)."""
    at = free_row[rows]
    wide = at >= 0
    if not wide.any():
        return _read_group(layout, U[rows, 1:9])
    if wide.all():
        return _read_group(layout, free_data[at])
    small_cols, small_ok = _read_group(layout, U[rows[~wide], 1:9])
    wide_cols, wide_ok = _read_group(layout, free_data[at[wide]])
    columns = []
    for a, b in zip(small_cols, wide_cols, strict=True):
        both = np.empty(len(rows), dtype=np.result_type(a, b))
        both[~wide], both[wide] = a, b
        columns.append(both)
    ok = np.empty(len(rows), bool)
    ok[~wide], ok[wide] = small_ok, wide_ok
    return columns, ok


def _read_group(layout: Layout, F: np.ndarray) -> tuple[list[np.ndarray], np.ndarray]:
    """Read single-line cards of one layout. F: the data fields 2-9, (n, 8) uint64 words of
    8 bytes, or (n, 8, w) of 8 w bytes."""
    n = len(F)
    nslots = len(layout.slots)
    # Fields past the layout's last must be blank (else the slow lane reports them).
    ok = np.ones(n, bool)
    for k in range(nslots, 8):
        ok &= blank_fields(F[:, k])
    out: list[np.ndarray] = []
    for k, slot in enumerate(layout.slots):
        field = F[:, k] if k < 8 else None
        if not slot.columns:
            if field is not None:
                ok &= blank_fields(field)
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
    blank = blank_fields(field)
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
