"""Sensor and input position files: CSV tables of the points a test measures or excites.

::

    label,grid,x,y,z,directions
    L01,39,50,430,127.5,123

``directions`` lists direction codes (1-3 translations along X, Y, Z, 4-6 rotations; 123
is a triaxial sensor) or gives one signed code (``-1``: along -X), or a ``direction``
column gives one signed code. A channel's label
is ``GRID:+X`` (:func:`point_label`); :func:`channel_names` gives each channel the sensor's
own name, for pictures and reports.
"""

from __future__ import annotations

import csv
from pathlib import Path

from ..errors import ConfigError


def read_points(path: str | Path) -> list[tuple[str, int, int]]:
    """(label, grid, direction) rows of a sensors or inputs CSV (``directions`` 123 expands
    to three rows labelled GRID:+X, +Y, +Z; a signed ``direction`` gives one).

    Raises
    ------
    ConfigError
        Naming the file and line of a missing column, a short row, a field that is not a
        number or text that is not UTF-8 (a ValueError too).
    """
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            return _points(path, csv.DictReader(fh))
    except UnicodeDecodeError as e:
        raise ConfigError(f"{path}: not UTF-8 text (byte {e.start}): expected a CSV table of "
                          "label, grid and directions") from None  # fmt: skip
    except csv.Error as e:
        raise ConfigError(f"{path}: {e}: expected a CSV table") from None


def _points(path: str | Path, reader: csv.DictReader) -> list[tuple[str, int, int]]:
    fields = reader.fieldnames or []
    dir_col = "directions" if "directions" in fields else "direction"
    missing = [c for c in ("label", "grid", dir_col) if c not in fields]
    if missing:
        raise ConfigError(f"{path}:1: missing column(s) {', '.join(missing)}; expected "
                          "label, grid and directions (or direction)")  # fmt: skip
    out = []
    for row in reader:
        line = reader.line_num
        if any(row[c] is None for c in ("label", "grid", dir_col)):
            raise ConfigError(f"{path}:{line}: a short row; expected label, grid and "
                              f"{dir_col}")  # fmt: skip
        try:
            g = int(row["grid"])
            text = row[dir_col].strip()
            signed = dir_col == "direction" or text[:1] in ("+", "-")
            codes = [int(text)] if signed else [int(c) for c in text]
        except ValueError:
            raise ConfigError(f"{path}:{line}: grid {row['grid']!r} and {dir_col} "
                              f"{row[dir_col]!r} must be integers") from None  # fmt: skip
        if not codes or any(not 1 <= abs(c) <= 6 for c in codes):
            raise ConfigError(f"{path}:{line}: {dir_col} {text!r}: expected codes 1-6")
        out += [(row["label"], g, c) for c in codes]
    return out


def point_label(grid: int, code: int) -> str:
    """The channel label of a grid and direction code (``455:+Z``, ``12:-RX``)."""
    axis = "XYZ"[abs(code) - 1] if abs(code) <= 3 else f"R{'XYZ'[abs(code) - 4]}"
    return f"{grid}:{'-' if code < 0 else '+'}{axis}"


def channel_names(path: str | Path) -> dict[str, str]:
    """Each channel label the file's points make, in both spellings (``455:+Z`` and
    ``455:3``, as FRF files label a component), and its sensor's name with the direction
    (``L03 +Z``); the other directions at a listed grid take its first point's name with
    their own direction.

    Raises
    ------
    ConfigError
        As :func:`read_points`.
    """
    out = {}
    points = read_points(path)
    for label, grid, code in points:
        channel = point_label(grid, code)
        name = f"{label} {channel.split(':', 1)[1]}"
        out[channel] = name
        out[f"{grid}:{code}"] = name
    # a test often measures more directions at a point than the file lists (a triaxial
    # sensor where a uniaxial one was planned): they take the point's name too
    for label, grid, _ in points:
        for code in (*range(1, 7), *range(-6, 0)):
            channel = point_label(grid, code)
            name = f"{label} {channel.split(':', 1)[1]}"
            out.setdefault(channel, name)
            out.setdefault(f"{grid}:{code}", name)
    return out
