"""Test-data file formats, registered by kind and suffix
(:mod:`~femcal.testdata.formats.registry`).

FRFs (kind ``"frf"``, :func:`read_frf` / :func:`write_frf`): NPZ, long-format CSV, UFF 58
and MATLAB .mat (femcal's variables or the LMS Test.Lab layout).

Time histories (kind ``"time"``, :func:`read_time_data` / :func:`write_time_data`): MTS RPC
III (.rsp, .tim, .drv; :mod:`~femcal.testdata.formats.rpc3`), CSV with a time column
(:mod:`~femcal.testdata.formats.timecsv`) and NPZ (:mod:`~femcal.testdata.formats.timenpz`).
"""

from __future__ import annotations

import os
from pathlib import Path

from ..data import FRFData
from ..timedata import TimeData
from . import matlab, npz, rpc3, text, timecsv, timenpz, uff
from .registry import Format, error_of, format_of, formats, read, register, suffixes, write

__all__ = [
    "Format",
    "error_of",
    "format_of",
    "formats",
    "matlab",
    "npz",
    "read",
    "read_frf",
    "read_time_data",
    "register",
    "rpc3",
    "suffixes",
    "text",
    "timecsv",
    "timenpz",
    "uff",
    "write",
    "write_frf",
    "write_time_data",
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


def read_time_data(path: str | os.PathLike[str]) -> TimeData:
    """Read a time-history file by its suffix: .rsp, .tim or .drv (MTS RPC III), .csv (a
    ``time_s`` column, then one column per channel) or .npz (``dt``, ``values``, ``names``,
    ``units``); ``suffixes("time")`` lists them.

    Parameters
    ----------
    path : the file; its suffix (any case) names the format.

    Returns
    -------
    TimeData
        The channels, their step, names and units (and an RPC III file's other keywords in
        ``header``).

    Raises
    ------
    TimeDataError
        (a ValueError) For another suffix (listing the time-history suffixes), or a file
        that is not what its suffix says, naming the file, where in it and what was
        expected.
    FileNotFoundError
        For a missing file (IsADirectoryError for a folder).
    """
    return read(path, "time")


def write_time_data(path: str | os.PathLike[str], data: TimeData) -> Path:
    """Write time histories in the format the suffix names, atomically (the file is whole
    or left as it was): .rsp/.tim/.drv as RPC III 32-bit floats, .csv with exact float64
    text, .npz as stored.

    Parameters
    ----------
    path : the file to write; its suffix (any case) names the format.
    data : the time histories.

    Returns
    -------
    Path
        The path written.

    Raises
    ------
    TimeDataError
        (a ValueError) For another suffix (listing the time-history suffixes), or data the
        format cannot hold (NaN samples, a CSV of fewer than two samples, names an RPC III
        record or a CSV header cannot hold...).
    """
    return write(path, data, "time")
