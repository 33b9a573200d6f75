"""The registry of test-data file formats: each format module registers its reader and
writer under its suffixes (as meshio's formats do), and :func:`read` / :func:`write` pick
them by a file's suffix.

A format holds one kind of data: ``"frf"`` (:class:`~femcal.testdata.data.FRFData`) or
``"time"`` (:class:`~femcal.testdata.timedata.TimeData`). The kinds are apart: a suffix names
one format of each kind (``.csv`` is the long-format FRF CSV for FRFs and the time-column CSV
for time histories), and the reader of a kind raises that kind's error
(:class:`~femcal.errors.FRFError`, :class:`~femcal.errors.TimeDataError`).
"""

from __future__ import annotations

import errno
import os
import zipfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from ...errors import FemcalError, FRFError, TimeDataError, message


@dataclass(frozen=True)
class Format:
    """One file format.

    Attributes
    ----------
    name : short name (``"uff"``), one per kind.
    kind : the data it holds (``"frf"``, ``"time"``).
    suffixes : file suffixes, lower case with the dot (``(".uff", ".unv")``).
    read : path -> data. write : (path, data) -> the path written, or None if the format is
        read only.
    description : one line for help texts.
    """

    name: str
    kind: str
    suffixes: tuple[str, ...]
    read: Callable[[Path], object]
    write: Callable[[Path, object], Path] | None
    description: str = ""


#: The formats by (kind, name), in registration order.
_FORMATS: dict[tuple[str, str], Format] = {}
#: How messages name each kind of data.
_WHAT = {"frf": "FRF", "time": "time-history"}
#: The error each kind's readers raise (FRFError for a kind without its own).
_ERRORS: dict[str, type[FemcalError]] = {"frf": FRFError, "time": TimeDataError}


def error_of(kind: str) -> type[FemcalError]:
    """The error class of ``kind``'s data (:class:`~femcal.errors.FRFError` for ``"frf"``,
    :class:`~femcal.errors.TimeDataError` for ``"time"``); both are ValueErrors too."""
    return _ERRORS.get(kind, FRFError)


def register(fmt: Format) -> None:
    """Add a format; a suffix belongs to one format of a kind.

    Raises
    ------
    ValueError
        If a suffix of ``fmt`` is already registered for the same kind by another format.
    """
    for s in fmt.suffixes:
        other = next((f for f in _FORMATS.values() if f.kind == fmt.kind and s in f.suffixes
                      and f.name != fmt.name), None)  # fmt: skip
        if other is not None:
            raise ValueError(f"suffix {s} is already the {other.name} format's")
    _FORMATS[(fmt.kind, fmt.name)] = fmt


def formats(kind: str) -> list[Format]:
    """The registered formats of one kind, in registration order."""
    return [f for f in _FORMATS.values() if f.kind == kind]


def suffixes(kind: str, *, writable: bool = False) -> list[str]:
    """Every suffix of the formats of ``kind`` (only those that can be written, if asked)."""
    return [s for f in formats(kind) if f.write is not None or not writable for s in f.suffixes]


def format_of(path: str | os.PathLike[str], kind: str, *, writing: bool = False) -> Format:
    """The format of ``kind`` a file's suffix names.

    Raises
    ------
    ValueError
        For a suffix no format of that kind has (or none that writes it), listing those
        that would do.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    for f in formats(kind):
        if suffix in f.suffixes and (f.write is not None or not writing):
            return f
    known = ", ".join(suffixes(kind, writable=writing))
    what = _WHAT.get(kind, kind)
    raise ValueError(f"{path}: unknown {what} file type {path.suffix!r}; expected {known}")


def read(path: str | os.PathLike[str], kind: str) -> object:
    """Read a file of ``kind`` by its suffix.

    The readers raise the kind's error (:func:`error_of`: :class:`~femcal.errors.FRFError`
    for ``"frf"``, :class:`~femcal.errors.TimeDataError` for ``"time"``, both ValueErrors)
    for a file that is not what its suffix says, naming the file and what is wrong; a
    KeyError or ValueError that a reader lets through is passed on as the kind's error naming
    the file too, so that no reader's slip shows the user a bare message.

    Raises
    ------
    FRFError or TimeDataError
        (as the kind says) For an unknown suffix, or a file that is not what its suffix says
        (naming the file and what is wrong).
    FileNotFoundError
        For a file that does not exist.
    """
    from scipy.io.matlab import MatReadError

    path = Path(path)
    what = _WHAT.get(kind, kind)
    error = error_of(kind)
    try:
        fmt = format_of(path, kind)
    except ValueError as e:
        raise error(str(e)) from None
    if not path.is_file():
        if path.is_dir():
            raise IsADirectoryError(errno.EISDIR, os.strerror(errno.EISDIR), str(path))
        raise FileNotFoundError(errno.ENOENT, os.strerror(errno.ENOENT), str(path))
    try:
        return fmt.read(path)
    except error as e:
        if str(path) in str(e):
            raise
        raise error(f"{path}: {e}") from e
    except FemcalError:
        raise
    except (KeyError, ValueError) as e:
        msg = message(e)
        raise error(msg if str(path) in msg else f"{path}: {msg}") from e
    except (OSError, EOFError, zipfile.BadZipFile, MatReadError) as e:
        raise error(f"{path}: not a readable {path.suffix} {what} file ({e})") from e


def write(path: str | os.PathLike[str], data: object, kind: str) -> Path:
    """Write ``data`` of ``kind`` in the format its suffix names (atomically).

    Raises
    ------
    FRFError or TimeDataError
        (as the kind says; both ValueErrors) For a suffix no format of that kind writes,
        listing those that would do.
    ValueError
        For data the format cannot hold (mostly the kind's error, naming what is wrong).
    """
    try:
        fmt = format_of(path, kind, writing=True)
    except ValueError as e:
        raise error_of(kind)(str(e)) from None
    return fmt.write(Path(path), data)
