"""FRFs from the MATLAB files that LMS Test.Lab (Simcenter Testlab) exports.

Test.Lab writes each exported block of functions as one MATLAB struct (named ``FRF`` by
default, any name is accepted) with the fields this reader uses::

    x_values.start_value        first abscissa (Hz)
    x_values.increment          abscissa step (Hz)
    x_values.number_of_values   number of abscissa values
    x_values.values             the abscissae themselves (only for uneven spacing)
    y_values.values             (n_freq,) or (n_freq, n_channels) complex, in SI units
    y_values.quantity.label     the display unit, e.g. ``g/N`` or ``(m/s2)/N``
    y_values.quantity.unit_transformation.factor, .offset
                                display value = SI value * factor + offset
    function_record.name        the channel name (char) or names (cell, one per column),
                                e.g. ``Point1005:+Z/Point12:+Y`` (response/reference)
    function_record.type        ``FRF`` for frequency response functions

Channel names of the form ``[component:]point:dir/[component:]point:dir`` give the response
and the reference; a point whose name ends in digits (``12``, ``Point12``, ``frame:12``)
becomes the femcal label ``12:+Y``, other names are kept as they are (e.g. ``hammer:+Y``).
A name that is not response/reference is an error: an FRF without its reference is
useless for assembling a MIMO set.

The values are returned in the display unit of the file (``unit_transformation`` applied),
the unit recorded in :attr:`FRFData.units`; :func:`femcal.testdata.data.convert_units` changes it.
A block without ``unit_transformation.factor`` holds SI values whatever its label says: they
are returned in the SI unit of the label's quantity (``m/s^2/N`` for ``g/N``). Structs that
are not function blocks, and blocks of another function type, are skipped with a
:class:`~femcal.errors.FemcalWarning`; other variables (notes) are skipped.
"""

from __future__ import annotations

import os
import re
import warnings
from pathlib import Path

import numpy as np

from ...errors import FemcalWarning
from ..data import FRFData, FRFError, check_frequencies, frf_of, quantity_of_units
from .mat5 import check_mat5

_POINT = re.compile(r"^(?:.*:)?\s*[A-Za-z_]*\s*(\d+)\s*:\s*([+-]?(?:R?[XYZ]|[1-6]))\s*$", re.I)


def is_lms_block(value: object) -> bool:
    """True for a (simplified) struct with ``x_values`` and ``y_values``."""
    return isinstance(value, dict) and "x_values" in value and "y_values" in value


def channel_label(point: str) -> str:
    """femcal label of one LMS point name: ``Point12:+Y`` -> ``12:+Y``; names without a
    trailing number are kept (stripped)."""
    m = _POINT.match(point)
    if m:
        d = m.group(2).upper()
        if not d.startswith(("+", "-")) and not d.isdigit():
            d = "+" + d
        return f"{int(m.group(1))}:{d}"
    return point.strip()


_DIR = r"[+-]?(?:R?[XYZ]|[1-6])"
_FUNCTION = re.compile(rf"^\s*(?:FRF\s+)?(?P<resp>[^/]+?:\s*{_DIR})\s*/\s*(?P<ref>[^/]+?:\s*{_DIR})"
                       r"(?:\s.*)?$", re.I)  # fmt: skip


def split_function_name(name: str, where: str) -> tuple[str, str]:
    """(response, reference) labels of an FRF channel name ``resp/ref``, e.g.
    ``FRF Point12:+Z/Point1:+Y (g/N)`` -> (``12:+Z``, ``1:+Y``); the LMS prefix ``FRF`` and
    anything after the reference's direction and a space are dropped.

    Raises
    ------
    FRFError
        For a name that is not response/reference, naming ``where``.
    """
    m = _FUNCTION.match(name)
    if not m:
        raise FRFError(f"{where}: channel name {name!r} is not 'point:direction/"
                       "point:direction' (response/reference, e.g. 'Point12:+Z/Point1:+Y')")
    return channel_label(m.group("resp")), channel_label(m.group("ref"))


def load_mat(path: str | os.PathLike[str], **options: object) -> dict:
    """``scipy.io.loadmat(path, **options)`` once :func:`~femcal.testdata.formats.mat5.
    check_mat5` has found nothing in the file that would crash SciPy's reader; FRFError
    naming the file for one that cannot be read (not a MATLAB file, a damaged one, version
    7.3)."""
    import scipy.io

    check_mat5(path)
    try:
        return scipy.io.loadmat(str(path), **options)
    except Exception as e:  # a damaged file makes SciPy fail in many ways
        raise FRFError(f"{path}: not a readable MATLAB file ({type(e).__name__}: {e}); "
                       "expected MATLAB version 5 to 7.2") from e  # fmt: skip


def _field(block: dict, keys: tuple[str, ...], where: str) -> object:
    """block[k1][k2]...; FRFError naming the dotted field when one is missing."""
    v: object = block
    for k in keys:
        if not isinstance(v, dict) or k not in v:
            raise FRFError(f"{where}: missing {'.'.join(keys)}")
        v = v[k]
    return v


def _number(value: object, field: str, where: str, default: float | None = None) -> float:
    """One finite real number (a scalar or a one-element array); FRFError naming the field
    otherwise. ``default`` stands for an empty value when given."""
    arr = np.asarray(value)
    if arr.size == 0 and default is not None:
        return default
    if arr.size != 1 or arr.dtype.kind not in "iuf" or not np.isfinite(arr).all():
        shown = (repr(arr.reshape(-1)[0].item()) if arr.size == 1
                 else f"an array of shape {arr.shape}")  # fmt: skip
        raise FRFError(f"{where}: {field} is {shown}; expected one finite number")
    return float(arr.reshape(-1)[0])


def _values(block: dict, where: str) -> np.ndarray:
    """y_values.values as (n_values, n_channels) or (n_channels, n_values) complex: as
    stored (a vector is one channel); FRFError for real, non-numeric or 3-D values."""
    y = np.asarray(_field(block, ("y_values", "values"), where))
    what = f"{where}: y_values.values"
    if y.dtype.kind in "iuf":
        raise FRFError(f"{what} holds real ({y.dtype}) values; expected complex FRFs (real "
                       "and imaginary parts): identification and calibration need the phase, "
                       "which magnitudes alone do not give")  # fmt: skip
    if y.dtype.kind != "c":
        raise FRFError(f"{what} holds {y.dtype} values; expected complex numbers")
    if y.ndim > 2 or y.size == 0:
        raise FRFError(f"{what} has shape {y.shape}; expected (n_values, n_channels)")
    return y.reshape(-1, 1) if y.ndim < 2 else y


def _abscissa(block: dict, y: np.ndarray, where: str) -> tuple[np.ndarray, np.ndarray]:
    """(abscissa (n,), y as (n, n_channels)): the stored abscissae (uneven spacing) or
    start + increment * k; y is turned to frequencies down the rows to match them.

    Raises
    ------
    FRFError
        For a missing or non-numeric field, or a number of abscissae that neither
        dimension of y has.
    """
    xv = _field(block, ("x_values",), where)
    if isinstance(xv, dict) and "values" in xv and np.size(xv["values"]) > 0:
        x = np.asarray(xv["values"])
        if x.dtype.kind not in "iuf":
            raise FRFError(f"{where}: x_values.values holds {x.dtype} values; expected "
                           "frequencies in Hz")  # fmt: skip
        x = x.reshape(-1).astype(float)
        n = len(x)
    else:
        start = _number(_field(block, ("x_values", "start_value"), where),
                        "x_values.start_value", where)  # fmt: skip
        step = _number(_field(block, ("x_values", "increment"), where),
                       "x_values.increment", where)  # fmt: skip
        count = _number(_field(block, ("x_values", "number_of_values"), where),
                        "x_values.number_of_values", where)  # fmt: skip
        n = int(count) if count.is_integer() else -1
        if n not in y.shape:  # checked before the abscissa is made: it may be huge
            raise FRFError(f"{where}: x_values.number_of_values is {count:g}; expected the "
                           f"number of values of y_values.values, shape {y.shape}")
        x = start + step * np.arange(n)
    if y.shape[0] != n:
        if y.shape[1] != n:
            raise FRFError(f"{where}: y_values.values has shape {y.shape}; expected "
                           f"({n}, n_channels) for {n} abscissae")  # fmt: skip
        y = y.T  # stored channels x frequencies
    return x, y


def _names(block: dict, n_channels: int, where: str) -> list[str]:
    rec = block.get("function_record")
    if not isinstance(rec, dict) or "name" not in rec:
        raise FRFError(f"{where}: missing function_record.name (the channel names)")
    names = rec["name"]
    names = [names] if isinstance(names, str) else [str(s) for s in np.ravel(names)]
    if len(names) != n_channels:
        raise FRFError(f"{where}: {len(names)} channel names for {n_channels} columns "
                       "of y_values.values")  # fmt: skip
    return names


#: The SI unit of each quantity, for SI values.
_SI = {"receptance": "m/N", "mobility": "m/s/N", "accelerance": "m/s^2/N"}


def _display_units(block: dict, where: str) -> tuple[str, float, float]:
    """(unit, factor, offset) of y_values.quantity: the display unit with its transformation
    from SI; without a transformation factor the values are SI, and the unit is the SI unit
    of the label's quantity (the label as it is if it names none)."""
    q = block["y_values"].get("quantity")
    if not isinstance(q, dict):
        return "", 1.0, 0.0
    label = str(q.get("label", "")).strip()
    tr = q.get("unit_transformation")
    if not isinstance(tr, dict) or "factor" not in tr:
        return _SI.get(quantity_of_units(label) or "", label), 1.0, 0.0
    field = "y_values.quantity.unit_transformation."
    factor = _number(tr["factor"], field + "factor", where)
    offset = _number(tr.get("offset", 0.0), field + "offset", where, 0.0)
    return label, factor, offset


def read_lms_mat(path: str | os.PathLike[str], *, quantity: str | None = None) -> FRFData:
    """Read every Test.Lab FRF block of a .mat file into one MIMO set.

    Parameters
    ----------
    path : the .mat file (MATLAB 5 to 7.2; a 7.3 HDF5 file is refused by SciPy).
    quantity : receptance, mobility or accelerance; by default read from the unit label
        (``g/N`` and ``(m/s2)/N`` are accelerance, ``(m/s)/N`` mobility, ``m/N``
        receptance); a label that names none of them needs it given.

    Returns
    -------
    FRFData with outputs and inputs in first-seen order, H in the file's display unit.

    Raises
    ------
    FRFError
        Naming the file, the struct and the field: no FRF block, a missing or malformed
        field, real values, blocks on different frequency axes or in different units, a
        channel name that is not response/reference, an output/input pair measured twice
        or not at all, values that are not finite.
    """
    path = Path(path)
    z = load_mat(path, simplify_cells=True)
    blocks = {k: v for k, v in z.items() if not k.startswith("__") and is_lms_block(v)}
    for k, v in z.items():  # a struct that is no block may be a damaged one
        if isinstance(v, dict) and not k.startswith("__") and k not in blocks:
            warnings.warn(f"{path}: struct {k} is not a Test.Lab function block (no x_values "
                          "and y_values): skipped", FemcalWarning, stacklevel=2)  # fmt: skip
    if not blocks:
        raise FRFError(f"{path}: no Test.Lab function block (a struct with x_values and "
                       "y_values)")  # fmt: skip
    f = None
    first = ""
    units = None
    outs: dict[str, int] = {}
    ins: dict[str, int] = {}
    cells: dict[tuple[int, int], np.ndarray] = {}
    for var, block in blocks.items():
        where = f"{path}: {var}"
        rec = block.get("function_record")
        ftype = str(rec.get("type", "FRF")) if isinstance(rec, dict) else "FRF"
        if ftype.strip().upper() != "FRF":
            warnings.warn(f"{where}: function_record.type {ftype!r}, not FRF: skipped",
                          FemcalWarning, stacklevel=2)  # fmt: skip
            continue
        if not isinstance(block["y_values"], dict):
            raise FRFError(f"{where}: y_values is not a struct; expected one with a values "
                           "field")  # fmt: skip
        x, y = _abscissa(block, _values(block, where), where)
        label, factor, offset = _display_units(block, where)
        y = y * factor + offset
        if f is None:
            f, units, first = x, label, var
        elif len(x) != len(f) or not np.allclose(x, f, rtol=1e-9, atol=1e-12):
            raise FRFError(f"{where}: on another frequency axis than {first}")
        elif label != units:
            raise FRFError(f"{where}: unit {label!r}, other blocks {units!r}")
        for c, name in enumerate(_names(block, y.shape[1], where)):
            o_lab, i_lab = split_function_name(name, where)
            key = (outs.setdefault(o_lab, len(outs)), ins.setdefault(i_lab, len(ins)))
            if key in cells:
                raise FRFError(f"{where}: {o_lab}/{i_lab} appears twice")
            cells[key] = y[:, c]
    if f is None:
        raise FRFError(f"{path}: no block with function_record.type FRF")
    H = np.full((len(outs), len(ins), len(f)), np.nan + 0j)
    for (o, i), v in cells.items():
        H[o, i] = v
    if len(cells) < len(outs) * len(ins):
        ol, il = list(outs), list(ins)
        missing = [f"{ol[o]}/{il[i]}" for o in range(len(ol)) for i in range(len(il))
                   if (o, i) not in cells]  # fmt: skip
        raise FRFError(f"{path}: {len(missing)} output/input pairs have no FRF: "
                       f"{', '.join(missing[:10])}")  # fmt: skip
    q = quantity or quantity_of_units(units or "")
    if q is None:
        raise FRFError(f"{path}: cannot tell receptance, mobility or accelerance from the "
                       f"unit {units!r}; give the quantity")  # fmt: skip
    check_frequencies(f, f"{path}: {first}: x_values")
    return frf_of(str(path), f, H, list(outs), list(ins), q, units or "",
                  names=("x_values", "y_values.values"))  # fmt: skip
