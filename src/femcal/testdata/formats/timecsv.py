"""Time histories as CSV: a column of sample times, then one column per channel.

The layout (what :func:`write_time_csv` writes; :func:`read_time_csv` reads it and the usual
exports of lab tools)::

    time_s,Act 1 disp,Act 1 force
    # units: mm, N
    0.0,0.125,-3.5
    0.001953125,0.25,-3.25

* The header row: the first column ``time_s`` (or ``time``; ``time [s]`` too), then each
  channel's name, CSV-quoted when it holds a comma or a quote. Names are stripped of
  surrounding blanks; each is given once.
* The units, the primary way: a comment line ``# units: U1, U2, ...`` right after the header
  row (before it is read as well), one unit per channel (or one more, a first ``s`` for the
  time column), CSV-quoted when a unit holds a comma; ``""`` for a channel without one. The
  writer writes the line when a channel has a unit. Without a units line, a header cell
  ``name [unit]`` gives the channel's name and unit (``Force [N]``), as some lab tools write
  it; a plain ``name`` has no unit.
* Then one row per sample: its time in seconds and each channel's value. Every line ends
  with a line break (a last line without one is taken for a file cut short). Blank lines,
  ``#`` comment lines and ``# ...`` after the numbers are skipped.
* The times are evenly spaced: the step dt is the mean step (t_last - t_first) / (rows - 1)
  (the first step, when the first time is 0 and the two agree to rounding, so that a file
  femcal wrote gives its dt back bit for bit), and every step must be within
  :data:`STEP_RTOL` (1e-6) of dt. The first time need not be 0, but it is not kept:
  :class:`~femcal.testdata.timedata.TimeData` counts time from the first sample.
* Values: float64 data are written as Python's ``repr`` (the shortest text that reads back
  as the same number: float64 data round trip exactly), float32 data as ``%.9g`` (exact for
  float32); only finite numbers.

:attr:`TimeData.header <femcal.testdata.timedata.TimeData.header>` is not stored (the reader
gives ``{}``).
"""

from __future__ import annotations

import csv
import io
import os
import re
from collections.abc import Callable
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ...atomic import write_atomic
from ...errors import TimeDataError
from ..timedata import TimeData
from .registry import Format, register

#: Largest relative difference between a time step and dt.
STEP_RTOL = 1e-6
#: Names the time column may have (compared in lower case).
TIME_COLUMNS = ("time_s", "time")
#: A ``# units: ...`` comment line; group 1 is the list.
_UNITS = re.compile(r"#\s*units\s*:(.*)", re.IGNORECASE)
#: The same, found anywhere in the text (a units line among the rows).
_UNITS_ANYWHERE = re.compile(r"^[ \t]*#[ \t]*units[ \t]*:", re.IGNORECASE | re.MULTILINE)
#: A header cell ``name [unit]``.
_NAME_UNIT = re.compile(r"(.*?)\s*\[([^\[\]]*)\]")
#: Rows formatted per write call.
_CHUNK = 4096


def read_time_csv(path: str | os.PathLike[str], *, rtol: float = STEP_RTOL) -> TimeData:
    """Read a time-history CSV (see the module docstring for the layout).

    Parameters
    ----------
    path : the file (UTF-8, with or without a byte-order mark).
    rtol : largest relative difference between a time step and dt.

    Raises
    ------
    TimeDataError
        Naming the file and line (and the column): an empty file, a last line without a line
        break, a first column that is not ``time_s``, a channel without a name or named twice,
        a units line that does not give one unit per channel, a row with too few or too many
        fields, a field that is not a number or not finite, fewer than two rows, times that
        do not increase or are not evenly spaced.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as e:
        raise TimeDataError(f"{path}: not UTF-8 text (byte {e.start}: {e.reason}); expected "
                            "a CSV file of times and channel values") from None  # fmt: skip
    if not text.strip():
        raise TimeDataError(f"{path}: empty; expected a header row time_s,NAME,... and one "
                            "row per sample")  # fmt: skip
    if not text.endswith("\n"):  # a writer ends every row; a cut file does not
        raise TimeDataError(f"{path}:{text.count(chr(10)) + 1}: the last line does not end with "
                            "a line break: is the file cut short? (if the line is whole, end "
                            "it with a line break)")  # fmt: skip
    lines = text.split("\n")
    head = _head(path, lines)
    names, units, first = head.names, head.units, head.first_row
    n_cols = len(names) + 1
    later = _UNITS_ANYWHERE.search(text, sum(len(s) + 1 for s in lines[:first]))
    if later is not None:
        raise TimeDataError(f"{path}:{text.count(chr(10), 0, later.start()) + 1}: a units line "
                            f"among the rows; expected it right after the header (line "
                            f"{head.header_line})")  # fmt: skip
    row_lines: np.ndarray | None = None
    if first < len(lines):  # there is a row (loadtxt would warn of an empty input otherwise)
        try:
            table = np.loadtxt(io.StringIO(text), delimiter=",", comments="#", skiprows=first,
                               ndmin=2, dtype=np.float64)  # fmt: skip
        except ValueError:  # find the line and column, and read what loadtxt would not
            table, row_lines = _parse(path, lines, first, names)
    else:
        table = np.empty((0, n_cols))

    def line_of(row: int) -> int:
        nonlocal row_lines
        if row_lines is None:
            row_lines = _row_lines(lines, first)
        return int(row_lines[row])

    if table.shape[1] != n_cols:  # every row alike, but not as the header says
        few = "too few" if table.shape[1] < n_cols else "too many"
        raise TimeDataError(f"{path}:{line_of(0)}: {table.shape[1]} fields ({few}); expected "
                            f"{n_cols}: time_s and {len(names)} channel"
                            f"{'s' * (len(names) != 1)}")  # fmt: skip
    n = table.shape[0]
    if n < 2:
        raise TimeDataError(f"{path}:{head.header_line}: {n} row{'s' * (n != 1)} after the "
                            "header; expected one row per sample, at least two to give the "
                            "time step")  # fmt: skip
    bad = np.flatnonzero(~np.isfinite(table).all(axis=1))
    if bad.size:
        r = int(bad[0])
        c = int(np.flatnonzero(~np.isfinite(table[r]))[0])
        raise TimeDataError(f"{path}:{line_of(r)}: column {c + 1} ({_column(c, names)}) is "
                            f"{float(table[r, c])!r}; expected a finite number")  # fmt: skip
    t = table[:, 0]
    dt = _step(path, t, rtol, line_of)
    values = np.ascontiguousarray(table[:, 1:].T)
    return TimeData(dt, values, tuple(names), tuple(units))


class _Head(NamedTuple):
    """What precedes the rows: the channels' names and units, the header's line number
    (1-based) and the index (0-based) of the first row's line."""

    names: list[str]
    units: list[str]
    header_line: int
    first_row: int


def _head(path: Path, lines: list[str]) -> _Head:
    """Find the header row and the units line (comment lines and blank lines around them are
    skipped); TimeDataError naming the line for a bad one."""
    header: list[str] | None = None
    header_line = 0
    units: tuple[list[str], int] | None = None  # the units and their line
    k = 0
    for k, line in enumerate(lines):
        s = line.strip()
        if not s or s.startswith("#"):
            m = _UNITS.match(s)
            if m is not None:
                if units is not None:
                    raise TimeDataError(f"{path}:{k + 1}: a second units line (the first on "
                                        f"line {units[1]}); expected one")  # fmt: skip
                units = (_fields(m.group(1), path, k + 1), k + 1)
            continue
        if header is not None:  # the first row
            break
        header, header_line = _fields(line, path, k + 1), k + 1
    else:
        k = len(lines)
    if header is None:
        raise TimeDataError(f"{path}: no header row; expected time_s,NAME,... and one row per "
                            "sample")  # fmt: skip
    time_name, time_unit = _name_unit(header[0])
    if time_name.lower() not in TIME_COLUMNS or time_unit not in ("", "s"):
        raise TimeDataError(f"{path}:{header_line}: column 1 is {header[0]!r}; expected time_s "
                            "(the sample times in s), then one column per channel")  # fmt: skip
    cells = header[1:]
    if not cells:
        raise TimeDataError(f"{path}:{header_line}: no channel columns; expected time_s, then "
                            "one column per channel")  # fmt: skip
    if units is None:
        pairs = [_name_unit(c) for c in cells]
        names, unit_list = [p[0] for p in pairs], [p[1] for p in pairs]
    else:
        names, (unit_list, units_line) = cells, units
        if len(unit_list) == len(cells) + 1 and unit_list[0] in ("s", ""):
            unit_list = unit_list[1:]  # the time column's
        if len(unit_list) != len(cells):
            raise TimeDataError(f"{path}:{units_line}: {len(unit_list)} units for "
                                f"{len(cells)} channels; expected '# units: U1, U2, ...' "
                                "with one unit per channel (an empty one for none)")  # fmt: skip
    seen: dict[str, int] = {}
    for c, name in enumerate(names, 2):
        if not name:
            raise TimeDataError(f"{path}:{header_line}: column {c} has no name; expected each "
                                "channel's name in the header")  # fmt: skip
        if name in seen:
            raise TimeDataError(f"{path}:{header_line}: column {c} is named {name!r} like column "
                                f"{seen[name]}; expected each channel name once")  # fmt: skip
        seen[name] = c
    return _Head(names, unit_list, header_line, k)


def _fields(text: str, path: Path, line: int) -> list[str]:
    """One line's CSV fields, stripped of blanks (``[""]`` for an empty line)."""
    try:
        row = next(csv.reader([text], skipinitialspace=True), [])
    except csv.Error as e:
        raise TimeDataError(f"{path}:{line}: not CSV ({e})") from None
    return [f.strip() for f in row] or [""]


def _name_unit(cell: str) -> tuple[str, str]:
    """``"Force [N]"`` -> ``("Force", "N")``; a cell without ``[unit]`` has no unit."""
    m = _NAME_UNIT.fullmatch(cell)
    return (m.group(1), m.group(2).strip()) if m else (cell, "")


def _column(c: int, names: list[str]) -> str:
    """How a message names column ``c`` (0-based): ``time_s`` or the channel's name."""
    return "time_s" if c == 0 else repr(names[c - 1])


def _row_lines(lines: list[str], first: int) -> np.ndarray:
    """The line numbers (1-based) of the rows: the lines from ``first`` on that hold more
    than blanks and a comment."""
    return np.array([k + 1 for k in range(first, len(lines))
                     if lines[k].partition("#")[0].strip()], dtype=np.int64)  # fmt: skip


def _parse(path: Path, lines: list[str], first: int,
           names: list[str]) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """The rows read one by one (quoted numbers, blank lines taken), with their line
    numbers; TimeDataError naming the line and column of the first bad field."""
    n_cols = len(names) + 1
    rows: list[list[float]] = []
    at: list[int] = []
    for k in range(first, len(lines)):
        text = lines[k].partition("#")[0]
        if not text.strip():
            continue
        fields = _fields(text, path, k + 1)
        if len(fields) != n_cols:
            few = "too few" if len(fields) < n_cols else "too many"
            raise TimeDataError(f"{path}:{k + 1}: {len(fields)} fields ({few}); expected "
                                f"{n_cols}: time_s and {len(names)} channel"
                                f"{'s' * (len(names) != 1)}")  # fmt: skip
        row = []
        for c, f in enumerate(fields):
            try:
                if "_" in f:
                    raise ValueError(f)
                row.append(float(f))
            except ValueError:
                raise TimeDataError(f"{path}:{k + 1}: column {c + 1} ({_column(c, names)}): "
                                    f"{f!r} is not a number") from None  # fmt: skip
        rows.append(row)
        at.append(k + 1)
    return np.array(rows, dtype=np.float64).reshape(-1, n_cols), np.array(at, dtype=np.int64)


def _step(path: Path, t: np.ndarray, rtol: float, line_of: Callable[[int], int]) -> float:
    """The time step of the times ``t`` (evenly spaced within ``rtol``); TimeDataError naming
    the line of the first step that is not."""
    steps = np.diff(t)
    dt = float((t[-1] - t[0]) / (len(t) - 1))
    back = np.flatnonzero(steps <= 0)
    if back.size:
        k = int(back[0])
        raise TimeDataError(f"{path}:{line_of(k + 1)}: time {float(t[k + 1])!r} s is not after "
                            f"{float(t[k])!r} s (line {line_of(k)}); expected increasing, "
                            "evenly spaced times")  # fmt: skip
    odd = np.flatnonzero(np.abs(steps - dt) > rtol * dt)
    if odd.size:
        k = int(odd[0])
        raise TimeDataError(f"{path}:{line_of(k + 1)}: time step {float(steps[k]):.9g} s from "
                            f"line {line_of(k)} (t = {float(t[k])!r} to {float(t[k + 1])!r}); "
                            f"expected evenly spaced times, every step within {rtol:g} of "
                            f"the mean step {dt:.9g} s")  # fmt: skip
    if t[0] == 0 and abs(t[1] - dt) <= 1e-12 * dt:
        dt = float(t[1])  # the exact step of times written as k * dt (femcal's writer)
    return dt


def write_time_csv(path: str | os.PathLike[str], data: TimeData) -> Path:
    """Write ``data`` as a time-history CSV (see the module docstring), atomically: the
    header ``time_s,NAME,...``, a ``# units: U1, U2, ...`` line when a channel has a unit,
    and one row per sample.

    Raises
    ------
    TimeDataError
        For data that the file could not give back: fewer than two samples, a channel
        without a name or with a line break in its name or unit, a name given twice, or
        samples that are NaN or infinite.
    """
    v = np.asarray(data.values)
    n_ch, n = v.shape
    if n < 2:
        raise TimeDataError(f"{n} sample{'s' * (n != 1)}: a time-history CSV needs at least "
                            "two (its time column gives the step)")  # fmt: skip
    if n_ch == 0:
        raise TimeDataError("no channels: a time-history CSV needs at least one")
    seen: dict[str, int] = {}
    for c, (name, unit) in enumerate(zip(data.names, data.units, strict=True)):
        if not name.strip():
            raise TimeDataError(f"channel {c + 1} has no name; a time-history CSV names each "
                                "channel in its header")  # fmt: skip
        if any(ch in name + unit for ch in "\r\n"):
            raise TimeDataError(f"channel {name!r}: a line break in its name or unit "
                                f"({unit!r}); a CSV header holds one line")  # fmt: skip
        if name.strip() in seen:
            raise TimeDataError(f"channels {seen[name.strip()] + 1} and {c + 1} are both named "
                                f"{name.strip()!r}; a time-history CSV needs each name "
                                "once")  # fmt: skip
        seen[name.strip()] = c
    finite = np.isfinite(v)
    if not finite.all():
        c = int(np.flatnonzero(~finite.all(axis=1))[0])
        k = int(np.flatnonzero(~finite[c])[0])
        raise TimeDataError(f"channel {data.names[c]!r} sample {k} is {float(v[c, k])!r}; a "
                            "time-history CSV holds finite numbers")  # fmt: skip
    single = v.dtype == np.float32
    values = v if single else v.astype(np.float64, copy=False)
    write_units = any(data.units) or any(_NAME_UNIT.fullmatch(s.strip()) for s in data.names)
    t = data.time

    def dump(tmp: str) -> None:
        with open(tmp, "w", encoding="utf-8", newline="\n") as fh:
            csv.writer(fh, lineterminator="\n").writerow(["time_s", *data.names])
            if write_units:
                fh.write(f"# units: {', '.join(_quote(u) for u in data.units)}\n")
            for a in range(0, n, _CHUNK):
                times = t[a:a + _CHUNK].tolist()
                block = values[:, a:a + _CHUNK].T
                if single:
                    rows = (",".join([f"{x:.9g}" for x in r]) for r in block.tolist())
                else:
                    rows = (",".join(map(repr, r)) for r in block.tolist())
                fh.write("".join(f"{tk!r},{r}\n" for tk, r in zip(times, rows, strict=True)))

    return write_atomic(path, dump)


def _quote(text: str) -> str:
    """A unit as a field of the units line: CSV-quoted when it holds a comma or a quote."""
    if any(ch in text for ch in ',"'):
        return '"' + text.replace('"', '""') + '"'
    return text


register(Format("csv", "time", (".csv",), read_time_csv, write_time_csv,
                "CSV, a time_s column and one per channel"))  # fmt: skip
