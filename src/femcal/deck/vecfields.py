"""Column readers of NASTRAN fields, for the reader's fast lane.

A field column arrives as an ``(n,)`` uint64 array, each element the field's 8 bytes
(upper-case text padded with spaces) in memory order, or as an ``(n, w)`` array of w such
words for a wider field (a free-field card's field of up to 8 w characters). Whole-column
tests work on 8 bytes at once with the usual SWAR (SIMD within a register) tricks; the
conversion itself is Python's ``int()`` and ``float()`` mapped over the column's texts (C
loops, no per-field Python code).

Each reader returns ``(values, ok, blank)``. ``ok[i]`` is False where the text is blank or
not a valid field of that type; the fast lane then leaves that card to the field-by-field
readers of :mod:`femcal.deck.fields`, which read it or say what is wrong. Values equal those
of :func:`~femcal.deck.fields.parse_int` and :func:`~femcal.deck.fields.parse_real` (the
tests check this). Guards cover what ``int()``/``float()`` accept and NASTRAN does not: ``_``
digit separators, and reals with neither a point nor an exponent letter (``7``, ``INF``,
``NAN``). NASTRAN forms ``float()`` rejects (``1.-3``, ``1.5D3``) are read one by one by
:func:`~femcal.deck.fields.parse_real`.
"""

from __future__ import annotations

import numpy as np

from .fields import BadField, parse_real

ONES = np.uint64(0x0101010101010101)
HIGHS = np.uint64(0x8080808080808080)
SPACES = np.uint64(0x2020202020202020)


def has_byte(v: np.ndarray, byte: int) -> np.ndarray:
    """(n,) bool: whether any of the 8 bytes of each element equals ``byte``."""
    t = v ^ (ONES * np.uint64(byte))
    return ((t - ONES) & ~t & HIGHS) != 0


def any_byte(v: np.ndarray, byte: int) -> np.ndarray:
    """(n,) bool: whether a field of the column (of one word or several) holds ``byte``."""
    hit = has_byte(v, byte)
    return hit if hit.ndim == 1 else hit.any(axis=1)


def blank_fields(v: np.ndarray) -> np.ndarray:
    """(n,) bool: whether each field of the column (of one word or several) is all spaces."""
    same = v == SPACES
    return same if same.ndim == 1 else same.all(axis=1)


def texts(v: np.ndarray) -> list[bytes]:
    """The texts (8 bytes a word) of a uint64 field column of one word or several."""
    v = np.ascontiguousarray(v)
    width = 8 * (v.shape[1] if v.ndim == 2 else 1)
    return v.view(f"S{width}").reshape(len(v)).tolist()


def read_ints(v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Integer fields (optional sign, digits). Returns (values int64, ok, blank), each (n,)."""
    n = len(v)
    blank = blank_fields(v)
    values = np.zeros(n, np.int64)
    ok = np.zeros(n, bool)
    rows = np.flatnonzero(~blank & ~any_byte(v, ord("_")))
    if len(rows) == 0:
        return values, ok, blank
    words = texts(v[rows])
    try:
        values[rows] = list(map(int, words))
        ok[rows] = True
    except (ValueError, OverflowError):
        for r, t in zip(rows.tolist(), words, strict=True):
            try:
                values[r] = int(t)
                ok[r] = True
            except (ValueError, OverflowError):
                pass
    ok &= values != np.iinfo(np.int64).min  # -2^63: beyond the field reader's magnitude
    return values, ok, blank


def read_reals(v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Real fields in every NASTRAN form. Returns (values float64, ok, blank), each (n,)."""
    n = len(v)
    blank = blank_fields(v)
    values = np.zeros(n, np.float64)
    ok = np.zeros(n, bool)
    candidate = ~blank & ~any_byte(v, ord("_"))
    pointed = candidate & (any_byte(v, ord(".")) | any_byte(v, ord("E")))
    rows = np.flatnonzero(pointed)
    if len(rows):
        words = texts(v[rows])
        try:
            values[rows] = list(map(float, words))
            ok[rows] = True
        except ValueError:
            for r, t in zip(rows.tolist(), words, strict=True):
                try:
                    values[r] = float(t)
                    ok[r] = True
                except ValueError:
                    ok[r] = _nastran_form(t, values, r)
    # What float() cannot read and needs no point or E: '1D3' (or is not a real at all).
    rest = np.flatnonzero(candidate & ~pointed)
    for r, t in zip(rest.tolist(), texts(v[rest]), strict=True):
        ok[r] = _nastran_form(t, values, r)
    ok &= ~np.isinf(values)  # beyond double precision: the field reader says so
    return values, ok, blank


def _nastran_form(t: bytes, values: np.ndarray, r: int) -> bool:
    try:
        values[r] = parse_real(t.decode("latin-1").strip())
    except BadField:
        return False
    return True
