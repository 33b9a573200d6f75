"""Typed readers for NASTRAN bulk-data fields.

Fields arrive as stripped, upper-case strings ('' for blank). Each reader returns a Python
value or raises :class:`BadField` with a phrase describing what was expected.

NASTRAN number forms accepted for reals: ``1.5``, ``1.``, ``.5``, ``1.5E3``, ``1.5E+3``,
``1.5D3``, ``1.-3`` (exponent without E), ``-.5+2``, ``7.85-9``, and exponent forms whose
mantissa has no point (``1E3``, ``1D3``). A bare integer (``7``) is *not* a real: NASTRAN
rejects it in a real field, and so do we, except in fields documented as integer-or-real.
"""

from __future__ import annotations

import math
import re

import numpy as np

_EXP_NO_E = re.compile(r"^([+-]?(?:\d+\.\d*|\.\d+))([+-]\d+)$")
_REAL_D = re.compile(r"^[+-]?(?:\d+\.?\d*|\.\d+)D[+-]?\d+$")


class BadField(ValueError):
    """A field's text does not fit the field's type. ``expected`` says what would."""

    def __init__(self, expected: str):
        super().__init__(expected)
        self.expected = expected


def is_int_text(s: str) -> bool:
    """True if ``s`` is a NASTRAN integer (optional sign, ASCII digits only)."""
    if s.isdigit():
        return s.isascii()
    return len(s) > 1 and s[0] in "+-" and s[1:].isdigit() and s.isascii()


def parse_int(s: str) -> int:
    """Read an integer field. Raises BadField for anything else (including reals)."""
    if is_int_text(s):
        v = int(s)
        if -INT_LIMIT < v < INT_LIMIT:
            return v
        raise BadField(f"an integer of magnitude below 2^63 ({INT_LIMIT})")
    raise BadField("an integer")


#: Integers are stored as int64: a larger one is an error, not an overflow.
INT_LIMIT = 2**63


def _finite(v: float) -> float:
    if math.isinf(v):
        raise BadField("a real within double precision (about 1.8E+308)")
    return v


def parse_real(s: str) -> float:
    """Read a real field in any NASTRAN form. Raises BadField for integers and garbage."""
    # Fast path: Python's float() on the common forms, guarded against what it accepts
    # and NASTRAN does not ('_' separators, inf/nan words, integers without a point).
    c = s[-1:]
    if (c.isdigit() or c == ".") and "_" not in s and ("." in s or "E" in s):
        try:
            return _finite(float(s))
        except ValueError:
            pass
    m = _EXP_NO_E.match(s)
    if m:
        return _finite(float(m.group(1) + "E" + m.group(2)))
    if _REAL_D.match(s):
        return _finite(float(s.replace("D", "E")))
    if is_int_text(s):
        raise BadField("a real (with a decimal point, e.g. '7.' not '7')")
    raise BadField("a real")


def parse_number(s: str) -> int | float:
    """Read a field that may be an integer or a real."""
    if is_int_text(s):
        return int(s)
    return parse_real(s)


def is_real_text(s: str) -> bool:
    """True if ``s`` reads as a NASTRAN real."""
    try:
        parse_real(s)
    except BadField:
        return False
    return True


_COMPONENT_OK = frozenset("123456")


def parse_components(s: str) -> int:
    """Read a component code such as ``123456`` or ``0``: distinct digits 1-6 (or a lone 0).

    Returned as the integer the digits spell (``'135'`` -> 135), sorted ascending as NASTRAN
    treats them.
    """
    if s == "0":
        return 0
    if s and s.isdigit() and set(s) <= _COMPONENT_OK and len(set(s)) == len(s):
        return int("".join(sorted(s)))
    raise BadField("a component code of distinct digits 1-6 (e.g. 123456), or 0")


def parse_string(s: str) -> str:
    """Read a character field (starts with a letter, at most 8 characters)."""
    if s and s[0].isalpha() and s.isascii():
        return s
    raise BadField("a word starting with a letter")


def components_to_list(code: int) -> list[int]:
    """Component code 135 -> [1, 3, 5]; 0 -> [0]."""
    return [int(c) for c in str(code)]


# --------------------------------------------------------------------------- writing


def format_real(x: float, width: int = 16, *, exact: bool = False) -> str:
    """Shortest NASTRAN text for ``x`` that fits ``width`` characters.

    Uses Python's shortest round-trip representation when it fits (so any value read from
    a deck is written back exactly), else the most significant digits that fit, or, with
    ``exact=True``, raises ValueError.
    """
    if not math.isfinite(x):
        raise ValueError(f"cannot write {x!r} to a NASTRAN field")
    r = repr(float(x))
    s = _compact(r)
    if len(s) <= width:
        return s
    if exact:
        raise ValueError(f"{x!r} does not fit {width} characters exactly")
    # The most precise text that fits: exponent or positional form, whichever keeps more digits.
    best, best_err = None, math.inf
    for digits in range(17, -1, -1):
        for text in (f"{x:.{digits}E}", f"{x:.{digits}f}"):
            c = _compact(text)
            if len(c) <= width:
                err = abs(_to_python(c) - x)
                if err < best_err:
                    best, best_err = c, err
    if best is None:
        raise ValueError(f"cannot write {x!r} in {width} characters")
    return best


def _to_python(c: str) -> float:
    """Float value of a compact NASTRAN real (``'1.5-5'`` -> 1.5e-05)."""
    m = _EXP_NO_E.match(c)
    return float(m.group(1) + "E" + m.group(2)) if m else float(c)


def _compact(r: str) -> str:
    """'1.5e-05' -> '1.5-5', '100.0' -> '100.', '1e+20' -> '1.+20' (NASTRAN compact form)."""
    r = r.upper()
    if "E" in r:
        mant, exp = r.split("E")
        if "." not in mant:
            mant += "."
        mant = mant.rstrip("0") if "." in mant else mant
        e = int(exp)
        if e == 0:
            return _strip_point_zero(mant)
        return f"{mant}{'+' if e > 0 else '-'}{abs(e)}"
    return _strip_point_zero(r if "." in r else r + ".")


def _strip_point_zero(m: str) -> str:
    if "." in m:
        m = m.rstrip("0")
    if m.startswith("0.") and len(m) > 2:
        m = m[1:]
    elif m.startswith("-0.") and len(m) > 3:
        m = "-" + m[2:]
    return m


def format_value(v: object, width: int = 16, *, exact: bool = False) -> str:
    """Text of one field value: None -> blank, int, float or str; ValueError if it won't fit."""
    if v is None:
        return ""
    if isinstance(v, bool):
        raise TypeError("booleans are not NASTRAN field values")
    if isinstance(v, (int, np.integer)):
        s = str(int(v))
    elif isinstance(v, (float, np.floating)):
        s = format_real(float(v), width, exact=exact)
    else:
        s = str(v)
    if len(s) > width:
        raise ValueError(f"value {v!r} does not fit a {width}-character field")
    return s
