"""FRF data sets: frequencies, H (n_out, n_in, n_freq), channel labels, quantity and units,
with readers and writers (NPZ, CSV). Every file is written to a temporary name and renamed.

Channel labels are ``GRID:DIR`` where DIR is a component 1-6 or a signed basic axis
(``+X``, ``-Y``, ``+RZ``...), e.g. ``1001:3`` or ``1001:+Z``; other labels are kept as they
are (a grid of None).
"""

from __future__ import annotations

import csv
import io
import os
import re
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

QUANTITIES = ("receptance", "mobility", "accelerance")
_LABEL = re.compile(r"^\s*(\d+)\s*:\s*([+-]?(?:[1-6]|R?[XYZ]))\s*$", re.IGNORECASE)


@dataclass(frozen=True)
class Channel:
    """One input or output: its label, and the GRID and direction it names (if any)."""

    label: str
    grid: int | None = None
    direction: str | None = None

    @classmethod
    def parse(cls, label: str) -> Channel:
        m = _LABEL.match(label)
        if not m:
            return cls(label.strip())
        return cls(label.strip(), int(m.group(1)), m.group(2).upper())


@dataclass(frozen=True)
class FRFData:
    """A set of FRFs.

    Attributes
    ----------
    frequency_hz : (n_freq,) ascending, Hz.
    H : (n_out, n_in, n_freq) complex.
    outputs, inputs : channels (n_out,), (n_in,).
    quantity : receptance, mobility or accelerance.
    units : of H, e.g. ``mm/N`` (free text).
    """

    frequency_hz: np.ndarray
    H: np.ndarray
    outputs: tuple[Channel, ...]
    inputs: tuple[Channel, ...]
    quantity: str = "receptance"
    units: str = ""

    def __post_init__(self) -> None:
        f, H = np.asarray(self.frequency_hz), np.asarray(self.H)
        if H.ndim != 3 or H.shape != (len(self.outputs), len(self.inputs), len(f)):
            raise ValueError(
                f"H has shape {H.shape}; expected (n_out, n_in, n_freq) = "
                f"({len(self.outputs)}, {len(self.inputs)}, {len(f)})"
            )
        if self.quantity not in QUANTITIES:
            raise ValueError(f"quantity must be one of {', '.join(QUANTITIES)}, "
                             f"not {self.quantity!r}")  # fmt: skip
        if len(f) > 1 and np.any(np.diff(f) <= 0):
            raise ValueError("frequencies must be strictly ascending")

    @classmethod
    def from_labels(cls, frequency_hz, H, output_labels, input_labels, quantity="receptance",
                    units="") -> FRFData:  # fmt: skip
        return cls(np.asarray(frequency_hz, float), np.asarray(H, complex),
                   tuple(Channel.parse(str(s)) for s in output_labels),
                   tuple(Channel.parse(str(s)) for s in input_labels), quantity, units)  # fmt: skip


# ----------------------------------------------------------------------------- NPZ


def write_npz(path: str | os.PathLike[str], data: FRFData) -> Path:
    """NPZ with keys ``frequency_hz``, ``H``, ``input_labels``, ``output_labels``,
    ``quantity`` and ``units``."""

    def dump(fh) -> None:
        np.savez(fh, frequency_hz=data.frequency_hz, H=data.H,
                 output_labels=np.array([c.label for c in data.outputs]),
                 input_labels=np.array([c.label for c in data.inputs]),
                 quantity=np.array(data.quantity), units=np.array(data.units))  # fmt: skip

    return _atomic(Path(path), dump, binary=True)


def read_npz(path: str | os.PathLike[str]) -> FRFData:
    """Read what :func:`write_npz` writes (``units`` optional); KeyError names a missing key."""
    with np.load(path, allow_pickle=False) as z:
        missing = {"frequency_hz", "H", "input_labels", "output_labels", "quantity"} - set(z)
        if missing:
            raise KeyError(f"{path}: missing {', '.join(sorted(missing))}")
        units = str(z["units"]) if "units" in z else ""
        return FRFData.from_labels(z["frequency_hz"], z["H"], z["output_labels"],
                                   z["input_labels"], str(z["quantity"]), units)  # fmt: skip


# ----------------------------------------------------------------------------- CSV

_CSV_HEAD = ["frequency_hz", "output", "input", "real", "imag"]


def write_csv(path: str | os.PathLike[str], data: FRFData) -> Path:
    """Long-format CSV: a ``# quantity=... units=...`` line, then one row per output, input
    and frequency: frequency_hz, output, input, real, imag."""

    def dump(fh) -> None:
        fh.write(f"# quantity={data.quantity} units={data.units}\n")
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(_CSV_HEAD)
        for o, co in enumerate(data.outputs):
            for i, ci in enumerate(data.inputs):
                for f, h in zip(data.frequency_hz, data.H[o, i], strict=True):
                    w.writerow(
                        [
                            repr(float(f)),
                            co.label,
                            ci.label,
                            repr(float(h.real)),
                            repr(float(h.imag)),
                        ]
                    )

    return _atomic(Path(path), dump, binary=False)


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


def _atomic(path: Path, dump, *, binary: bool) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb" if binary else "w", **({} if binary else {"newline": ""})) as fh:
            dump(fh)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path
