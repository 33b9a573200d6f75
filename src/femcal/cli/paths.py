"""Checks of the paths a command is asked to write, made before any work starts."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from ..errors import FemcalError


class UsageError(FemcalError):
    """A command-line argument that cannot be used (exit status 2)."""


def file_in_the_way(path: Path) -> Path | None:
    """The nearest existing parent of ``path`` if it is not a directory (the output could
    not be made there), else None."""
    for parent in path.parents:
        if parent.exists():
            return None if parent.is_dir() else parent
    return None


def output_folder(path: Path | None, option: str) -> Path | None:
    """``path`` if it is a folder or can become one; a :class:`UsageError` naming ``option``
    if it is an existing file (or under one)."""
    if path is None:
        return None
    blocker = path if path.exists() and not path.is_dir() else file_in_the_way(path)
    if blocker is not None:
        raise UsageError(f"{option} {path}: expected a folder, but {blocker} is a file")
    return path


def output_file(path: Path, option: str, kind: str) -> Path:
    """``path`` if a file of test data of ``kind`` (``"frf"``, ``"time"``) can be written
    there: a :class:`UsageError` naming ``option`` for a folder, a suffix no format of that
    kind writes, or a file where a parent folder should be."""
    from ..testdata.formats import format_of

    def suffix() -> None:
        try:
            format_of(path, kind, writing=True)
        except ValueError as e:
            raise UsageError(f"{option} {e}") from None

    return _file_target(path, option, suffix)


def output_path(path: Path | None, option: str, suffixes: tuple[str, ...]) -> Path | None:
    """``path`` (None stays None) if a file with one of ``suffixes`` can be written there; a
    :class:`UsageError` naming ``option`` for a folder, another suffix or a file where a
    parent folder should be."""
    if path is None:
        return None

    def suffix() -> None:
        if path.suffix.lower() not in suffixes:
            raise UsageError(f"{option} {path}: suffix {path.suffix or '(none)'!r}; expected "
                             f"{' or '.join(suffixes)}")  # fmt: skip

    return _file_target(path, option, suffix)


def _file_target(path: Path, option: str, check_suffix: Callable[[], None]) -> Path:
    """``path`` after the checks every output file gets: not a folder, its suffix
    (``check_suffix`` raises), no file where a parent folder should be."""
    if path.is_dir():
        raise UsageError(f"{option} {path}: is a directory; expected a file name")
    check_suffix()
    blocked = file_in_the_way(path)
    if blocked is not None:
        raise UsageError(f"{option} {path}: {blocked} is a file, not a directory")
    return path
