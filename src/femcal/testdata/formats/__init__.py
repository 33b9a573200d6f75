"""Test-data file formats, registered by suffix (:mod:`~femcal.testdata.formats.registry`):
NPZ, CSV, UFF 58 and MATLAB .mat (femcal's variables or the LMS Test.Lab layout)."""

from __future__ import annotations

import os
from pathlib import Path

from ..data import FRFData
from . import matlab, npz, text, uff
from .registry import Format, format_of, formats, read, register, suffixes, write

__all__ = [
    "Format",
    "format_of",
    "formats",
    "matlab",
    "npz",
    "read",
    "read_frf",
    "register",
    "suffixes",
    "text",
    "uff",
    "write",
    "write_frf",
]


def read_frf(path: str | os.PathLike[str]) -> FRFData:
    """Read an FRF file by its suffix: .npz, .csv, .uff/.unv (UFF 58) or .mat (femcal's
    variables or the LMS Test.Lab layout).

    Raises
    ------
    ValueError
        For another suffix, or a file that is not what its suffix says.
    FileNotFoundError
        For a missing file.
    """
    return read(path, "frf")


def write_frf(path: str | os.PathLike[str], data: FRFData) -> Path:
    """Write FRF data in the format the suffix names (atomically)."""
    return write(path, data, "frf")
