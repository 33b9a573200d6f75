"""FRF data as long-format CSV: one row per output, input and frequency."""

from __future__ import annotations

import csv
import io
import os
from pathlib import Path

import numpy as np

from ...atomic import write_atomic
from ...response.modal import QUANTITIES
from ..data import FRFData, FRFError, frf_of
from .registry import Format, register

_CSV_HEAD = ["frequency_hz", "output", "input", "real", "imag"]


def write_csv(path: str | os.PathLike[str], data: FRFData) -> Path:
    """Long-format CSV: a ``# quantity=... units=...`` line, then one row per output, input
    and frequency: frequency_hz, output, input, real, imag."""

    def dump(tmp: str) -> None:
        with open(tmp, "w", newline="") as fh:
            _csv_rows(fh, data)

    return write_atomic(path, dump)


def _csv_rows(fh, data: FRFData) -> None:
    fh.write(f"# quantity={data.quantity} units={data.units}\n")
    w = csv.writer(fh, lineterminator="\n")
    w.writerow(_CSV_HEAD)
    for o, co in enumerate(data.outputs):
        for i, ci in enumerate(data.inputs):
            for f, h in zip(data.frequency_hz, data.H[o, i], strict=True):
                row = [repr(float(f)), co.label, ci.label, repr(float(h.real)), repr(float(h.imag))]
                w.writerow(row)


def read_csv(path: str | os.PathLike[str]) -> FRFData:
    """Read what :func:`write_csv` writes: an optional ``# quantity=Q units=U`` line, the
    header, then one row per output, input and frequency, each exactly once, each line ended
    by a line break (a last line without one is taken for a file cut short).

    Raises
    ------
    FRFError
        Naming the file and line: a last line without a line break, no header or no rows,
        a row without 5 fields, a field that is not a number, a frequency or value that is
        not finite (or a negative frequency), a row that repeats an output, input and
        frequency, or an output, input and frequency that no row gives.
    """
    path = Path(path)
    try:
        text = path.read_text()
    except UnicodeDecodeError as e:
        raise FRFError(f"{path}: not a text file ({e})") from None
    if text and not text.endswith("\n"):  # a writer ends every row; a cut file does not
        raise FRFError(f"{path}:{text.count(chr(10)) + 1}: the last line does not end with a "
                       "line break: is the file cut short? (if the line is whole, end it "
                       "with a line break)")  # fmt: skip
    quantity, units = "receptance", ""
    first, _, rest = text.partition("\n")
    skipped = 0  # lines before the CSV text
    if first.startswith("#"):  # "# quantity=Q units=U" (U may hold spaces)
        head, _, units = first[1:].partition(" units=")
        quantity = head.strip().removeprefix("quantity=") or quantity
        units = units.strip()
        if quantity not in QUANTITIES:
            raise FRFError(f"{path}:1: quantity {quantity!r}; expected "
                           f"'# quantity=Q units=U' with Q one of {', '.join(QUANTITIES)}")
        text, skipped = rest, 1
    reader = csv.reader(io.StringIO(text))
    freqs: list[float] = []
    values: list[complex] = []
    lines: list[int] = []
    outs: dict[str, int] = {}
    ins: dict[str, int] = {}
    pairs: list[tuple[int, int]] = []
    header = None
    try:
        for r in reader:
            n = reader.line_num + skipped
            if header is None:
                if r != _CSV_HEAD:
                    raise FRFError(f"{path}:{n}: found {','.join(r)!r}; expected the header "
                                   f"{','.join(_CSV_HEAD)}")  # fmt: skip
                header = n
                continue
            if not r:  # a blank line
                continue
            if len(r) != 5:
                raise FRFError(f"{path}:{n}: expected 5 fields ({','.join(_CSV_HEAD)}), "
                               f"found {len(r)}")  # fmt: skip
            freqs.append(_number(r[0], "frequency_hz", path, n))
            values.append(complex(_number(r[3], "real", path, n), _number(r[4], "imag", path, n)))
            pairs.append((outs.setdefault(r[1], len(outs)), ins.setdefault(r[2], len(ins))))
            lines.append(n)
    except csv.Error as e:
        raise FRFError(f"{path}:{reader.line_num + skipped}: not CSV ({e})") from None
    if header is None:
        raise FRFError(f"{path}: no header; expected {','.join(_CSV_HEAD)}")
    if not lines:
        raise FRFError(f"{path}:{header}: no rows after the header; expected one row per "
                       "output, input and frequency")  # fmt: skip
    return _assemble(path, np.array(freqs), np.array(values), np.array(pairs),
                     np.array(lines), list(outs), list(ins), quantity, units)  # fmt: skip


def _number(text: str, field: str, path: Path, line: int) -> float:
    """One field as a float; FRFError naming the file, line and field otherwise."""
    try:
        return float(text)
    except ValueError:
        raise FRFError(f"{path}:{line}: {field} {text!r} is not a number") from None


def _assemble(path: Path, f: np.ndarray, h: np.ndarray, pairs: np.ndarray, lines: np.ndarray,
              outs: list[str], ins: list[str], quantity: str, units: str) -> FRFData:  # fmt: skip
    """The FRF set of the rows (frequency, value, (output, input) index, line each), every
    output, input and frequency given once; FRFError naming the line otherwise."""
    bad = np.flatnonzero(~np.isfinite(f) | (f < 0))
    if bad.size:
        k = bad[0]
        raise FRFError(f"{path}:{lines[k]}: frequency_hz is {float(f[k])!r}; expected a finite, "
                       "non-negative frequency in Hz")  # fmt: skip
    bad = np.flatnonzero(~np.isfinite(h))
    if bad.size:
        k = bad[0]
        o, i = pairs[k]
        raise FRFError(f"{path}:{lines[k]}: output {outs[o]} / input {ins[i]} at {f[k]:g} Hz: "
                       f"H is {h[k]}; expected finite real and imag")  # fmt: skip
    fs, kf = np.unique(f, return_inverse=True)
    n_o, n_i, n_f = len(outs), len(ins), len(fs)
    key = np.column_stack([pairs, kf])  # (rows, 3): output, input, frequency index
    order = np.lexsort(key.T[::-1])
    sk = key[order]
    same = np.flatnonzero((sk[1:] == sk[:-1]).all(axis=1))
    if same.size:
        a, b = np.sort(order[same[0]:same[0] + 2])
        o, i = pairs[a]
        raise FRFError(f"{path}:{lines[b]}: output {outs[o]} / input {ins[i]} at {f[a]:g} Hz "
                       f"is given again (first on line {lines[a]}); expected each output, "
                       "input and frequency once")  # fmt: skip
    # sorted and without repeats, row j is cell j of the full grid until one is missing
    j = np.arange(len(sk))
    want = np.column_stack([j // (n_i * n_f), j // n_f % n_i, j % n_f])
    gaps = np.flatnonzero((sk != want).any(axis=1))
    if gaps.size or len(sk) < n_o * n_i * n_f:
        o, i, k = want[gaps[0]] if gaps.size else (
            (len(sk) // (n_i * n_f), len(sk) // n_f % n_i, len(sk) % n_f))  # fmt: skip
        raise FRFError(f"{path}: output {outs[o]} / input {ins[i]} has no row at {fs[k]:g} Hz; "
                       f"expected a row for each of the {n_o} outputs x {n_i} inputs x "
                       f"{n_f} frequencies, found {len(lines)} rows")  # fmt: skip
    total = len(sk)
    cell = (pairs[:, 0] * n_i + pairs[:, 1]) * n_f + kf
    H = np.empty(total, complex)
    H[cell] = h
    return frf_of(str(path), fs, H.reshape(n_o, n_i, n_f), outs, ins, quantity, units)


register(Format("csv", "frf", (".csv",), read_csv, write_csv, "long-format CSV"))
