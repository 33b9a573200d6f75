"""MTS RPC III time-history files (``.rsp``, ``.tim``, ``.drv``): reading and writing.

The layout (MTS, RPC III data file format):

* a header of NUM_HEADER_BLOCKS blocks of 512 bytes, each holding four 128-byte records:
  a keyword (32 bytes) and its value (96 bytes), ASCII, padded with NUL or blanks. The
  first three records are FORMAT (``BINARY_IEEE_LITTLE_END``, ``BINARY_IEEE_BIG_END``, or
  ``BINARY``, the little-endian legacy name), NUM_HEADER_BLOCKS and NUM_PARAMS (how many
  records are used), in that order; the others in any order: CHANNELS, DELTA_T,
  PTS_PER_FRAME, FRAMES, PTS_PER_GROUP, DATA_TYPE (``SHORT_INTEGER``, the default, or
  ``FLOATING_POINT``), and per channel n = 1.. DESC.CHAN_n, UNITS.CHAN_n, SCALE.CHAN_n;
* the data after the header, demultiplexed in groups: PTS_PER_GROUP points of channel 1,
  then of channel 2, ..., then the next group. A channel holds FRAMES x PTS_PER_FRAME points;
  the last group is padded to full size by most writers, cut short (each channel's remaining
  points) by some; both are read. Short integers are 16-bit, floats 32-bit IEEE; the value of
  a point is the stored number times SCALE.CHAN_n.

Writing: the keywords a lab's tools expect, floats or short integers scaled to the channel's
largest magnitude (within half a step of the value), groups padded to full size, written
whole or not at all.

The format is registered for time histories (kind ``"time"``) under .rsp, .tim and .drv, so
:func:`femcal.testdata.formats.read_time_data` and ``write_time_data`` take these files by
suffix (the writer with its defaults: 32-bit floats).
"""

from __future__ import annotations

import datetime
import math
import os
from pathlib import Path

import numpy as np

from ...atomic import write_atomic
from ...errors import TimeDataError
from ..timedata import TimeData
from .registry import Format, register

RECORD, BLOCK = 128, 512
KEY_BYTES = 32
#: FORMAT values and the byte order they stand for.
BYTE_ORDERS = {"BINARY_IEEE_LITTLE_END": "<", "BINARY_IEEE_BIG_END": ">", "BINARY": "<"}
#: DATA_TYPE values and the stored number type.
DATA_TYPES = {"SHORT_INTEGER": "i2", "FLOATING_POINT": "f4"}
#: The largest short integer the writer uses (INT_FULL_SCALE is 32768).
SHORT_MAX = 32767


def _records(raw: bytes, path: Path, first: int = 0) -> list[tuple[str, str]]:
    """(keyword, value) of the 128-byte records in ``raw``."""
    out = []
    for k in range(len(raw) // RECORD):
        rec = raw[k * RECORD:(k + 1) * RECORD]
        try:
            key = rec[:KEY_BYTES].split(b"\0", 1)[0].decode("ascii").strip()
            value = rec[KEY_BYTES:].split(b"\0", 1)[0].decode("ascii").strip()
        except UnicodeDecodeError:
            raise TimeDataError(f"{path}: header record {first + k + 1} is not ASCII text: "
                                "expected a keyword and its value") from None  # fmt: skip
        out.append((key, value))
    return out


def read_header(path: str | os.PathLike[str]) -> tuple[dict[str, str], int]:
    """The header keywords of an RPC III file (in file order) and the header's size in bytes.

    Raises
    ------
    TimeDataError
        Naming the file and the record or keyword: FORMAT, NUM_HEADER_BLOCKS and NUM_PARAMS
        not first, a count out of range, a header cut short, a keyword given twice.
    """
    path = Path(path)
    with open(path, "rb") as fh:
        first = fh.read(BLOCK)
        if len(first) < 3 * RECORD:
            raise TimeDataError(f"{path}: {len(first)} bytes; expected an RPC III header of "
                                f"512-byte blocks")  # fmt: skip
        lead = _records(first[: 3 * RECORD], path)
        want = ("FORMAT", "NUM_HEADER_BLOCKS", "NUM_PARAMS")
        for k, ((key, _), expected) in enumerate(zip(lead, want, strict=True)):
            if key != expected:
                raise TimeDataError(f"{path}: header record {k + 1} is {key!r}; expected "
                                    f"{expected} (an RPC III file starts with FORMAT, "
                                    "NUM_HEADER_BLOCKS, NUM_PARAMS)")  # fmt: skip
        blocks = _int(lead[1][1], "NUM_HEADER_BLOCKS", path, lo=1)
        n_params = _int(lead[2][1], "NUM_PARAMS", path, lo=3)
        if n_params > 4 * blocks:
            raise TimeDataError(f"{path}: NUM_PARAMS = {n_params} records do not fit in "
                                f"NUM_HEADER_BLOCKS = {blocks} blocks of 4")  # fmt: skip
        raw = first + fh.read(blocks * BLOCK - len(first))
    if len(raw) < blocks * BLOCK:
        raise TimeDataError(f"{path}: the header is cut short at byte {len(raw)}; "
                            f"NUM_HEADER_BLOCKS = {blocks} asks for {blocks * BLOCK}")  # fmt: skip
    header: dict[str, str] = {}
    for k, (key, value) in enumerate(_records(raw[: n_params * RECORD], path)):
        if not key:
            raise TimeDataError(f"{path}: header record {k + 1} has no keyword; expected "
                                f"NUM_PARAMS = {n_params} keyword records")  # fmt: skip
        if key in header:
            raise TimeDataError(f"{path}: keyword {key} given twice (records "
                                f"{list(header).index(key) + 1} and {k + 1})")  # fmt: skip
        header[key] = value
    return header, blocks * BLOCK


def _int(text: str, key: str, path: Path, lo: int = 0) -> int:
    try:
        v = int(text)
    except ValueError:
        raise TimeDataError(f"{path}: {key} = {text!r}; expected a whole number") from None
    if v < lo:
        raise TimeDataError(f"{path}: {key} = {v}; expected a whole number >= {lo}")
    return v


def _float(text: str, key: str, path: Path) -> float:
    try:
        v = float(text)
    except ValueError:
        raise TimeDataError(f"{path}: {key} = {text!r}; expected a number") from None
    if not math.isfinite(v):
        raise TimeDataError(f"{path}: {key} = {text!r}; expected a finite number")
    return v


def read_rpc3(path: str | os.PathLike[str]) -> TimeData:
    """Read an RPC III time-history file (see the module docstring).

    Raises
    ------
    TimeDataError
        Naming the file and the keyword for a header that breaks the format, and the sizes
        for data that do not fill the groups the header announces.
    FileNotFoundError
        For a missing file.
    """
    path = Path(path)
    header, offset = read_header(path)

    def need(key: str) -> str:
        if key not in header:
            raise TimeDataError(f"{path}: no {key} keyword; an RPC III time history needs it")
        return header[key]

    fmt = header["FORMAT"].upper()
    if fmt not in BYTE_ORDERS:
        raise TimeDataError(f"{path}: FORMAT = {header['FORMAT']!r}; expected one of "
                            f"{', '.join(BYTE_ORDERS)}")  # fmt: skip
    file_type = header.get("FILE_TYPE", "TIME_HISTORY").upper()
    if file_type != "TIME_HISTORY":
        raise TimeDataError(f"{path}: FILE_TYPE = {file_type}; expected TIME_HISTORY")
    data_type = header.get("DATA_TYPE", "SHORT_INTEGER").upper()
    if data_type not in DATA_TYPES:
        raise TimeDataError(f"{path}: DATA_TYPE = {data_type!r}; expected SHORT_INTEGER or "
                            "FLOATING_POINT")  # fmt: skip
    n_ch = _int(need("CHANNELS"), "CHANNELS", path, lo=1)
    dt = _float(need("DELTA_T"), "DELTA_T", path)
    if dt <= 0:
        raise TimeDataError(f"{path}: DELTA_T = {dt:g}; expected a step > 0 s")
    ppf = _int(need("PTS_PER_FRAME"), "PTS_PER_FRAME", path, lo=1)
    frames = _int(need("FRAMES"), "FRAMES", path, lo=1)
    ppg = _int(need("PTS_PER_GROUP"), "PTS_PER_GROUP", path, lo=1)
    if _int(header.get("HALF_FRAMES", "0"), "HALF_FRAMES", path) != 0:
        raise TimeDataError(f"{path}: HALF_FRAMES = {header['HALF_FRAMES']}: half frames are "
                            "not read; expected 0")  # fmt: skip
    scales = np.array([_float(header.get(f"SCALE.CHAN_{c}", "1"), f"SCALE.CHAN_{c}", path)
                       for c in range(1, n_ch + 1)])  # fmt: skip
    names = tuple(header.get(f"DESC.CHAN_{c}", f"channel {c}") for c in range(1, n_ch + 1))
    units = tuple(header.get(f"UNITS.CHAN_{c}", "") for c in range(1, n_ch + 1))

    dtype = np.dtype(BYTE_ORDERS[fmt] + DATA_TYPES[data_type])
    n_points = frames * ppf
    n_groups = -(-n_points // ppg)
    rest = n_points - (n_groups - 1) * ppg  # points of each channel in the last group
    full = n_groups * n_ch * ppg * dtype.itemsize
    cut = ((n_groups - 1) * n_ch * ppg + n_ch * rest) * dtype.itemsize
    size = path.stat().st_size - offset
    if size >= full:
        nbytes = full
    elif size == cut:
        nbytes = cut
    else:
        raise TimeDataError(f"{path}: {size} bytes of data after the header; {n_ch} channels x "
                            f"{n_points} points ({frames} frames of {ppf}) in {n_groups} groups "
                            f"of {ppg} need {full} (or {cut} with the last group cut "
                            "short)")  # fmt: skip
    with open(path, "rb") as fh:
        fh.seek(offset)
        stored = np.frombuffer(fh.read(nbytes), dtype=dtype)
    head = stored[: (n_groups - 1) * n_ch * ppg].reshape(n_groups - 1, n_ch, ppg)
    last = stored[(n_groups - 1) * n_ch * ppg:]
    last = last.reshape(n_ch, -1)[:, :rest]
    values = np.concatenate([head.transpose(1, 0, 2).reshape(n_ch, -1), last], axis=1)
    values = values.astype(np.float64) * scales[:, None]
    keep = {k: v for k, v in header.items()
            if k not in ("FORMAT", "NUM_HEADER_BLOCKS", "NUM_PARAMS")}  # fmt: skip
    return TimeData(dt, values, names, units, keep)


def write_rpc3(path: str | os.PathLike[str], data: TimeData, *,
               data_type: str = "FLOATING_POINT", pts_per_frame: int = 1024,
               pts_per_group: int = 2048, time_type: str = "RESPONSE") -> Path:  # fmt: skip
    """Write ``data`` as an RPC III file (little-endian IEEE). Floats are stored as 32-bit
    IEEE; short integers as round(value / SCALE) with SCALE = the channel's largest
    magnitude / 32767, within half a SCALE of the value. The samples fill whole frames of
    ``pts_per_frame`` (a smaller frame that divides the sample count is taken when it does
    not), the groups are padded to full size.

    Raises
    ------
    TimeDataError
        For an unknown data type, or non-finite samples.
    """
    if data_type not in DATA_TYPES:
        raise TimeDataError(f"data_type {data_type!r}: expected SHORT_INTEGER or FLOATING_POINT")
    if not np.isfinite(data.values).all():
        c = int(np.flatnonzero(~np.isfinite(data.values).all(axis=1))[0])
        raise TimeDataError(f"channel {data.names[c]!r} holds NaN or infinite samples; an RPC "
                            "III file holds finite numbers")  # fmt: skip
    n_ch, n = data.values.shape
    ppf = math.gcd(n, pts_per_frame) if n % pts_per_frame else pts_per_frame
    ppg = max(pts_per_group, ppf)
    n_groups = -(-n // ppg)
    if data_type == "SHORT_INTEGER":
        peak = np.abs(data.values).max(axis=1)
        scales = np.where(peak > 0, peak / SHORT_MAX, 1.0)
        stored = np.rint(data.values / scales[:, None]).astype("<i2")
    else:
        scales = np.ones(n_ch)
        stored = data.values.astype("<f4")
    padded = np.zeros((n_ch, n_groups * ppg), stored.dtype)
    padded[:, :n] = stored
    body = padded.reshape(n_ch, n_groups, ppg).transpose(1, 0, 2).tobytes()

    keys: list[tuple[str, str]] = [
        ("FILE_TYPE", "TIME_HISTORY"), ("TIME_TYPE", time_type),
        ("DELTA_T", repr(float(data.dt))), ("CHANNELS", str(n_ch)),
        ("DATE", datetime.datetime.now().strftime("%H:%M:%S %d-%b-%Y").upper()),
        ("REPEATS", "1"), ("DATA_TYPE", data_type), ("PTS_PER_FRAME", str(ppf)),
        ("PTS_PER_GROUP", str(ppg)), ("FRAMES", str(n // ppf)), ("HALF_FRAMES", "0"),
        ("BYPASS_FILTER", "0"), ("INT_FULL_SCALE", "32768"), ("PARTITIONS", "1"),
        ("PART.CHAN_1", "1"), ("PART.NCHAN_1", str(n_ch)),
    ]  # fmt: skip
    for c in range(n_ch):
        peak = float(np.abs(data.values[c]).max(initial=0.0))
        keys += [(f"DESC.CHAN_{c + 1}", data.names[c]), (f"UNITS.CHAN_{c + 1}", data.units[c]),
                 (f"SCALE.CHAN_{c + 1}", repr(float(scales[c]))),
                 (f"LOWER_LIMIT.CHAN_{c + 1}", repr(-peak)),
                 (f"UPPER_LIMIT.CHAN_{c + 1}", repr(peak)),
                 (f"MAP.CHAN_{c + 1}", str(c + 1))]  # fmt: skip
    n_params = len(keys) + 3
    blocks = -(-n_params // 4)
    records = [("FORMAT", "BINARY_IEEE_LITTLE_END"), ("NUM_HEADER_BLOCKS", str(blocks)),
               ("NUM_PARAMS", str(n_params)), *keys]  # fmt: skip
    head = b"".join(_record(k, v) for k, v in records).ljust(blocks * BLOCK, b"\0")

    def dump(tmp: str) -> None:
        with open(tmp, "wb") as fh:
            fh.write(head)
            fh.write(body)

    return write_atomic(path, dump)


def _record(key: str, value: str) -> bytes:
    k, v = key.encode("ascii"), value.encode("ascii", "replace")
    if len(k) > KEY_BYTES or len(v) > RECORD - KEY_BYTES:
        raise TimeDataError(f"RPC III record {key} = {value!r}: a keyword holds at most 32 "
                            "characters, a value 96")  # fmt: skip
    return k.ljust(KEY_BYTES, b"\0") + v.ljust(RECORD - KEY_BYTES, b"\0")


register(Format("rpc3", "time", (".rsp", ".tim", ".drv"), read_rpc3, write_rpc3,
                "MTS RPC III"))  # fmt: skip
