"""A check of a MATLAB 5 file's elements, made before SciPy reads it.

SciPy's MATLAB 5 reader (``scipy.io.loadmat``, C code in ``_mio5_utils``) looks up the data
type code of each number or character element in a table without checking it: a damaged
file with a code the table lacks (0, 8, 10, 11, 14, 15, 19 or more) makes it read through a
null or stray pointer and kills the process, and so does a character array without
dimensions (its conversion to strings reads the last one unchecked); SciPy's docstring says
the reader is not hardened against untrusted input. This module walks a file's elements the
way SciPy's reader consumes them and refuses, with the byte offset, an element SciPy would
misread in these ways, or a cell, struct or character array whose dimensions claim more
elements than the data could hold (SciPy allocates them first); any other damage is left to
SciPy, whose errors for it are clean exceptions.

The layout (MathWorks, "MAT-File Format", version 5): a 128-byte header (text, subsystem
offset, version 0x0100, endian indicator ``IM`` little or ``MI`` big), then variables, each
an 8-byte tag (type code, byte count) and its data: a matrix (``miMATRIX``), or compressed
data (``miCOMPRESSED``) that inflate to one. A matrix holds array flags (class, complex),
dimensions and a name, then its class's parts: real and imaginary numbers, characters,
sparse indices and values, or cells and struct fields, each itself a matrix. Elements
inside a matrix are padded to 8 bytes; a small element packs its byte count (1-4) into the
tag's upper 16 bits and its data into the tag's second word.
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

from ..data import FRFError

#: Element type codes.
MI_INT8, MI_INT32, MI_UINT32, MI_MATRIX, MI_COMPRESSED, MI_UTF8 = 1, 5, 6, 14, 15, 16
#: The type codes SciPy's table of element types holds (reading any other is the crash).
TABLE = frozenset({1, 2, 3, 4, 5, 6, 7, 9, 12, 13, 16, 17, 18})
#: Array classes (mxCELL_CLASS ... mxOPAQUE_CLASS) and the numeric ones.
CELL, STRUCT, OBJECT, CHAR, SPARSE, FUNCTION, OPAQUE = 1, 2, 3, 4, 5, 16, 17
NUMERIC = frozenset(range(6, 16))
#: Nesting deeper than this is refused (each level is a cell or a struct field).
MAX_DEPTH = 64


class _Damaged(Exception):
    """An element SciPy would misread: its byte offset (in the file, or in the inflated data
    of a compressed variable) and what is wrong."""

    def __init__(self, offset: int, what: str):
        self.offset = offset
        super().__init__(what)


class _Stream:
    """A cursor over bytes that reads elements as SciPy's ``VarReader5`` does."""

    def __init__(self, buf: bytes, order: str, pos: int = 0):
        self.buf, self.order, self.pos = buf, order, pos

    def take(self, n: int) -> bytes:
        if n > len(self.buf) - self.pos:
            raise _Damaged(self.pos, f"the data end {n} bytes short (cut short?)")
        out = self.buf[self.pos:self.pos + n]
        self.pos += n
        return out

    def words(self) -> tuple[int, int]:
        return struct.unpack(self.order + "II", self.take(8))

    def element(self) -> tuple[int, int, bytes]:
        """(offset, type code, data) of the next element, small or full; full elements are
        followed by padding to 8 bytes."""
        at = self.pos
        code, count = self.words()
        if code >> 16:  # small data element
            code, small = code & 0xFFFF, code >> 16
            if small > 4:
                raise _Damaged(at, f"a small element of {small} bytes (at most 4)")
            return at, code, self.buf[at + 4:at + 4 + small]
        data = self.take(count)
        self.pos += -count % 8
        return at, code, data


def _numbers(s: _Stream, what: str) -> bytes:
    """A number (or character) element whose type code SciPy looks up in its table."""
    at, code, data = s.element()
    if code not in TABLE:
        raise _Damaged(at, f"{what} of type code {code}; expected one of {sorted(TABLE)}")
    return data


def _int8_string(s: _Stream, what: str) -> bytes:
    at, code, data = s.element()
    if code not in (MI_INT8, MI_UTF8):
        raise _Damaged(at, f"{what} of type code {code}; expected {MI_INT8} (miINT8)")
    return data


def _int32s(s: _Stream, what: str) -> list[int]:
    at, code, data = s.element()
    if code not in (MI_INT32, MI_UINT32):
        raise _Damaged(at, f"{what} of type code {code}; expected {MI_INT32} (miINT32)")
    return list(struct.unpack(f"{s.order}{len(data) // 4}i", data[: len(data) // 4 * 4]))


def _matrix(s: _Stream, depth: int, tag: str = "inner") -> None:
    """Walk one matrix as SciPy reads it: ``tag`` "inner" for one inside another (its tag
    first; 0 bytes is an empty matrix), "top" for a compressed variable's (its tag first),
    "none" for an uncompressed variable's (the tag already read)."""
    at = s.pos
    if depth > MAX_DEPTH:
        raise _Damaged(at, f"matrices nested more than {MAX_DEPTH} deep")
    if tag != "none":
        code, count = s.words()
        if code != MI_MATRIX:
            raise _Damaged(at, f"an element of type code {code} where a matrix ({MI_MATRIX}) "
                           "belongs")  # fmt: skip
        if count == 0 and tag == "inner":
            return
    s.take(8)  # the array flags' tag (SciPy does not look at it)
    flags = struct.unpack(s.order + "I", s.take(8)[:4])[0]
    cls, complex_ = flags & 0xFF, bool(flags >> 11 & 1)
    if cls == OPAQUE:
        _int8_string(s, "the name")
        _int8_string(s, "the type system")
        _int8_string(s, "the class name")
        _matrix(s, depth + 1)
        return
    dims = _int32s(s, "the dimensions")
    _int8_string(s, "the name")
    if any(d < 0 for d in dims):
        raise _Damaged(at, f"dimensions {dims}; expected no negative one")
    count = 1
    for d in dims:
        count *= d
    if cls in NUMERIC:
        for _ in range(2 if complex_ else 1):
            _numbers(s, "the numbers")
    elif cls == SPARSE:
        for _ in range(4 if complex_ else 3):
            _numbers(s, "the sparse indices or values")
    elif cls == CHAR:
        if not dims:  # SciPy's chars_to_strings reads the last dimension unchecked
            raise _Damaged(at, "a character array without dimensions")
        if count > len(s.buf):  # an empty element makes SciPy allocate them as blanks
            raise _Damaged(at, f"dimensions {dims} claim more characters than the file holds")
        _numbers(s, "the characters")
    elif cls in (CELL, STRUCT, OBJECT):
        names = 1
        if cls == OBJECT:
            _int8_string(s, "the class name")
        if cls in (STRUCT, OBJECT):
            names = _field_names(s)
        if count * names * 8 > len(s.buf) - s.pos:  # SciPy allocates them before reading
            raise _Damaged(at, f"dimensions {dims} (x {names} fields) claim more elements "
                           f"than the {len(s.buf) - s.pos} bytes left can hold")  # fmt: skip
        for _ in range(count * names):
            _matrix(s, depth + 1)
    elif cls == FUNCTION:
        _matrix(s, depth + 1)


def _field_names(s: _Stream) -> int:
    """Walk a struct's field name length and names; the number of fields."""
    at = s.pos
    length = _int32s(s, "the field name length")
    if len(length) != 1 or length[0] <= 0:
        raise _Damaged(at, f"field name length {length}; expected one positive number")
    return len(_int8_string(s, "the field names")) // length[0]


def _variables(raw: bytes, order: str) -> None:
    """Walk the variables after the 128-byte header as SciPy's ``get_variables`` does."""
    s = _Stream(raw, order, 128)
    while s.pos < len(raw):
        at = s.pos
        code, count = s.words()
        if count == 0:
            raise _Damaged(at, "a variable of 0 bytes")
        following = s.pos + count
        if code == MI_COMPRESSED:
            try:
                inner = zlib.decompressobj().decompress(s.take(count))
            except zlib.error as e:
                raise _Damaged(at, f"compressed data that do not inflate ({e})") from None
            try:
                _matrix(_Stream(inner, order), 0, "top")
            except _Damaged as e:
                raise _Damaged(at, f"in the compressed variable, at its byte {e.offset}: {e}"
                               ) from None  # fmt: skip
        elif code == MI_MATRIX:
            _matrix(s, 0, "none")
        else:
            raise _Damaged(at, f"a variable of type code {code}; expected a matrix "
                           f"({MI_MATRIX}) or compressed data ({MI_COMPRESSED})")
        s.pos = following


def check_mat5(path: str | Path) -> None:
    """Refuse a MATLAB 5 file that SciPy would misread in the ways the module docstring
    names; other files (MATLAB 4, 7.3, not MATLAB at all) are left to SciPy, which refuses
    them cleanly.

    Raises
    ------
    FRFError
        Naming the file, the byte offset of the element and what is wrong with it.
    """
    raw = Path(path).read_bytes()
    # SciPy's test of the version: MATLAB 4 has a zero in its first 4 bytes; otherwise the
    # byte at 124 or 125 (by the endian indicator) is the major version, 1 for MATLAB 5
    if len(raw) < 128 or 0 in raw[:4] or raw[124 + (raw[126] == ord("I"))] != 1:
        return
    order = "<" if raw[126:128] == b"IM" else ">"
    try:
        _variables(raw, order)
    except _Damaged as e:
        raise FRFError(f"{path}: byte {e.offset}: {e}; the MATLAB file is damaged (expected "
                       "MATLAB 5 data elements)") from None
