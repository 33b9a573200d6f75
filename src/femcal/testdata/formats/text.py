"""FRF data as long-format CSV: one row per output, input and frequency."""

from __future__ import annotations

import csv
import io
import os
from pathlib import Path

import numpy as np

from ...atomic import write_atomic
from ..data import FRFData
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
    """Read what :func:`write_csv` writes; ValueError with the line for a bad row."""
    text = Path(path).read_text()
    quantity, units = "receptance", ""
    first, _, rest = text.partition("\n")
    if first.startswith("#"):  # "# quantity=Q units=U" (U may hold spaces)
        head, _, units = first[1:].partition(" units=")
        quantity = head.strip().removeprefix("quantity=") or quantity
        units = units.strip()
        text = rest
    rows = list(csv.reader(io.StringIO(text)))
    if not rows or rows[0] != _CSV_HEAD:
        raise ValueError(f"{path}: expected the header {','.join(_CSV_HEAD)}")
    outs: dict[str, int] = {}
    ins: dict[str, int] = {}
    freqs: dict[float, int] = {}
    values = []
    for n, r in enumerate(rows[1:], start=2 + (first.startswith("#"))):
        if len(r) != 5:
            raise ValueError(f"{path}:{n}: expected 5 fields, found {len(r)}")
        try:
            f, re_, im = float(r[0]), float(r[3]), float(r[4])
        except ValueError:
            raise ValueError(f"{path}:{n}: frequency, real and imag must be numbers") from None
        o = outs.setdefault(r[1], len(outs))
        i = ins.setdefault(r[2], len(ins))
        k = freqs.setdefault(f, len(freqs))
        values.append((o, i, k, complex(re_, im)))
    fs = np.array(sorted(freqs))
    order = {f: j for j, f in enumerate(fs)}
    kmap = np.array([order[f] for f in freqs])
    H = np.full((len(outs), len(ins), len(fs)), np.nan + 0j)
    for o, i, k, h in values:
        H[o, i, kmap[k]] = h
    if np.isnan(H.real).any():
        raise ValueError(f"{path}: not every output, input and frequency has a value")
    return FRFData.from_labels(fs, H, list(outs), list(ins), quantity, units)


register(Format("csv", "frf", (".csv",), read_csv, write_csv, "long-format CSV"))
