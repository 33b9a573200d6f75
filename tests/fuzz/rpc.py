"""Fuzzing of femcal's RPC III reader (:func:`femcal.testdata.formats.rpc3.read_rpc3`).

Each case makes one valid RPC III time history at random, in the variants real writers give
(MTS's published layout, and what the public writers cited in tests/test_rpc3.py do):

- FORMAT ``BINARY_IEEE_LITTLE_END``, ``BINARY`` (little-endian) or ``BINARY_IEEE_BIG_END``;
- DATA_TYPE ``SHORT_INTEGER`` with a SCALE per channel (sometimes the keyword left out, the
  default; sometimes a channel all zero with SCALE 0), ``FLOATING_POINT`` (SCALE 1, left out or
  any: it applies to short integers only) or FEDEM's ``DOUBLE_PRECISION``;
- 1..30 channels, 1..12 frames of 1..128 points, PTS_PER_GROUP 1, 2, 4 or 8 frames, a last
  group padded (with zeros, or with each channel's last value) or cut short;
- the keywords after the first three in a writer's order or shuffled, optional ones left out
  (FILE_TYPE, DATA_TYPE, DESC, UNITS, SCALE), extra ones (DATE, OPERATION, PARENT_1,
  INT_FULL_SCALE 32752 or 32768, BYPASS_FILTER, HALF_FRAMES 0, REPEATS, PARTITIONS, MAP,
  LOWER_LIMIT, UPPER_LIMIT, a vendor's own), DESC and UNITS with blanks and Latin-1 signs
  (``µm/m``, ``°C``), records padded with NULs or blanks, spare header blocks, a SAMPLES count
  (python rpc3-file's writer), numbers in several notations, now and then a header whose
  strings are byte-swapped in pairs (``OFMRTA...``, which FEDEM's reader takes).

The case then changes the file (:func:`mutate`), by one or more of

- changes that keep its meaning (:data:`SAME`): records shuffled, extra or empty records, a
  spare block, the other padding, DELTA_T or a count written another way (``+0012``), a
  keyword in lower case, the header strings byte-swapped, a few bytes after padded data;
- at most one change of meaning (:data:`CHANGES`): a keyword removed or given twice, a count
  (CHANNELS, FRAMES, PTS_PER_FRAME, PTS_PER_GROUP, NUM_HEADER_BLOCKS, NUM_PARAMS, SAMPLES) made
  0, negative, off by one, doubled, not a number or huge (10^12 and more: terabytes), DELTA_T
  made 0, negative, NaN, infinite, huge or tiny, a SCALE made 0, negative, NaN, infinite or
  huge, FORMAT / DATA_TYPE / FILE_TYPE / TIME_TYPE / HALF_FRAMES given another value, the
  first three records out of order, non-ASCII bytes in a record, a DESC or UNITS changed;
  the file cut anywhere, bytes flipped in the header or the data, bytes inserted into or
  deleted from the header, junk appended.

What the reader must answer is known for most cases: the generator's channels, names, units
and step for a valid file or one changed only in form (and for the changes whose effect is
known: DESC or UNITS removed, a SCALE made 0), an error for a file that cannot be read
(a count that is not a whole number, DELTA_T 0, a keyword twice, a file cut short, ...);
nothing for the rest (a flipped byte may or may not matter). The mutated file is read by the
format's own reader (:attr:`Format.read`, so that the registry's net does not hide a stray
exception) under a time limit and, on Linux, a cap on the address space (1 GiB above what the
process holds: the files are under a megabyte, so anything near the cap is an attempt to
allocate what the header claims rather than what the file holds). Each case ends as

- ``ok``: read, and (where known) what the generator meant;
- ``clean error``: a :class:`~femcal.errors.TimeDataError` whose message names the file,
  for a file that is not what it should be;
- ``crash``: any other exception (a MemoryError too: the reader tried to allocate what the
  file does not hold), or a TimeDataError that does not name the file;
- ``hang``: the case ran past its time limit;
- ``wrong``: a file the generator meant to be valid (or changed only in form) that reads as
  other channels, names, units or step, or is refused; a broken one that reads without
  error; or samples that are not finite numbers.

``python -m tests.fuzz.rpc --seed 1 --n 5000`` runs a long campaign and prints the counts and
every case that is not ``ok`` or a clean error; :func:`write_case` writes one case's file again
(``SEED:K`` rebuilds case K of seed SEED alone) to keep it as a regression test.
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
import traceback
import warnings
from collections import Counter
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from femcal.errors import TimeDataError
from femcal.testdata.formats.registry import format_of
from femcal.testdata.timedata import TimeData

from .timeout import Timeout, alarm

#: The outcomes of a case, from best to worst.
OUTCOMES = ("ok", "clean error", "crash", "hang", "wrong")
#: Seconds a case may take before it counts as a hang.
TIMEOUT = 10.0
#: Bytes a case may allocate above what the process holds (Linux; see the docstring).
MEMORY_CAP = 1 << 30
BLOCK, RECORD = 512, 128
#: Suffixes the cases are written under (all are RPC III).
SUFFIXES = (".rsp", ".tim", ".drv")
#: What the expectation is when nothing is known of the answer.
ANY = None
#: The expectation of a file that must be refused.
ERROR = "error"


@dataclass(frozen=True)
class Intended:
    """What a valid file means: the step, the samples (channels x samples, float64, as the
    stored numbers times SCALE for short integers), the channel names and units."""

    dt: float
    values: np.ndarray
    names: tuple[str, ...]
    units: tuple[str, ...]


@dataclass
class RPCFile:
    """A file as the generator (and then the mutations) make it.

    ``records`` are the (keyword, value) records after the first three; ``lead`` holds text
    templates for the first three values (``{v}`` is the value the file's shape gives) and
    ``lead_order`` their order; ``body`` the data as written (``data_bytes`` of them the data
    proper: the last group full, ``full``, or cut short, ``cut``); ``trailing`` bytes after
    them. ``intended`` is what the file means while it stays valid."""

    fmt: str
    data_type: str
    records: list[list[str]]
    pad: bytes
    body: bytes
    layout: str  # "padded" or "cut"
    full: int
    cut: int
    intended: Intended
    variant: str
    counts: np.ndarray  # the stored numbers (channels x samples, float64)
    shape: tuple[int, int, int, int]  # CHANNELS, FRAMES, PTS_PER_FRAME, PTS_PER_GROUP
    itemsize: int
    spare_blocks: int = 0
    swapped: bool = False
    trailing: bytes = b""
    lead: dict[int, str] = field(default_factory=dict)
    lead_key: dict[int, str] = field(default_factory=dict)
    lead_order: tuple[int, int, int] = (0, 1, 2)

    def physical_blocks(self) -> int:
        return -(-(3 + len(self.records)) // 4) + self.spare_blocks


@dataclass(frozen=True)
class Finding:
    """One fuzz case and how it ended.

    Attributes
    ----------
    case : ``seed:index``, what :func:`write_case` takes to write the file again.
    variant : the valid file it started from (format, data type, shape, layout).
    mutation : what was changed (``"none"`` for the valid file).
    outcome : one of :data:`OUTCOMES`.
    error : ``Type: message`` of the exception (``""`` for ok); for a crash, the last frames
        of its traceback too; for ``wrong``, what differs.
    seconds : how long the case took.
    """

    case: str
    variant: str
    mutation: str
    outcome: str
    error: str
    seconds: float


# ----------------------------------------------------------------------------- valid files

_NAMES = ("Left front vert", "Act 1 disp", "FDO 54x Loc", "wheel force Z", "Strain gauge",
          "ACC 76z Glob", "right rear vert", "Pot", "x", "Spindle Fx (LF)")  # fmt: skip
_UNITS = ("mm", "N", "m/s^2", "g", "µm/m", "°C", "micro strain", "kN m", "in", "V", "deg")
_DATES = ("05-Oct-95 14:19:14", "14:19:14 05-OCT-1995", "Thu Oct  5 14:19:14 1995\n",
          "2024-01-31T12:00:00", "9:5:3 1-2-2024")  # fmt: skip
_STORED = {"SHORT_INTEGER": "i2", "FLOATING_POINT": "f4", "DOUBLE_PRECISION": "f8"}


def _choice(rng: np.random.Generator, seq: tuple | list):
    return seq[int(rng.integers(len(seq)))]


def _float_text(rng: np.random.Generator, x: float) -> str:
    """``x`` the way one writer or another writes a real number."""
    return _choice(rng, (f"{x:.6E}", repr(float(x)), f"{x:e}", f"{x:.8g}"))


def valid_file(rng: np.random.Generator) -> RPCFile:
    """A valid RPC III file in one of the variants of the module docstring."""
    big = rng.random() < 0.35
    fmt = "BINARY_IEEE_BIG_END" if big else _choice(rng, ("BINARY_IEEE_LITTLE_END", "BINARY"))
    order = ">" if big else "<"
    data_type = _choice(rng, ("SHORT_INTEGER",) * 5 + ("FLOATING_POINT",) * 4
                        + ("DOUBLE_PRECISION",))  # fmt: skip
    stored = np.dtype(order + _STORED[data_type])
    n_ch = int(rng.integers(1, 31))
    ppf = 2 ** int(rng.integers(0, 8))
    ppg = ppf * 2 ** int(rng.integers(0, 4))
    frames = int(rng.integers(1, 13))
    n = frames * ppf
    dt_text = _float_text(rng, float(_choice(rng, (1 / 512, 1 / 1024, 1 / 256, 4.8828125e-3,
                                                   1e-3, float(rng.uniform(1e-5, 1.0))))))  # fmt: skip

    records: list[list[str]] = [["CHANNELS", str(n_ch)], ["DELTA_T", dt_text],
                                ["PTS_PER_FRAME", str(ppf)], ["FRAMES", str(frames)],
                                ["PTS_PER_GROUP", str(ppg)]]  # fmt: skip
    if data_type != "SHORT_INTEGER" or rng.random() < 0.8:
        records.append(["DATA_TYPE", data_type])
    if rng.random() < 0.8:
        records.append(["FILE_TYPE", "TIME_HISTORY"])
    extras = [["DATE", _choice(rng, _DATES)], ["OPERATION", "RPC3 WRITER 1.0"],
              ["PARENT_1", r"C:\TEST\DATA\POT.RSP"],
              ["INT_FULL_SCALE", _choice(rng, ("32752", "32768"))],
              ["BYPASS_FILTER", _choice(rng, ("0", "1"))], ["HALF_FRAMES", "0"],
              ["REPEATS", _choice(rng, ("0", "1"))], ["PARTITIONS", "1"], ["PART.CHAN_1", "1"],
              ["PART.NCHAN_1", str(n_ch)],
              ["TIME_TYPE", _choice(rng, ("RESPONSE", "DRIVE", "1", "2", "MULT_RESP"))]]  # fmt: skip
    records += [r for r in extras if rng.random() < 0.5]
    records += [[f"X_VENDOR.KEY_{k}", _choice(rng, ("yes", "12", "a b c", ""))]
                for k in range(int(rng.integers(0, 4)))]  # fmt: skip

    if data_type == "SHORT_INTEGER":
        raw = rng.integers(-32768, 32768, size=(n_ch, n))
        scales = 10.0 ** rng.uniform(-6, 2, size=n_ch)
    else:
        raw = rng.standard_normal((n_ch, n)) * 10.0 ** rng.uniform(-3, 4, size=(n_ch, 1))
        scales = np.ones(n_ch)
    raw = raw.astype(stored)
    limits = rng.random() < 0.5
    names, units, factors = [], [], []
    for c in range(n_ch):
        name = f"{_choice(rng, _NAMES)} {c + 1}"
        unit = _choice(rng, _UNITS)
        if rng.random() < 0.92:
            records.append([f"DESC.CHAN_{c + 1}", name])
        else:
            name = f"channel {c + 1}"
        if rng.random() < 0.9:
            records.append([f"UNITS.CHAN_{c + 1}", unit])
        else:
            unit = ""
        factor = 1.0
        if data_type == "SHORT_INTEGER":
            if rng.random() < 0.05:  # all zero, SCALE 0 (pyRPC3's writer for a zero channel)
                raw[c] = 0
                text = "0.000000E+00"
            else:
                text = _float_text(rng, float(scales[c]))
            if rng.random() < 0.95:
                records.append([f"SCALE.CHAN_{c + 1}", text])
                factor = float(text)
        elif rng.random() < 0.8:  # floats: SCALE does not apply
            records.append([f"SCALE.CHAN_{c + 1}", _choice(rng, ("1", "1.0", "1.000000E+00",
                                                                 "3.053249E-04", "2.5"))])  # fmt: skip
        if limits:
            records += [[f"MAP.CHAN_{c + 1}", str(c + 1)],
                        [f"LOWER_LIMIT.CHAN_{c + 1}", "-1."],
                        [f"UPPER_LIMIT.CHAN_{c + 1}", "1."]]  # fmt: skip
        names.append(name)
        units.append(unit)
        factors.append(factor)

    n_groups = -(-n // ppg)
    rest = n - (n_groups - 1) * ppg
    layout = "cut" if rest < ppg and rng.random() < 0.4 else "padded"
    fill = _choice(rng, ("zeros", "last value"))
    chunks = []
    for g in range(n_groups):
        for c in range(n_ch):
            chunk = raw[c, g * ppg:(g + 1) * ppg]
            if layout == "padded" and len(chunk) < ppg:
                pad = np.zeros(ppg - len(chunk), stored) if fill == "zeros" else \
                    np.full(ppg - len(chunk), chunk[-1], stored)  # fmt: skip
                chunk = np.concatenate([chunk, pad])
            chunks.append(chunk.astype(stored).tobytes())  # concatenate makes it native
    body = b"".join(chunks)
    full = n_groups * n_ch * ppg * stored.itemsize
    cut = ((n_groups - 1) * n_ch * ppg + n_ch * rest) * stored.itemsize

    samples = n
    if rng.random() < 0.15:  # the real length before the last frame's padding (rpc3-file)
        samples = int(rng.integers(max(1, n - ppf + 1), n + 1))
        records.append(["SAMPLES", str(samples)])
    counts = raw[:, :samples].astype(np.float64)
    values = counts * np.array(factors)[:, None] if data_type == "SHORT_INTEGER" else counts

    if rng.random() < 0.5:
        records = [records[k] for k in rng.permutation(len(records))]
    pad = b"\0" if rng.random() < 0.7 else b" "
    spare = 0 if rng.random() < 0.8 else int(rng.integers(1, 3))
    swapped = bool(rng.random() < 0.05)
    variant = (f"{fmt} {data_type} {n_ch} ch, {frames} frames of {ppf}, groups of {ppg}, "
               f"{layout}{' (' + fill + ')' if layout == 'padded' and rest < ppg else ''}"
               f"{', SAMPLES ' + str(samples) if samples != n else ''}"
               f"{', blank padding' if pad == b' ' else ''}"
               f"{', byte-swapped header' if swapped else ''}")  # fmt: skip
    return RPCFile(fmt, data_type, records, pad, body, layout, full, cut,
                   Intended(float(dt_text), values, tuple(names), tuple(units)), variant,
                   counts, (n_ch, frames, ppf, ppg), stored.itemsize, spare_blocks=spare,
                   swapped=swapped)  # fmt: skip


def _record(key: str, value: str, pad: bytes) -> bytes:
    k = key.encode("latin-1", "replace")[:32]
    v = value.encode("latin-1", "replace")[:96]
    return k.ljust(32, pad) + v.ljust(96, pad)


def header_bytes(f: RPCFile) -> bytes:
    """The header of ``f`` as written: its physical blocks, the first three records from
    its shape (or their templates), the others, the rest of the last block padded."""
    blocks = f.physical_blocks()
    lead = [["FORMAT", f.fmt], ["NUM_HEADER_BLOCKS", str(blocks)],
            ["NUM_PARAMS", str(3 + len(f.records))]]  # fmt: skip
    for k, template in f.lead.items():
        lead[k][1] = template.format(v=lead[k][1])
    for k, key in f.lead_key.items():
        lead[k][0] = key
    lead = [lead[k] for k in f.lead_order]
    raw = b"".join(_record(k, v, f.pad) for k, v in [*lead, *f.records])
    raw = raw.ljust(blocks * BLOCK, f.pad)
    if f.swapped:
        b = bytearray(raw)
        b[0::2], b[1::2] = raw[1::2], raw[0::2]
        raw = bytes(b)
    return raw


def file_bytes(f: RPCFile) -> bytes:
    return header_bytes(f) + f.body + f.trailing


# ----------------------------------------------------------------------------- mutations

Expect = Intended | str | None


def _find(f: RPCFile, key: str) -> int | None:
    """Index of the record ``key`` (in any case), or None."""
    return next((k for k, (name, _) in enumerate(f.records) if name.upper() == key), None)


def _set(f: RPCFile, key: str, value: str) -> None:
    """Give the record ``key`` the value ``value``, adding the record if there is none."""
    k = _find(f, key)
    if k is None:
        f.records.append([key, value])
    else:
        f.records[k][1] = value


def _keyed(f: RPCFile) -> list[int]:
    return [k for k, (name, _) in enumerate(f.records) if name.strip()]


def _shuffle(rng: np.random.Generator, f: RPCFile) -> str:
    f.records = [f.records[k] for k in rng.permutation(len(f.records))]
    return "records shuffled"


def _extra(rng: np.random.Generator, f: RPCFile) -> str:
    n, first = int(rng.integers(1, 4)), len(f.records)
    for k in range(first, first + n):
        at = int(rng.integers(len(f.records) + 1))
        f.records.insert(at, [f"ZZ_EXTRA_{k}", _choice(rng, ("1", "text with blanks", ""))])
    return f"{n} unknown keywords added"


def _spare(rng: np.random.Generator, f: RPCFile) -> str:
    n = int(rng.integers(1, 3))
    f.spare_blocks += n
    return f"{n} spare header blocks"


def _padding(rng: np.random.Generator, f: RPCFile) -> str:
    f.pad = b" " if f.pad == b"\0" else b"\0"
    return f"records padded with {f.pad!r}"


def _empty(rng: np.random.Generator, f: RPCFile) -> str:
    n = int(rng.integers(1, 4))
    for _ in range(n):
        f.records.insert(int(rng.integers(len(f.records) + 1)), ["", ""])
    return f"{n} empty records among NUM_PARAMS"


def _dt_form(rng: np.random.Generator, f: RPCFile) -> str:
    k = _find(f, "DELTA_T")
    dt = f.intended.dt
    f.records[k][1] = _choice(rng, (repr(dt), f"{dt:.17E}", f"{dt:.17g}", f" {dt!r} "))
    return f"DELTA_T written {f.records[k][1]!r}"


def _count_form(rng: np.random.Generator, f: RPCFile) -> str:
    keys = [k for k in ("CHANNELS", "FRAMES", "PTS_PER_FRAME", "PTS_PER_GROUP", "SAMPLES")
            if _find(f, k) is not None] + ["NUM_HEADER_BLOCKS", "NUM_PARAMS"]  # fmt: skip
    key = _choice(rng, keys)
    template = _choice(rng, ("+{v}", "00{v}", " {v} ", "+000{v}"))
    if key in ("NUM_HEADER_BLOCKS", "NUM_PARAMS"):
        f.lead[1 if key == "NUM_HEADER_BLOCKS" else 2] = template
    else:
        k = _find(f, key)
        f.records[k][1] = template.format(v=int(f.records[k][1]))
    return f"{key} written {template!r}"


def _lower(rng: np.random.Generator, f: RPCFile) -> str:
    keyed = _keyed(f)
    if rng.random() < 0.2 or not keyed:
        f.lead_key[0] = "format"
        return "FORMAT keyword in lower case"
    k = _choice(rng, keyed)
    f.records[k][0] = f.records[k][0].lower()
    return f"keyword {f.records[k][0]} in lower case"


def _swap_strings(rng: np.random.Generator, f: RPCFile) -> str:
    f.swapped = not f.swapped
    return "header strings byte-swapped" if f.swapped else "header strings swapped back"


def _trailing(rng: np.random.Generator, f: RPCFile) -> str:
    if f.layout != "padded" or len(f.trailing) >= BLOCK - 1:
        return _shuffle(rng, f)
    n = int(rng.integers(1, BLOCK - len(f.trailing)))
    f.trailing += rng.integers(256, size=n).astype(np.uint8).tobytes()
    return f"{n} bytes after the data"


#: Changes of form only: the file means what it meant.
SAME: tuple[Callable[[np.random.Generator, RPCFile], str], ...] = (
    _shuffle, _extra, _spare, _padding, _empty, _dt_form, _count_form, _lower, _swap_strings,
    _trailing,
)  # fmt: skip

#: Values a count is replaced by (the original's neighbours are added per case).
BAD_COUNTS = ("0", "-1", "-4096", "", "x", "1.5", "1e3", "nan", "0x10", "2 048", "１２",
              "1000000000000", "1000000000000000000", "9" * 40, "9" * 90, "4294967296",
              "1099511627776")  # fmt: skip
#: Values DELTA_T is replaced by.
BAD_REALS = ("0", "0.0", "-0.001953125", "-1", "nan", "NaN", "inf", "-inf", "1e308", "1e-320",
             "", "x", "1,5", "1.0.0", "1e999", "5E-324")  # fmt: skip
#: Values a SCALE is replaced by.
BAD_SCALES = ("0", "0.0", "-2.5", "nan", "inf", "-inf", "1e308", "", "x", "1e-320")


def _whole(text: str) -> int | None:
    """The whole number ``text`` is, as a reader takes it (blanks and a sign allowed; ASCII
    digits only), or None."""
    t = text.strip()
    if not t or not t.lstrip("+-").isdigit() or not t.isascii():
        return None
    return int(t)


def _real(text: str) -> float | None:
    try:
        return float(text)
    except ValueError:
        return None


def _remove(rng: np.random.Generator, f: RPCFile) -> tuple[str, Expect]:
    key, _ = f.records.pop(_choice(rng, _keyed(f)))
    name, i = key.upper(), f.intended
    what = f"{key} removed"
    if name in ("CHANNELS", "DELTA_T", "PTS_PER_FRAME", "FRAMES", "PTS_PER_GROUP"):
        return what, ERROR
    if name == "DATA_TYPE":
        return what, i if f.data_type == "SHORT_INTEGER" else ANY
    if name == "SAMPLES":
        return what, ANY  # the padding of the last frame is data again
    if name.startswith(("DESC.CHAN_", "UNITS.CHAN_", "SCALE.CHAN_")):
        c = int(name.rsplit("_", 1)[1]) - 1
        if name.startswith("DESC"):
            names = list(i.names)
            names[c] = f"channel {c + 1}"
            return what, replace(i, names=tuple(names))
        if name.startswith("UNITS"):
            units = list(i.units)
            units[c] = ""
            return what, replace(i, units=tuple(units))
        if f.data_type == "SHORT_INTEGER":  # SCALE 1: the stored numbers
            v = i.values.copy()
            v[c] = f.counts[c]
            return what, replace(i, values=v)
    return what, i


def _duplicate(rng: np.random.Generator, f: RPCFile) -> tuple[str, Expect]:
    key, value = f.records[_choice(rng, _keyed(f))]
    new = value if rng.random() < 0.5 else _choice(rng, ("1", "0", "x", value + "0"))
    f.records.insert(int(rng.integers(len(f.records) + 1)), [key, new])
    return f"{key} given twice ({value!r}, {new!r})", ERROR


def _count(rng: np.random.Generator, f: RPCFile) -> tuple[str, Expect]:
    keys = [k for k in ("CHANNELS", "FRAMES", "PTS_PER_FRAME", "PTS_PER_GROUP", "SAMPLES")
            if _find(f, k) is not None] + ["NUM_HEADER_BLOCKS", "NUM_PARAMS", "HALF_FRAMES"]  # fmt: skip
    key = _choice(rng, keys)
    if key == "NUM_HEADER_BLOCKS":
        old = f.physical_blocks()
    elif key == "NUM_PARAMS":
        old = 3 + len(f.records)
    elif key == "HALF_FRAMES":
        old = 0
    else:
        old = int(f.records[_find(f, key)][1])
    value = _choice(rng, (*BAD_COUNTS, str(old + 1), str(old - 1), str(2 * old),
                          str(old // 2), str(old + 1)))  # fmt: skip
    if key in ("NUM_HEADER_BLOCKS", "NUM_PARAMS"):
        f.lead[1 if key == "NUM_HEADER_BLOCKS" else 2] = value
    elif _find(f, key) is None:
        f.records.append([key, value])
    else:
        f.records[_find(f, key)][1] = value
    what = f"{key} = {value!r} (was {old})"
    v = _whole(value)
    if v is None or v < (0 if key == "HALF_FRAMES" else 1) or (key == "NUM_PARAMS" and v < 3):
        return what, ERROR
    if v == old:
        return what, f.intended
    n_ch, frames, ppf, _ = f.shape
    stored = len(f.body) + len(f.trailing)
    if key == "HALF_FRAMES":
        return what, ERROR
    if key == "CHANNELS" and v * frames * ppf * f.itemsize > stored:
        return what, ERROR  # more than the file holds (terabytes, for the huge ones)
    if key == "FRAMES" and n_ch * v * ppf * f.itemsize > stored:
        return what, ERROR
    if key == "PTS_PER_FRAME" and n_ch * frames * v * f.itemsize > stored:
        return what, ERROR
    if key == "NUM_HEADER_BLOCKS" and v * BLOCK > f.physical_blocks() * BLOCK + stored:
        return what, ERROR
    if key == "NUM_PARAMS" and v > 4 * f.physical_blocks():
        return what, ERROR
    if key == "SAMPLES":
        if v > frames * ppf:
            return what, ERROR
        n = f.intended.values.shape[1]
        return what, ANY if v > n else replace(f.intended, values=f.intended.values[:, :v])
    return what, ANY


def _dt(rng: np.random.Generator, f: RPCFile) -> tuple[str, Expect]:
    value = _choice(rng, BAD_REALS)
    f.records[_find(f, "DELTA_T")][1] = value
    dt = _real(value)
    if dt is None or not (math.isfinite(dt) and dt > 0):
        return f"DELTA_T = {value!r}", ERROR
    return f"DELTA_T = {value!r}", replace(f.intended, dt=dt)


def _scale(rng: np.random.Generator, f: RPCFile) -> tuple[str, Expect]:
    c = int(rng.integers(len(f.intended.names)))
    key, value = f"SCALE.CHAN_{c + 1}", _choice(rng, BAD_SCALES)
    _set(f, key, value)
    what = f"{key} = {value!r}"
    if f.data_type != "SHORT_INTEGER":
        return what, f.intended  # SCALE applies to short integers only
    factor = _real(value)
    if factor is None or not math.isfinite(factor):
        return what, ERROR
    v = f.intended.values.copy()
    with np.errstate(over="ignore"):
        v[c] = f.counts[c] * factor
    if not np.isfinite(v[c]).all():
        return what, ERROR  # samples that overflow
    return what, replace(f.intended, values=v)


def _enum(rng: np.random.Generator, f: RPCFile) -> tuple[str, Expect]:
    key = _choice(rng, ("FORMAT", "DATA_TYPE", "FILE_TYPE", "TIME_TYPE"))
    if key == "FORMAT":
        value = _choice(rng, ("ASCII", "BINARY_VAX", "", "BINARY_IEEE", "binary_ieee_little_end",
                              "BINARY_IEEE_BIG_END", "BINARY_IEEE_LITTLE_END"))  # fmt: skip
        f.lead[0] = value
        order = {"BINARY_IEEE_LITTLE_END": "<", "BINARY": "<", "BINARY_IEEE_BIG_END": ">"}
        what, now = f"FORMAT = {value!r} (was {f.fmt})", order.get(value.upper())
        if now is None:
            return what, ERROR
        return what, f.intended if now == order[f.fmt] else ANY
    value = _choice(rng, {
        "DATA_TYPE": ("FLOATING_POINT", "SHORT_INTEGER", "DOUBLE_PRECISION", "INTEGER", "",
                      "floating_point", "LONG"),
        "FILE_TYPE": ("CONFIGURATION", "MATRIX", "HISTOGRAM", "", "time_history"),
        "TIME_TYPE": ("CONFIG_RESP", "CONFIG_DRIVE", "5", "6", "PEAK_PICK", "DRIVE")}[key])  # fmt: skip
    _set(f, key, value)
    what = f"{key} = {value!r}"
    if key == "DATA_TYPE":
        if value.upper() == f.data_type:
            return what, f.intended
        return what, ANY if value.upper() in _STORED else ERROR
    if key == "FILE_TYPE":
        return what, f.intended if value.upper() == "TIME_HISTORY" else ERROR
    return what, ERROR if value in ("CONFIG_RESP", "CONFIG_DRIVE", "5", "6") else f.intended


def _lead_order(rng: np.random.Generator, f: RPCFile) -> tuple[str, Expect]:
    f.lead_order = _choice(rng, ((1, 0, 2), (0, 2, 1), (2, 1, 0), (1, 2, 0), (2, 0, 1)))
    return f"first three records in order {f.lead_order}", ERROR


def _non_ascii(rng: np.random.Generator, f: RPCFile) -> tuple[str, Expect]:
    k = _choice(rng, _keyed(f))
    part = int(rng.integers(2))
    text = f.records[k][part]
    at = int(rng.integers(len(text) + 1))
    junk = "".join(chr(int(x)) for x in rng.integers(0x80, 0x100, size=int(rng.integers(1, 4))))
    f.records[k][part] = text[:at] + junk + text[at:]
    return f"non-ASCII {junk!r} in the {('keyword', 'value')[part]} of {text!r}", ANY


def _text(rng: np.random.Generator, f: RPCFile) -> tuple[str, Expect]:
    c = int(rng.integers(len(f.intended.names)))
    kind = _choice(rng, ("DESC", "UNITS"))
    key = f"{kind}.CHAN_{c + 1}"
    value = _choice(rng, ("two  blanks inside", "Müller µ-Gauge °3", "N·m", "a", "x" * 95))
    _set(f, key, value)
    texts = list(f.intended.names if kind == "DESC" else f.intended.units)
    texts[c] = value
    field_ = "names" if kind == "DESC" else "units"
    return f"{key} = {value!r}", replace(f.intended, **{field_: tuple(texts)})


#: Changes of meaning made to the records (each returns what is known of the answer).
CHANGES = (_remove, _duplicate, _count, _count, _count, _dt, _scale, _enum, _lead_order,
           _non_ascii, _text)  # fmt: skip


def _truncate(rng: np.random.Generator, f: RPCFile, raw: bytes) -> tuple[str, bytes, Expect]:
    t = int(rng.integers(len(raw)))
    head = f.physical_blocks() * BLOCK
    what = f"cut at byte {t} of {len(raw)}"
    if f.layout == "padded" and t >= head + f.full:
        return what, raw[:t], f.intended
    if f.layout == "padded" and t == head + f.cut and f.cut < f.full:
        return what, raw[:t], ANY  # reads as a file whose last group is cut short
    return what, raw[:t], ERROR


def _flip(rng: np.random.Generator, f: RPCFile, raw: bytes) -> tuple[str, bytes, Expect]:
    head = f.physical_blocks() * BLOCK
    in_header = rng.random() < 0.6 or len(raw) <= head
    lo, hi = (0, head) if in_header else (head, len(raw))
    b = bytearray(raw)
    at = sorted(int(x) for x in rng.integers(lo, hi, size=int(rng.integers(1, 5))))
    for k in at:
        b[k] ^= 1 << int(rng.integers(8))
    return f"bits flipped in the {'header' if in_header else 'data'} at {at}", bytes(b), ANY


def _splice(rng: np.random.Generator, f: RPCFile, raw: bytes) -> tuple[str, bytes, Expect]:
    a = int(rng.integers(f.physical_blocks() * BLOCK))
    n = int(rng.integers(1, 200))
    if rng.random() < 0.5:
        return f"header bytes {a}-{a + n} deleted", raw[:a] + raw[a + n:], ANY
    junk = rng.integers(256, size=n).astype(np.uint8).tobytes()
    return f"{n} bytes inserted into the header at {a}", raw[:a] + junk + raw[a:], ANY


def _append(rng: np.random.Generator, f: RPCFile, raw: bytes) -> tuple[str, bytes, Expect]:
    n = int(_choice(rng, (1, 2, 7, 100, 511, 512, 513, 4096, 100_000)))
    junk = rng.integers(256, size=n).astype(np.uint8).tobytes()
    what = f"{n} junk bytes appended"
    if f.layout != "padded":
        return what, raw + junk, ANY  # may reach a padded file's size
    return what, raw + junk, f.intended if len(f.trailing) + n < BLOCK else ERROR


#: Changes made to the bytes of the written file.
BYTE_CHANGES = (_truncate, _truncate, _flip, _flip, _splice, _append)


def mutate(rng: np.random.Generator, f: RPCFile) -> tuple[str, bytes, Expect]:
    """Change ``f`` (see the module docstring): (what was done, the file's bytes, what the
    reader must answer: an :class:`Intended`, :data:`ERROR` or :data:`ANY`). One case in
    eight keeps the valid file, one in four changes its form only, the others change its
    form or not and then its meaning once (the records three times in five, else the
    bytes)."""
    choice = rng.random()
    if choice < 0.12:
        return "none", file_bytes(f), f.intended
    n_same = int(rng.integers(1, 4)) if choice < 0.37 else int(rng.integers(0, 3))
    done = [_choice(rng, SAME)(rng, f) for _ in range(n_same)]
    expect: Expect = f.intended
    if choice < 0.37:
        raw = file_bytes(f)
    elif rng.random() < 0.6:
        what, expect = _choice(rng, CHANGES)(rng, f)
        done.append(what)
        raw = file_bytes(f)
    else:
        what, raw, expect = _choice(rng, BYTE_CHANGES)(rng, f, file_bytes(f))
        done.append(what)
    return "; ".join(done), raw, expect


# ----------------------------------------------------------------------------- running


def _address_space() -> int | None:
    """Bytes of address space the process holds (Linux), or None."""
    try:
        pages = int(Path("/proc/self/statm").read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return None
    import resource

    return pages * resource.getpagesize()


@contextmanager
def _memory_cap(extra: int) -> Iterator[None]:
    """Cap the address space at what the process holds plus ``extra`` bytes for the block
    (Linux; elsewhere no cap): an allocation of what a header claims fails at once, as a
    MemoryError, instead of swapping the machine."""
    held = _address_space()
    if held is None:
        yield
        return
    import resource

    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    cap = held + extra
    for limit in (soft, hard):  # never above a limit already set
        if limit != resource.RLIM_INFINITY:
            cap = min(cap, limit)
    resource.setrlimit(resource.RLIMIT_AS, (cap, hard))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))


def _differences(data: TimeData, want: Intended) -> str:
    """How ``data`` differs from what the generator meant (``""`` if not at all)."""
    out = []
    if data.dt != want.dt:
        out.append(f"dt {data.dt!r}, meant {want.dt!r}")
    if data.names != want.names:
        out.append(f"names {data.names}, meant {want.names}")
    if data.units != want.units:
        out.append(f"units {data.units}, meant {want.units}")
    if data.values.shape != want.values.shape:
        out.append(f"values of shape {data.values.shape}, meant {want.values.shape}")
    elif not np.array_equal(data.values, want.values):
        c, k = np.argwhere(data.values != want.values)[0]
        out.append(f"channel {c + 1} sample {k}: {data.values[c, k]!r}, meant "
                   f"{want.values[c, k]!r}")  # fmt: skip
    return "; ".join(out)


def _broken_promise(data: object) -> str:
    """What a TimeData read without error breaks (``""`` if nothing)."""
    if not isinstance(data, TimeData):
        return f"the reader returned {type(data).__name__}, not TimeData"
    v = data.values
    if v.ndim != 2 or v.shape[0] < 1 or v.shape[1] < 1:
        return f"values of shape {v.shape}"
    if not np.isfinite(v).all():
        c, k = np.argwhere(~np.isfinite(v))[0]
        return f"channel {c + 1} sample {k} is {v[c, k]!r}: not a finite number"
    if not (math.isfinite(data.dt) and data.dt > 0):
        return f"dt = {data.dt!r}"
    if not all(isinstance(s, str) for s in (*data.names, *data.units)):
        return "a name or unit that is not text"
    return ""


def run_case(path: Path, expect: Expect = ANY, *, timeout: float = TIMEOUT,
             memory: int | None = MEMORY_CAP) -> tuple[str, str]:  # fmt: skip
    """Read ``path`` with its format's reader and judge the answer against ``expect`` (what
    the generator meant, :data:`ERROR` or :data:`ANY`): (outcome, detail) as the module
    docstring defines them."""
    reader = format_of(path, "time").read
    cap = _memory_cap(memory) if memory else _no_cap()
    try:
        with alarm(timeout) as fired, warnings.catch_warnings(), cap:
            warnings.simplefilter("ignore")
            try:
                data = reader(path)
            except TimeDataError as e:
                if fired[0]:
                    return "hang", f"timed out after {timeout:g} s"
                text = f"{type(e).__name__}: {e}"
                if str(path) not in str(e):
                    return "crash", f"an error that does not name the file: {text}"
                if isinstance(expect, Intended):
                    return "wrong", f"refused a valid file: {text}"
                return "clean error", text
            except Exception as e:
                if fired[0]:
                    return "hang", f"timed out after {timeout:g} s"
                frames = "".join(traceback.format_tb(e.__traceback__)[-3:])
                return "crash", f"{type(e).__name__}: {e}\n{frames}"
    except Timeout:
        return "hang", f"timed out after {timeout:g} s"
    if fired[0]:
        return "hang", f"timed out after {timeout:g} s"
    broken = _broken_promise(data)
    if broken:
        return "wrong", broken
    if expect == ERROR:
        return "wrong", "read without error a file that cannot be read"
    if isinstance(expect, Intended):
        diff = _differences(data, expect)
        if diff:
            return "wrong", diff
    return "ok", ""


@contextmanager
def _no_cap() -> Iterator[None]:
    yield


def _case(seed: int, index: int) -> tuple[str, str, bytes, Expect, str]:
    """(variant, mutation, bytes, expectation, suffix) of case ``index`` of ``seed``: each
    case its own random stream, so that any case can be made again alone."""
    rng = np.random.default_rng([seed, index])
    f = valid_file(rng)
    variant = f.variant
    what, raw, expect = mutate(rng, f)
    return variant, what, raw, expect, SUFFIXES[index % len(SUFFIXES)]


def write_case(case: str, directory: str | Path) -> Path:
    """Write the file of case ``seed:index`` into ``directory`` again (for a regression
    test); returns its path."""
    seed, index = (int(x) for x in case.split(":"))
    _, _, raw, _, suffix = _case(seed, index)
    path = Path(directory) / f"case_{seed}_{index}{suffix}"
    path.write_bytes(raw)
    return path


def expectation(case: str) -> Expect:
    """What the reader must answer for case ``seed:index`` (see :func:`mutate`)."""
    seed, index = (int(x) for x in case.split(":"))
    return _case(seed, index)[3]


def run_rpc_fuzz(seed: int, n: int, *, timeout: float = TIMEOUT) -> list[Finding]:
    """Run cases ``0 .. n-1`` of ``seed`` and return how each ended."""
    findings = []
    with tempfile.TemporaryDirectory(prefix="femcal-fuzz-rpc-") as tmp:
        directory = Path(tmp)
        for index in range(n):
            variant, what, raw, expect, suffix = _case(seed, index)
            path = directory / f"case{suffix}"
            path.write_bytes(raw)
            t0 = time.perf_counter()
            outcome, error = run_case(path, expect, timeout=timeout)
            findings.append(Finding(f"{seed}:{index}", variant, what, outcome, error,
                                    time.perf_counter() - t0))  # fmt: skip
    return findings


def summary(findings: list[Finding]) -> str:
    """Counts by outcome, on one line, and the valid files' and the changes' share of them."""
    total = Counter(f.outcome for f in findings)
    valid = Counter(f.outcome for f in findings if f.mutation == "none")
    return ("all: " + ", ".join(f"{total[o]} {o}" for o in OUTCOMES) + "\nunchanged valid "
            "files: " + ", ".join(f"{valid[o]} {o}" for o in OUTCOMES))  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    """``python -m tests.fuzz.rpc --seed S --n N``: run a campaign, print the counts and
    every crash, hang and wrong answer; exit status 1 if there was any."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--n", type=int, default=1000)
    parser.add_argument("--timeout", type=float, default=TIMEOUT)
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    findings = run_rpc_fuzz(args.seed, args.n, timeout=args.timeout)
    seconds = time.perf_counter() - t0
    bad = [f for f in findings if f.outcome in ("crash", "hang", "wrong")]
    for f in bad:
        print(f"{f.case} [{f.variant}] [{f.mutation}] {f.outcome}: {f.error}")
    print(summary(findings))
    slowest = max(findings, key=lambda f: f.seconds)
    print(f"{len(findings)} cases in {seconds:.1f} s; slowest {slowest.case} "
          f"({slowest.seconds:.2f} s)")
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
