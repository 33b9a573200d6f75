"""FRF data sets: frequencies, H (n_out, n_in, n_freq), channel labels, quantity and units,
and conversion between units. Files are read and written by :mod:`femcal.testdata.formats`.

Channel labels are ``GRID:DIR`` where DIR is a component 1-6 or a signed basic axis
(``+X``, ``-Y``, ``+RZ``...), e.g. ``1001:3`` or ``1001:+Z``; other labels are kept as they
are (a grid of None).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from ..response.modal import QUANTITIES

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


# ----------------------------------------------------------------------------- units

#: Lengths in metres for the unit strings of FRFs (numerator of length/N, length/s/N,
#: length/s^2/N).
_LENGTHS = {"m": 1.0, "mm": 1e-3, "cm": 1e-2, "um": 1e-6, "in": 0.0254}
_G = 9.80665  # m/s^2 per g (standard gravity)


def _parse_units(units: str) -> tuple[str, float] | None:
    """(quantity, SI value of one unit) for FRF units such as ``mm/s^2/N``, ``(m/s2)/N``,
    ``g/N``, ``m/N``; None when the string is not one of these forms."""
    s = units.replace(" ", "").replace("(", "").replace(")", "").replace("²", "^2")
    s = s.replace("s2", "s^2").replace("*", "")
    if s.lower() == "g/n":
        return "accelerance", _G
    for length, metres in _LENGTHS.items():
        for suffix, quantity in (("/N", "receptance"), ("/s/N", "mobility"),
                                 ("/s^2/N", "accelerance")):  # fmt: skip
            if s == length + suffix:
                return quantity, metres
    return None


def quantity_of_units(units: str) -> str | None:
    """receptance, mobility or accelerance as the unit string says (``mm/s^2/N`` ->
    accelerance), or None if it says none of them."""
    parsed = _parse_units(units)
    return parsed[0] if parsed else None


def convert_units(data: FRFData, units: str) -> FRFData:
    """The same FRFs in other units of the same quantity (``g/N`` -> ``mm/s^2/N`` multiplies
    by 9806.65); ValueError naming both units if either is not understood or they measure
    different quantities."""
    have, want = _parse_units(data.units), _parse_units(units)
    if have is None or want is None:
        bad = data.units if have is None else units
        raise ValueError(f"cannot convert FRF units {data.units!r} to {units!r}: {bad!r} is "
                         "not one of length/N, length/s/N, length/s^2/N (length m, mm, cm, "
                         "um, in) or g/N")  # fmt: skip
    if have[0] != want[0] or have[0] != data.quantity:
        raise ValueError(f"cannot convert {data.quantity} in {data.units!r} to {units!r}")
    return FRFData(data.frequency_hz, data.H * (have[1] / want[1]), data.outputs, data.inputs,
                   data.quantity, units)  # fmt: skip
