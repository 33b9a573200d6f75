"""Eigenvalues and eigenvectors as a NASTRAN punch file (``.pch``), the file SOL 103 writes
for ``DISPLACEMENT(PUNCH) = ALL``, and a reader of that layout.

The layout, as MSC and NX Nastran punch it (seen in real punch files: pyNastran's
``models/beam_modes/beam_modes.pch`` for the ``$EIGENVALUE`` line, ``h5Nastran/models/
model_001.pch`` (real displacements) and ``models/fsi/fsi.pch`` (eigenvectors) for the
point lines; read the same way by the column positions of SU2's and NeoLCO's
``readPunchShapes.m``: eigenvalue in columns 16-28, mode in 38-42, point type in 16-20,
values in 24-72)::

    $TITLE   = LADDER FRAME EXAMPLE                                                1
    $SUBTITLE=                                                                     2
    $LABEL   =                                                                     3
    $EIGENVECTOR                                                                   4
    $REAL OUTPUT                                                                   5
    $SUBCASE ID =           1                                                      6
    $EIGENVALUE =  3.8090336E+02  MODE =     1                                     7
             1       G      8.146530E-04      1.484150E+00      1.809040E-01       8
    -CONT-                  1.234567E-03     -2.345678E-04      0.000000E+00       9

Every line is 80 columns: the text in columns 1-72, the line's sequence number (from 1,
through the whole file) right-justified in columns 73-80. Per mode the six header lines and
the ``$EIGENVALUE`` line (``$EIGENVALUE = `` then the eigenvalue in E14.7, rad^2/s^2, then
``  MODE = `` and the mode number in I5), then two lines per point in ascending id order: the
point id (I10), its type in column 18 (``G`` a GRID, ``S`` a scalar point), T1 T2 T3 in
three 18-column fields (E13.6 right-justified: 7 significant digits), and a ``-CONT-`` line
with R1 R2 R3 (a scalar point's value is its T1, the other five 0).

The values are each GRID's components in its displacement (CD) frame, as NASTRAN punches
them: femcal keeps the shapes of :class:`~femcal.solve.normal_modes.Modes` in the CD frames
(the ``cd_frames`` of the model map them to basic), so they are written as solved, in the
normalisation the deck's EIGRL asks for (MASS or MAX).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..atomic import write_lines
from ..errors import FemcalError
from ..solve.normal_modes import Modes


class PunchError(FemcalError, ValueError):
    """A punch file that breaks the layout: the message names the file, the line and what
    was expected."""


def _fields(values: np.ndarray) -> str:
    return "".join(f"{float(v):18.6E}" for v in values)


def _header(text: str) -> str:
    return " ".join(str(text).split())[:61]


def punch_lines(modes: Modes, *, title: str = "", subtitle: str = "", label: str = "",
                subcase: int = 1) -> Iterator[str]:  # fmt: skip
    """The lines (80 columns, sequence numbers included) of the punch file of ``modes``."""
    seq = 0

    def line(text: str) -> str:
        nonlocal seq
        seq += 1
        if len(text) > 72:
            raise ValueError(f"punch line {seq} is {len(text)} columns; expected at most 72")
        return f"{text:<72}{seq:8d}"

    starts = modes.dof_start
    for k, lam in enumerate(modes.eigenvalues):
        yield line(f"$TITLE   = {_header(title)}")
        yield line(f"$SUBTITLE= {_header(subtitle)}")
        yield line(f"$LABEL   = {_header(label)}")
        yield line("$EIGENVECTOR")
        yield line("$REAL OUTPUT")
        yield line(f"$SUBCASE ID = {subcase:11d}")
        yield line(f"$EIGENVALUE = {float(lam):14.7E}  MODE = {k + 1:5d}")
        u = modes.shapes[:, k]
        for nid, start, grid in zip(modes.node_ids, starts, modes.is_grid, strict=True):
            if grid:
                v = u[start:start + 6]
                yield line(f"{int(nid):10d}       G{_fields(v[:3])}")
                yield line(f"-CONT-            {_fields(v[3:])}")
            else:
                yield line(f"{int(nid):10d}       S{_fields([u[start], 0.0, 0.0])}")
                yield line(f"-CONT-            {_fields([0.0, 0.0, 0.0])}")


def write_punch(path: str | os.PathLike[str], modes: Modes, *, title: str = "",
                subtitle: str = "", label: str = "", subcase: int = 1) -> Path:  # fmt: skip
    """The punch file of the eigenvalues and eigenvectors (every GRID and scalar point, CD
    frames), written to a temporary name and renamed."""
    return write_lines(path, punch_lines(modes, title=title, subtitle=subtitle, label=label,
                                         subcase=subcase), encoding="ascii")  # fmt: skip


@dataclass(frozen=True)
class PunchModes:
    """Eigenvectors read from a punch file.

    Attributes
    ----------
    eigenvalues : (k,) as punched; modes : (k,) their mode numbers.
    point_ids : (n,) ids of the points, as in the first mode; point_types : (n,) ``G``/``S``.
    values : (k, n, 6) T1 T2 T3 R1 R2 R3 of each point in each mode (a scalar point's in
        column 0).
    title, subtitle, label : of the first mode; subcase : its subcase id.
    """

    eigenvalues: np.ndarray
    modes: np.ndarray
    point_ids: np.ndarray
    point_types: np.ndarray
    values: np.ndarray
    title: str = ""
    subtitle: str = ""
    label: str = ""
    subcase: int = 0


def _number(text: str, where: str, what: str, kind: type = float):
    try:
        return kind(text.strip())
    except ValueError:
        raise PunchError(f"{where}: {what} {text.strip()!r} is not a number") from None


def read_punch(path: str | os.PathLike[str]) -> PunchModes:
    """The eigenvalues and eigenvectors of a punch file of real eigenvectors (the layout
    :func:`write_punch` writes, NASTRAN's). Other result blocks (``$DISPLACEMENTS``,
    element forces) are skipped.

    Raises
    ------
    PunchError
        Naming the file and line: a point line or value that is not a number, a
        ``-CONT-`` line without its point, modes with different points, no eigenvector.
    """
    path = Path(path)
    heads: dict[str, str] = {}
    block = ""
    first_heads: dict[str, str] = {}
    modes: list[tuple[float, int, list[int], list[str], list[list[float]]]] = []
    current = None
    for n, raw in enumerate(path.read_text(encoding="latin-1").splitlines(), start=1):
        text = raw[:72]
        where = f"{path}:{n}"
        if text.startswith("$"):
            key, _, value = text[1:].partition("=")
            key = key.strip().upper()
            if key in ("TITLE", "SUBTITLE", "LABEL", "SUBCASE ID"):
                heads[key] = value.strip()
            elif key == "EIGENVALUE" and block == "EIGENVECTOR":
                lam, _, mode = value.partition("MODE")
                current = (_number(lam, where, "eigenvalue"),
                           _number(mode.lstrip(" ="), where, "mode number", int), [], [], [])
                modes.append(current)
                if len(modes) == 1:
                    first_heads = dict(heads)
            elif not value and key not in ("REAL OUTPUT",):
                block = key
                current = None
            continue
        if current is None or not text.strip():
            continue
        if text.startswith("-CONT-"):
            if not current[4] or len(current[4][-1]) != 3:
                raise PunchError(f"{where}: a -CONT- line without its point line before it")
            current[4][-1] += [_number(text[18 + 18 * i:36 + 18 * i], where, f"R{i + 1}")
                               for i in range(3)]  # fmt: skip
            continue
        current[2].append(_number(text[:10], where, "point id", int))
        current[3].append(text[10:18].strip())
        current[4].append([_number(text[18 + 18 * i:36 + 18 * i], where, f"T{i + 1}")
                           for i in range(3)])  # fmt: skip
    if not modes:
        raise PunchError(f"{path}: no $EIGENVECTOR block with an $EIGENVALUE line; expected "
                         "the punch file of a normal modes solution")  # fmt: skip
    ids = modes[0][2]
    for _, mode, other, _, _ in modes[1:]:
        if other != ids:
            raise PunchError(f"{path}: mode {mode} has other points than mode {modes[0][1]}; "
                             "expected the same points in every mode")  # fmt: skip
    values = np.zeros((len(modes), len(ids), 6))
    for k, (_, _, _, _, rows) in enumerate(modes):
        for i, r in enumerate(rows):
            values[k, i, :len(r)] = r
    return PunchModes(np.array([m[0] for m in modes]), np.array([m[1] for m in modes]),
                      np.array(ids, dtype=np.int64), np.array(modes[0][3]), values,
                      first_heads.get("TITLE", ""), first_heads.get("SUBTITLE", ""),
                      first_heads.get("LABEL", ""),
                      int(first_heads.get("SUBCASE ID", "0") or 0))  # fmt: skip
