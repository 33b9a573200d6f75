"""MTS RPC III time-history files (``.rsp``, ``.tim``, ``.drv``): reading and writing.

The layout (MTS, RPC III data file format):

* a header of NUM_HEADER_BLOCKS blocks of 512 bytes, each holding four 128-byte records:
  a keyword (32 bytes) and its value (96 bytes), padded with NUL or blanks. The first three
  records are FORMAT (``BINARY_IEEE_LITTLE_END``, ``BINARY_IEEE_BIG_END``, or ``BINARY``,
  which MTS reads as little-endian IEEE), NUM_HEADER_BLOCKS and NUM_PARAMS (how many records
  are used), in that order; the others in any order: CHANNELS, DELTA_T, PTS_PER_FRAME,
  FRAMES, PTS_PER_GROUP, DATA_TYPE (``SHORT_INTEGER``, the default, or ``FLOATING_POINT``),
  and per channel n = 1.. DESC.CHAN_n, UNITS.CHAN_n, SCALE.CHAN_n;
* the data after the header, demultiplexed in groups: PTS_PER_GROUP points of channel 1,
  then of channel 2, ..., then the next group. A channel holds FRAMES x PTS_PER_FRAME points;
  the last group is padded to full size by most writers, cut short (each channel's remaining
  points) by some; both are read. Short integers are 16-bit, floats 32-bit IEEE.

What the reader takes beyond that, as other writers and readers do (tests/test_rpc3.py builds
files the way each cited writer does):

* the value of a short integer is the stored number times SCALE.CHAN_n (1 when missing).
  SCALE is the 16-bit converter's step (MTS); floats are stored in engineering units and
  their SCALE does not apply, as the public readers take it (pyRPC3, rpc3-file, RPC3.js);
  INT_FULL_SCALE, BYPASS_FILTER and REPEATS are kept in the header, not applied;
* DATA_TYPE ``DOUBLE_PRECISION`` (64-bit IEEE, FEDEM's writer);
* SAMPLES (python rpc3-file's writer): the real number of points of each channel, the rest
  of the last frame being padding;
* values in Windows-1252 or Latin-1 (``µm/m``, ``°C``: writers encode them so); keywords in
  any case (FEDEM's reader upper-cases them); empty records among the NUM_PARAMS (skipped);
  a header whose strings are byte-swapped in pairs (``OFMRTA...``, as FEDEM's reader takes);
* after the data, at most the rest of a 512-byte record (FEDEM's writer leaves one sample
  past the end).

Refused with an error naming the file and the keyword: ASCII data (FORMAT ``ASCII``), other
formats (VAX, ...), configuration files (FILE_TYPE CONFIGURATION or TIME_TYPE CONFIG_DRIVE /
CONFIG_RESP: a header and no data), half frames (HALF_FRAMES 1), a header or data that the
file does not hold (every size is checked against the file's before anything is read or
allocated), a keyword given twice, samples that are not finite numbers.

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
import re
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
#: DATA_TYPE values the writer writes, and the stored number type.
DATA_TYPES = {"SHORT_INTEGER": "i2", "FLOATING_POINT": "f4"}
#: DATA_TYPE values the reader reads (FEDEM's writer adds 64-bit floats).
READ_TYPES = {**DATA_TYPES, "DOUBLE_PRECISION": "f8"}
#: TIME_TYPE values of configuration files (a header and no data), by name and by number.
CONFIGURATION_TYPES = ("CONFIG_DRIVE", "CONFIG_RESP", "5", "6")
#: The largest short integer the writer uses (INT_FULL_SCALE is 32768).
SHORT_MAX = 32767
_WHOLE = re.compile(r"[+-]?[0-9]+")
_REAL = re.compile(r"[+-]?([0-9]+\.?[0-9]*|\.[0-9]+)([eEdD][+-]?[0-9]+)?|[+-]?(nan|inf|infinity)",
                   re.IGNORECASE)  # fmt: skip


def _text(raw: bytes) -> str:
    """A value's text: up to its NUL, Windows-1252 (Latin-1 for the bytes that has none),
    without the blanks around it."""
    raw = raw.split(b"\0", 1)[0]
    try:
        return raw.decode("cp1252").strip()
    except UnicodeDecodeError:
        return raw.decode("latin-1").strip()


def _unswap(raw: bytes) -> bytes:
    """``raw`` with each pair of bytes swapped back (a header written as 16-bit words of the
    other byte order: ``OFMRTA`` for ``FORMAT``)."""
    out = bytearray(raw)
    out[0::2], out[1::2] = raw[1::2], raw[0::2]
    return bytes(out)


def _records(raw: bytes, path: Path, first: int = 0) -> list[tuple[str, str]]:
    """(KEYWORD, value) of the 128-byte records in ``raw``: the keyword in upper case."""
    out = []
    for k in range(len(raw) // RECORD):
        rec = raw[k * RECORD:(k + 1) * RECORD]
        key = rec[:KEY_BYTES].split(b"\0", 1)[0].strip()
        if not key.isascii():
            raise TimeDataError(f"{path}: header record {first + k + 1}: keyword {_text(key)!r} "
                                "is not ASCII text; expected an RPC III keyword")  # fmt: skip
        out.append((key.decode("ascii").upper(), _text(rec[KEY_BYTES:])))
    return out


def read_header(path: str | os.PathLike[str]) -> tuple[dict[str, str], int]:
    """The header keywords of an RPC III file (in file order, upper case) and the header's
    size in bytes. Empty records among the NUM_PARAMS are skipped; a header written
    byte-swapped in pairs (``OFMRTA...``) is read swapped back.

    Raises
    ------
    TimeDataError
        Naming the file and the record or keyword: FORMAT, NUM_HEADER_BLOCKS and NUM_PARAMS
        not first, a count out of range or more than the file holds, a header cut short, a
        keyword given twice or not ASCII, a value without a keyword.
    """
    path = Path(path)
    size = path.stat().st_size
    with open(path, "rb") as fh:
        lead_raw = fh.read(3 * RECORD)
        if len(lead_raw) < 3 * RECORD:
            raise TimeDataError(f"{path}: {len(lead_raw)} bytes; expected an RPC III header of "
                                f"512-byte blocks")  # fmt: skip
        swapped = lead_raw[:6].upper() == b"OFMRTA"
        lead = _records(_unswap(lead_raw) if swapped else lead_raw, path)
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
        if blocks * BLOCK > size:  # checked before reading: a count may ask for terabytes
            raise TimeDataError(f"{path}: the header is cut short at byte {size}; NUM_HEADER_"
                                f"BLOCKS = {blocks} asks for {blocks * BLOCK}")  # fmt: skip
        raw = lead_raw + fh.read((n_params - 3) * RECORD)
    if len(raw) < n_params * RECORD:  # the file shrank since its size was taken
        raise TimeDataError(f"{path}: the header is cut short at byte {len(raw)}; "
                            f"NUM_PARAMS = {n_params} asks for {n_params * RECORD}")  # fmt: skip
    if swapped:
        raw = _unswap(raw)
    header: dict[str, str] = {}
    where: dict[str, int] = {}
    for k, (key, value) in enumerate(_records(raw, path)):
        if not key:
            if value:
                raise TimeDataError(f"{path}: header record {k + 1} has the value {value!r} "
                                    "and no keyword; expected a keyword and its value")  # fmt: skip
            continue  # an unused record among the NUM_PARAMS (some writers count them)
        if key in header:
            raise TimeDataError(f"{path}: keyword {key} given twice (records "
                                f"{where[key] + 1} and {k + 1})")  # fmt: skip
        header[key] = value
        where[key] = k
    return header, blocks * BLOCK


def _int(text: str, key: str, path: Path, lo: int = 0) -> int:
    if not _WHOLE.fullmatch(text.strip()):
        raise TimeDataError(f"{path}: {key} = {text!r}; expected a whole number")
    v = int(text)
    if v < lo:
        raise TimeDataError(f"{path}: {key} = {v}; expected a whole number >= {lo}")
    return v


def _float(text: str, key: str, path: Path) -> float:
    if not _REAL.fullmatch(text.strip()):
        raise TimeDataError(f"{path}: {key} = {text!r}; expected a number")
    v = float(text.strip().replace("D", "E").replace("d", "e"))
    if not math.isfinite(v):
        raise TimeDataError(f"{path}: {key} = {text!r}; expected a finite number")
    return v


def read_rpc3(path: str | os.PathLike[str]) -> TimeData:
    """Read an RPC III time-history file (see the module docstring).

    Raises
    ------
    TimeDataError
        Naming the file and the keyword for a header that breaks the format or that this
        reader does not read (ASCII data, configuration files, half frames), the sizes for
        data that do not fill the groups the header announces (checked against the file's
        size before anything is allocated), the channel and sample for samples that are not
        finite numbers.
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
    if fmt == "ASCII":
        raise TimeDataError(f"{path}: FORMAT = ASCII: RPC III data written as text are not "
                            f"read; expected one of {', '.join(BYTE_ORDERS)}")  # fmt: skip
    if fmt not in BYTE_ORDERS:
        raise TimeDataError(f"{path}: FORMAT = {header['FORMAT']!r}; expected one of "
                            f"{', '.join(BYTE_ORDERS)}")  # fmt: skip
    file_type = header.get("FILE_TYPE", "TIME_HISTORY").upper()
    if file_type == "CONFIGURATION":
        raise TimeDataError(f"{path}: FILE_TYPE = CONFIGURATION: a configuration file holds a "
                            "header and no data; expected TIME_HISTORY")  # fmt: skip
    if file_type != "TIME_HISTORY":
        raise TimeDataError(f"{path}: FILE_TYPE = {file_type!r}; expected TIME_HISTORY")
    time_type = header.get("TIME_TYPE", "").upper()
    if time_type in CONFIGURATION_TYPES:
        raise TimeDataError(f"{path}: TIME_TYPE = {header['TIME_TYPE']}: a configuration file "
                            "holds a header and no data; expected a time history (DRIVE, "
                            "RESPONSE, ...)")  # fmt: skip
    data_type = header.get("DATA_TYPE", "SHORT_INTEGER").upper()
    if data_type not in READ_TYPES:
        raise TimeDataError(f"{path}: DATA_TYPE = {data_type!r}; expected SHORT_INTEGER, "
                            "FLOATING_POINT or DOUBLE_PRECISION")  # fmt: skip
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
    n_points = frames * ppf
    n_keep = n_points
    if "SAMPLES" in header:
        n_keep = _int(header["SAMPLES"], "SAMPLES", path, lo=1)
        if n_keep > n_points:
            raise TimeDataError(f"{path}: SAMPLES = {n_keep}; expected at most the {n_points} "
                                f"points of FRAMES x PTS_PER_FRAME ({frames} x {ppf})")  # fmt: skip

    # the sizes against the file's, before anything per channel or per point is made
    dtype = np.dtype(BYTE_ORDERS[fmt] + READ_TYPES[data_type])
    n_groups = -(-n_points // ppg)
    rest = n_points - (n_groups - 1) * ppg  # points of each channel in the last group
    full = n_groups * n_ch * ppg * dtype.itemsize
    cut = ((n_groups - 1) * n_ch * ppg + n_ch * rest) * dtype.itemsize
    size = path.stat().st_size - offset
    if full <= size < full + BLOCK:  # at most the rest of a 512-byte record after the data
        nbytes = full
    elif size == cut:
        nbytes = cut
    else:
        more = f", and at most {BLOCK - 1} bytes more" if size > full else ""
        raise TimeDataError(f"{path}: {size} bytes of data after the header; {n_ch} channels x "
                            f"{n_points} points ({frames} frames of {ppf}) in {n_groups} groups "
                            f"of {ppg} need {full} (or {cut} with the last group cut "
                            f"short){more}")  # fmt: skip
    short = data_type == "SHORT_INTEGER"
    scales = np.ones(n_ch)
    if short:  # the step of the 16-bit converter; floats are engineering units already
        scales = np.array([_float(header.get(f"SCALE.CHAN_{c}", "1"), f"SCALE.CHAN_{c}", path)
                           for c in range(1, n_ch + 1)])  # fmt: skip
    names = tuple(header.get(f"DESC.CHAN_{c}", f"channel {c}") for c in range(1, n_ch + 1))
    units = tuple(header.get(f"UNITS.CHAN_{c}", "") for c in range(1, n_ch + 1))

    with open(path, "rb") as fh:
        fh.seek(offset)
        buffer = fh.read(nbytes)
    if len(buffer) < nbytes:  # the file shrank since its size was taken
        raise TimeDataError(f"{path}: the data end at byte {offset + len(buffer)}; expected "
                            f"{nbytes} bytes of data")  # fmt: skip
    stored = np.frombuffer(buffer, dtype=dtype)
    whole = (n_groups - 1) * n_ch * ppg  # the numbers of the groups before the last
    last = stored[whole:].reshape(n_ch, -1)[:, :rest]
    if n_groups > 1:
        head = stored[:whole].reshape(n_groups - 1, n_ch, ppg).transpose(1, 0, 2)
        values = np.concatenate([head.reshape(n_ch, -1), last], axis=1)
    else:  # one group: PTS_PER_GROUP may be any size beyond the points, not a shape
        values = last
    values = values[:, :n_keep]
    if not short and not np.isfinite(values).all():
        c = int(np.flatnonzero(~np.isfinite(values).all(axis=1))[0])
        k = int(np.flatnonzero(~np.isfinite(values[c]))[0])
        raise TimeDataError(f"{path}: channel {c + 1} ({names[c]!r}) sample {k} (t = "
                            f"{k * dt:g} s) is {float(values[c, k])!r}; expected finite "
                            "numbers")  # fmt: skip
    with np.errstate(over="ignore"):
        values = values.astype(np.float64) * scales[:, None]
    if short and np.abs(scales).max() > np.finfo(np.float64).max / 32768 and \
            not np.isfinite(values).all():  # only a huge SCALE can overflow  # fmt: skip
        c = int(np.flatnonzero(~np.isfinite(values).all(axis=1))[0])
        raise TimeDataError(f"{path}: SCALE.CHAN_{c + 1} = {header[f'SCALE.CHAN_{c + 1}']} "
                            f"times the stored short integers of channel {c + 1} "
                            f"({names[c]!r}) overflows; expected a SCALE that gives finite "
                            "values")  # fmt: skip
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
        For an unknown data type, non-finite samples, or floats beyond single precision.
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
        big = np.abs(data.values).max(axis=1) > np.finfo(np.float32).max
        if big.any():
            c = int(np.flatnonzero(big)[0])
            raise TimeDataError(f"channel {data.names[c]!r} reaches "
                                f"{np.abs(data.values[c]).max():.3g}, beyond the largest "
                                f"single-precision number ({np.finfo(np.float32).max:.3g}) an "
                                "RPC III FLOATING_POINT file holds")  # fmt: skip
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
