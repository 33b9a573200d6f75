"""FRF data sets: frequencies, H (n_out, n_in, n_freq), channel labels, quantity and units,
with readers and writers (NPZ, CSV, UFF 58 through pyuff). Every file is written to a
temporary name and renamed.

Channel labels are ``GRID:DIR`` where DIR is a component 1-6 or a signed basic axis
(``+X``, ``-Y``, ``+RZ``...), e.g. ``1001:3`` or ``1001:+Z``; other labels are kept as they
are (a grid of None).
"""

from __future__ import annotations

import csv
import errno
import io
import os
import re
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..io.atomic import write_atomic
from ..response.frf import QUANTITIES

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


# ----------------------------------------------------------------------------- NPZ


def write_npz(path: str | os.PathLike[str], data: FRFData) -> Path:
    """NPZ with keys ``frequency_hz``, ``H``, ``input_labels``, ``output_labels``,
    ``quantity`` and ``units``."""

    def dump(tmp: str) -> None:
        np.savez(tmp, frequency_hz=data.frequency_hz, H=data.H,
                 output_labels=np.array([c.label for c in data.outputs]),
                 input_labels=np.array([c.label for c in data.inputs]),
                 quantity=np.array(data.quantity), units=np.array(data.units))  # fmt: skip

    return write_atomic(path, dump)


def read_npz(path: str | os.PathLike[str]) -> FRFData:
    """Read what :func:`write_npz` writes (``units`` optional); KeyError names a missing key."""
    try:
        z = np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError, zipfile.BadZipFile):
        raise ValueError(f"{path}: not an NPZ archive of arrays") from None
    if not hasattr(z, "files"):  # a single .npy array, not an archive
        raise ValueError(f"{path}: not an NPZ archive of arrays")
    with z:
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


# ----------------------------------------------------------------------------- UFF 58

#: UFF 58 ordinate data types of the response (per unit force, type 13 in the denominator).
_UFF_ORDINATE = {"receptance": 8, "mobility": 11, "accelerance": 12}
_UFF_AXES = {"X": 1, "Y": 2, "Z": 3, "RX": 4, "RY": 5, "RZ": 6}


def _uff_direction(ch: Channel) -> int:
    """UFF direction code (+-1..6) of a channel; ValueError if it names no grid."""
    if ch.grid is None or ch.direction is None:
        raise ValueError(f"channel {ch.label!r}: UFF 58 needs a GRID:DIRECTION label")
    d = ch.direction
    sign = -1 if d.startswith("-") else 1
    d = d.lstrip("+-")
    return sign * (int(d) if d.isdigit() else _UFF_AXES[d])


def _uff_label(node: int, direction: int) -> str:
    return f"{node}:{direction}" if direction > 0 else f"{node}:-{-direction}"


def write_uff(path: str | os.PathLike[str], data: FRFData, *, binary: bool = False) -> Path:
    """UFF (universal file) with one dataset 58 per output and input (58b with ``binary``,
    about 2.5 times smaller), complex ordinates; channels must be ``GRID:DIR`` (direction
    codes 1-6 or signed axes)."""
    import pyuff

    path = Path(path)
    sets = []
    f = np.asarray(data.frequency_hz, float)
    df = np.diff(f)
    even = len(f) > 1 and np.allclose(df, df[0], rtol=1e-9, atol=0)
    for o, co in enumerate(data.outputs):
        for i, ci in enumerate(data.inputs):
            sets.append(pyuff.prepare_58(
                binary=int(binary), id1=f"FRF {co.label} / {ci.label}", id2=data.units or "NONE",
                id3=data.quantity, id4="femcal", id5="NONE", func_type=4,
                rsp_node=co.grid if co.grid is not None else 0,
                rsp_dir=_uff_direction(co), ref_node=ci.grid if ci.grid is not None else 0,
                ref_dir=_uff_direction(ci), ord_data_type=6,
                abscissa_spacing=1 if even else 0, abscissa_spec_data_type=18,
                ordinate_spec_data_type=_UFF_ORDINATE[data.quantity],
                orddenom_spec_data_type=13, data=np.asarray(data.H[o, i], complex), x=f,
            ))  # fmt: skip

    def dump(tmp: str) -> None:
        Path(tmp).unlink()  # pyuff adds to a file that exists: start from none
        pyuff.UFF(tmp).write_sets(sets, mode="add")

    return write_atomic(path, dump)


def read_uff(path: str | os.PathLike[str]) -> FRFData:
    """FRFs of every dataset 58 with function type 4 (FRF) in a universal file, arranged as
    outputs x inputs (labels ``GRID:DIR``); ValueError if the sets share no common frequency
    axis or leave an output/input pair without data."""
    import pyuff

    sets = pyuff.UFF(str(path)).read_sets()
    sets = [sets] if isinstance(sets, dict) else sets
    frfs = [s for s in sets if s.get("type") == 58 and s.get("func_type") == 4]
    if not frfs:
        raise ValueError(f"{path}: no dataset 58 FRF (function type 4)")
    f = np.asarray(frfs[0]["x"], float)
    outs: dict[str, int] = {}
    ins: dict[str, int] = {}
    cells = {}
    for s in frfs:
        if len(s["x"]) != len(f) or not np.allclose(s["x"], f, rtol=1e-9, atol=1e-12):
            raise ValueError(f"{path}: datasets 58 on different frequency axes")
        o = outs.setdefault(_uff_label(int(s["rsp_node"]), int(s["rsp_dir"])), len(outs))
        i = ins.setdefault(_uff_label(int(s["ref_node"]), int(s["ref_dir"])), len(ins))
        cells[o, i] = np.asarray(s["data"], complex)
    H = np.full((len(outs), len(ins), len(f)), np.nan + 0j)
    for (o, i), v in cells.items():
        H[o, i] = v
    if np.isnan(H.real).any():
        raise ValueError(f"{path}: not every output and input pair has an FRF")
    code = int(frfs[0].get("ordinate_spec_data_type", 8))
    quantity = {v: k for k, v in _UFF_ORDINATE.items()}.get(code, "receptance")
    units = str(frfs[0].get("id2", "")).strip()
    return FRFData.from_labels(f, H, list(outs), list(ins), quantity,
                               "" if units == "NONE" else units)  # fmt: skip


# ----------------------------------------------------------------------------- assembly


def assemble_runs(
    runs: list[FRFData],
    channel_maps: list[dict[str, str] | None] | None = None,
    *,
    allow_missing: bool = False,
) -> FRFData:
    """One MIMO set from several runs (e.g. roving triaxial sensors, one hammer input each).

    Parameters
    ----------
    runs : the runs, on one frequency axis and of one quantity.
    channel_maps : per run, a map from the run's channel labels (outputs and inputs) to the
        labels they stand for in the assembled set (e.g. ``{"ch3": "1005:+Y"}``); labels not
        in the map are kept. None: no renaming.
    allow_missing : leave output/input pairs no run measured as NaN instead of raising.

    Returns
    -------
    The assembled set: outputs and inputs in first-seen order; a pair measured in several
    runs is their mean.

    Raises
    ------
    ValueError
        For runs on different frequency axes or of different quantities, or (unless
        ``allow_missing``) pairs that no run measured, naming them.
    """
    if not runs:
        raise ValueError("no runs to assemble")
    maps = channel_maps if channel_maps is not None else [None] * len(runs)
    if len(maps) != len(runs):
        raise ValueError(f"{len(maps)} channel maps for {len(runs)} runs")
    f = runs[0].frequency_hz
    outs: dict[str, int] = {}
    ins: dict[str, int] = {}
    acc: dict[tuple[int, int], list[np.ndarray]] = {}
    for r, (run, cmap) in enumerate(zip(runs, maps, strict=True)):
        if len(run.frequency_hz) != len(f) or not np.allclose(run.frequency_hz, f, rtol=1e-9):
            raise ValueError(f"run {r + 1} is on another frequency axis than run 1")
        if run.quantity != runs[0].quantity:
            raise ValueError(f"run {r + 1} holds {run.quantity}, run 1 {runs[0].quantity}")
        rename = cmap or {}
        o_idx = [outs.setdefault(rename.get(c.label, c.label), len(outs)) for c in run.outputs]
        i_idx = [ins.setdefault(rename.get(c.label, c.label), len(ins)) for c in run.inputs]
        for a, o in enumerate(o_idx):
            for b, i in enumerate(i_idx):
                acc.setdefault((o, i), []).append(run.H[a, b])
    H = np.full((len(outs), len(ins), len(f)), np.nan + 0j)
    for (o, i), values in acc.items():
        H[o, i] = np.mean(values, axis=0)
    if not allow_missing:
        missing = [(o, i) for o in range(len(outs)) for i in range(len(ins)) if (o, i) not in acc]
        if missing:
            ol, il = list(outs), list(ins)
            named = ", ".join(f"{ol[o]}/{il[i]}" for o, i in missing[:10])
            raise ValueError(f"{len(missing)} output/input pairs were not measured: {named}")
    return FRFData.from_labels(f, H, list(outs), list(ins), runs[0].quantity, runs[0].units)


# ----------------------------------------------------------------------------- MATLAB


def write_mat(path: str | os.PathLike[str], data: FRFData) -> Path:
    """MATLAB .mat (version 5, scipy.io) with the NPZ's variables: ``frequency_hz`` (1 x
    n_freq), ``H`` (n_out x n_in x n_freq complex), ``output_labels`` and ``input_labels``
    (cell arrays of char), ``quantity`` and ``units``."""
    import scipy.io

    def dump(tmp: str) -> None:
        cells = lambda chs: np.array([c.label for c in chs], dtype=object)  # noqa: E731
        scipy.io.savemat(tmp, {
            "frequency_hz": np.asarray(data.frequency_hz, float)[None, :],
            "H": np.asarray(data.H, complex), "output_labels": cells(data.outputs),
            "input_labels": cells(data.inputs), "quantity": data.quantity,
            "units": data.units,
        }, do_compression=True)  # fmt: skip

    return write_atomic(path, dump)


def read_mat(path: str | os.PathLike[str], *, quantity: str | None = None) -> FRFData:
    """Read a MATLAB file (version 5 to 7.2): what :func:`write_mat` writes, or the LMS
    Test.Lab export layout (structs with ``x_values`` and ``y_values``; see
    :mod:`femcal.testdata.lms`, where ``quantity`` is used). KeyError names a missing variable."""
    import scipy.io

    z = scipy.io.loadmat(str(path), squeeze_me=True)
    missing = {"frequency_hz", "H", "input_labels", "output_labels", "quantity"} - set(z)
    if missing:
        if not any(isinstance(v, np.ndarray) and v.dtype.names and "x_values" in v.dtype.names
                   and "y_values" in v.dtype.names for v in z.values()):  # fmt: skip
            raise KeyError(f"{path}: missing {', '.join(sorted(missing))} (and no Test.Lab "
                           "struct with x_values and y_values)")  # fmt: skip
        from .lms import read_lms_mat

        return read_lms_mat(path, quantity=quantity)
    f = np.atleast_1d(np.asarray(z["frequency_hz"], float))
    labels = lambda v: [str(s) for s in np.atleast_1d(v)]  # noqa: E731
    outs, ins = labels(z["output_labels"]), labels(z["input_labels"])
    H = np.asarray(z["H"], complex).reshape(len(outs), len(ins), len(f))
    units = str(z["units"]) if "units" in z and np.size(z["units"]) else ""
    return FRFData.from_labels(f, H, outs, ins, str(z["quantity"]), units)


# ----------------------------------------------------------------------------- any format

READERS = {".npz": read_npz, ".csv": read_csv, ".uff": read_uff, ".unv": read_uff,
           ".mat": read_mat}  # fmt: skip


def read_frf(path: str | os.PathLike[str]) -> FRFData:
    """Read an FRF file by its suffix: .npz, .csv, .uff/.unv (UFF 58) or .mat (femcal's
    variables or the LMS Test.Lab layout). ValueError for another suffix,
    FileNotFoundError for a missing file."""
    path = Path(path)
    reader = READERS.get(path.suffix.lower())
    if reader is None:
        raise ValueError(f"{path}: unknown FRF file type {path.suffix!r}; expected "
                         f"{', '.join(READERS)}")  # fmt: skip
    if not path.is_file():
        raise FileNotFoundError(errno.ENOENT, os.strerror(errno.ENOENT), str(path))
    from scipy.io.matlab import MatReadError

    try:
        return reader(path)
    except (KeyError, ValueError) as e:  # the readers' own errors mostly name the file
        msg = str(e).strip('"')
        raise ValueError(msg if str(path) in msg else f"{path}: {msg}") from None
    except (OSError, EOFError, zipfile.BadZipFile, MatReadError) as e:
        raise ValueError(f"{path}: not a readable {path.suffix} FRF file ({e})") from None
