"""FRF data sets: frequencies, H (n_out, n_in, n_freq), channel labels, quantity and units,
and conversion between units. Files are read and written by :mod:`femcal.testdata.formats`.

Channel labels are ``GRID:DIR`` where DIR is a component 1-6 or a signed basic axis
(``+X``, ``-Y``, ``+RZ``...), e.g. ``1001:3`` or ``1001:+Z``; other labels are kept as they
are (a grid of None).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import FRFError
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
    coherence : in [0, 1], when the FRFs were estimated from time histories: (n_out, n_freq)
        the multiple coherence of each output (the share of its power the inputs explain),
        or (n_out, n_in, n_freq) the coherence of each FRF (an impact test's ordinary
        coherence, each hammer point measured on its own); None otherwise.
    """

    frequency_hz: np.ndarray
    H: np.ndarray
    outputs: tuple[Channel, ...]
    inputs: tuple[Channel, ...]
    quantity: str = "receptance"
    units: str = ""
    coherence: np.ndarray | None = None

    def __post_init__(self) -> None:
        """Check the shapes, the quantity and the frequency axis (FRFError naming what is
        wrong); H may hold NaN for pairs not measured (see :func:`~femcal.testdata.runs.
        assemble_runs`), which :func:`check_values` refuses where values are needed."""
        f, H = np.asarray(self.frequency_hz), np.asarray(self.H)
        if f.ndim != 1:
            raise FRFError(f"the frequencies have shape {f.shape}; expected one axis")
        if H.ndim != 3 or H.shape != (len(self.outputs), len(self.inputs), len(f)):
            raise FRFError(
                f"H has shape {H.shape}; expected (n_out, n_in, n_freq) = "
                f"({len(self.outputs)}, {len(self.inputs)}, {len(f)})"
            )
        if self.coherence is not None:
            c = np.asarray(self.coherence)
            if c.shape not in ((H.shape[0], H.shape[2]), H.shape):
                raise FRFError(f"the coherence has shape {c.shape}; expected (n_out, n_freq) = "
                               f"({H.shape[0]}, {H.shape[2]}) or (n_out, n_in, n_freq) = "
                               f"{H.shape}")  # fmt: skip
            if c.dtype.kind not in "iuf":
                raise FRFError(f"the coherence holds {c.dtype} values; expected real numbers "
                               "in [0, 1]")  # fmt: skip
            bad = ~((c >= 0) & (c <= 1))
            if bad.any():
                at = tuple(int(x) for x in np.argwhere(bad)[0])
                chans = f"output {self.outputs[at[0]].label}" + (
                    f" / input {self.inputs[at[1]].label}" if c.ndim == 3 else "")
                raise FRFError(f"the coherence of {chans} at {float(f[at[-1]]):g} Hz is "
                               f"{float(c[at])!r} ({int(bad.sum())} such value"
                               f"{'s' if bad.sum() > 1 else ''}); expected a coherence in "
                               "[0, 1] at each frequency (outside [0, 1]; NaN where the "
                               "estimator had no power)")  # fmt: skip
        if self.quantity not in QUANTITIES:
            raise FRFError(f"quantity must be one of {', '.join(QUANTITIES)}, "
                           f"not {self.quantity!r}")  # fmt: skip
        check_frequencies(f)

    @classmethod
    def from_labels(cls, frequency_hz, H, output_labels, input_labels, quantity="receptance",
                    units="") -> FRFData:  # fmt: skip
        return cls(np.asarray(frequency_hz, float), np.asarray(H, complex),
                   tuple(Channel.parse(str(s)) for s in output_labels),
                   tuple(Channel.parse(str(s)) for s in input_labels), quantity, units)  # fmt: skip


# ----------------------------------------------------------------------------- checks


def _at(where: str) -> str:
    return f"{where}: " if where else ""


def check_frequencies(frequency_hz: np.ndarray, where: str = "") -> None:
    """Refuse a frequency axis that is not finite, has a negative frequency or is not
    strictly increasing.

    Parameters
    ----------
    frequency_hz : (n_freq,) Hz.
    where : what the message names first (a file, ``file: variable``), or ``""``.

    Raises
    ------
    FRFError
        Naming the first offending frequency by its position (1-based, ``frequency 11 of
        220``) and value, and what was expected.
    """
    f = np.asarray(frequency_hz)
    n = len(f)
    if f.dtype.kind not in "iuf":
        raise FRFError(f"{_at(where)}the frequencies are {f.dtype} values; expected real "
                       "numbers in Hz")  # fmt: skip
    expected = "expected finite, non-negative, strictly increasing frequencies in Hz"
    bad = np.flatnonzero(~np.isfinite(f) | (f < 0))
    if bad.size:
        k = int(bad[0])
        raise FRFError(f"{_at(where)}frequency {k + 1} of {n} is {float(f[k])!r}; {expected}")
    down = np.flatnonzero(np.diff(f) <= 0)
    if down.size:
        k = int(down[0]) + 1
        what = "repeats" if f[k] == f[k - 1] else "is below"
        raise FRFError(f"{_at(where)}frequency {k + 1} of {n} ({float(f[k])!r} Hz) {what} "
                       f"frequency {k} ({float(f[k - 1])!r} Hz); {expected}")  # fmt: skip


def pair_names(outputs: Sequence[Channel], inputs: Sequence[Channel],
               pairs: np.ndarray, limit: int = 10) -> str:  # fmt: skip
    """``out/in, out/in, ...`` of (k, 2) output and input indices, the first ``limit`` of
    them, with ``and N more`` after."""
    names = [f"{outputs[o].label}/{inputs[i].label}" for o, i in np.asarray(pairs)[:limit]]
    more = len(pairs) - limit
    return ", ".join(names) + (f" and {more} more" if more > 0 else "")


def check_values(data: FRFData, where: str = "") -> None:
    """Refuse an FRF set with a value that is not finite (NaN, inf, or a pair left out).

    Raises
    ------
    FRFError
        Naming the first such value by output, input and frequency, and how many there are.
    """
    bad = ~np.isfinite(data.H)
    if not bad.any():
        return
    o, i, k = (int(x) for x in np.argwhere(bad)[0])
    n = int(bad.sum())
    more = f" (and {n - 1} more such values)" if n > 1 else ""
    raise FRFError(f"{_at(where)}output {data.outputs[o].label} / input "
                   f"{data.inputs[i].label} at {data.frequency_hz[k]:g} Hz: H is "
                   f"{complex(data.H[o, i, k])}{more}; expected finite complex values")  # fmt: skip


def check_frf(data: FRFData, where: str = "") -> FRFData:
    """``data`` once its frequencies (:func:`check_frequencies`) and values
    (:func:`check_values`) are good; every FRF reader returns through it.

    Raises
    ------
    FRFError
        As those functions, naming ``where`` first.
    """
    check_frequencies(data.frequency_hz, where)
    check_values(data, where)
    return data


def _labels(values: object, what: str, where: str) -> list[str]:
    """A file's channel labels as strings (one label may come as a scalar); FRFError for
    labels that are not one axis, or a label that repeats."""
    arr = np.atleast_1d(np.asarray(values, dtype=object))
    if arr.ndim != 1:
        raise FRFError(f"{_at(where)}{what} labels have shape {arr.shape}; expected one "
                       "label per channel")  # fmt: skip
    labels = [str(v).strip() for v in arr]
    seen: dict[str, int] = {}
    for k, label in enumerate(labels):
        if label in seen:
            raise FRFError(f"{_at(where)}{what} label {label!r} is given to {what}s "
                           f"{seen[label] + 1} and {k + 1}; expected one label per channel")
        seen[label] = k
    return labels


def frf_of(where: str, frequency_hz: object, H: object, output_labels: object,
           input_labels: object, quantity: str, units: str = "", *,
           names: tuple[str, str] = ("frequency_hz", "H")) -> FRFData:  # fmt: skip
    """A checked FRF set from a file's arrays; every message names ``where`` (the file)
    first and the array by its name in the file (``names``: of the frequencies and of H).

    The frequencies must be real numbers, H complex numbers (a real H is refused: an FRF
    has a phase, which identification and calibration need), the labels one axis without
    repeats; then :meth:`FRFData.from_labels` and :func:`check_frf`.

    Raises
    ------
    FRFError
        For arrays that do not make an FRF set (types, shapes, labels, quantity,
        frequencies, values).
    """
    f, h = np.asarray(frequency_hz), np.asarray(H)
    if f.dtype.kind not in "iuf":
        raise FRFError(f"{_at(where)}{names[0]} holds {f.dtype} values; expected real "
                       "numbers (Hz)")  # fmt: skip
    if h.dtype.kind in "iuf":
        raise FRFError(f"{_at(where)}{names[1]} holds real ({h.dtype}) values; expected "
                       "complex FRFs (real and imaginary parts): identification and "
                       "calibration need the phase, which magnitudes alone do not give")
    if h.dtype.kind != "c":
        raise FRFError(f"{_at(where)}{names[1]} holds {h.dtype} values; expected complex "
                       "numbers")  # fmt: skip
    outs = _labels(output_labels, "output", where)
    ins = _labels(input_labels, "input", where)
    if f.ndim <= 1:
        check_frequencies(np.atleast_1d(f), f"{_at(where)}{names[0]}".rstrip())
    try:
        data = FRFData.from_labels(np.atleast_1d(f), h, outs, ins, quantity, units)
    except FRFError as e:
        raise FRFError(f"{_at(where)}{e}") from None
    return check_frf(data, where)


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
    by 9806.65); FRFError naming both units if either is not understood or they measure
    different quantities."""
    have, want = _parse_units(data.units), _parse_units(units)
    if have is None or want is None:
        bad = data.units if have is None else units
        raise FRFError(f"cannot convert FRF units {data.units!r} to {units!r}: {bad!r} is "
                       "not one of length/N, length/s/N, length/s^2/N (length m, mm, cm, "
                       "um, in) or g/N")  # fmt: skip
    if have[0] != want[0] or have[0] != data.quantity:
        raise FRFError(f"cannot convert {data.quantity} in {data.units!r} to {units!r}")
    return FRFData(data.frequency_hz, data.H * (have[1] / want[1]), data.outputs, data.inputs,
                   data.quantity, units, coherence=data.coherence)  # fmt: skip
