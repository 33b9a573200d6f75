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
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from ..data import FRFData, quantity_of_units

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
    anything after the reference's direction and a space are dropped."""
    m = _FUNCTION.match(name)
    if not m:
        raise ValueError(f"{where}: channel name {name!r} is not 'point:direction/"
                         "point:direction' (response/reference, e.g. 'Point12:+Z/Point1:+Y')")
    return channel_label(m.group("resp")), channel_label(m.group("ref"))


def _scalar(block: dict, *keys: str, where: str) -> float:
    v = block
    for k in keys:
        if not isinstance(v, dict) or k not in v:
            raise KeyError(f"{where}: missing {'.'.join(keys)}")
        v = v[k]
    return float(np.asarray(v, float).reshape(-1)[0])


def _abscissa(block: dict, where: str) -> np.ndarray:
    xv = block["x_values"]
    if isinstance(xv, dict) and "values" in xv and np.size(xv["values"]) > 0:
        return np.asarray(xv["values"], float).reshape(-1)
    start = _scalar(block, "x_values", "start_value", where=where)
    step = _scalar(block, "x_values", "increment", where=where)
    n = int(_scalar(block, "x_values", "number_of_values", where=where))
    return start + step * np.arange(n)


def _names(block: dict, n_channels: int, where: str) -> list[str]:
    rec = block.get("function_record")
    if not isinstance(rec, dict) or "name" not in rec:
        raise KeyError(f"{where}: missing function_record.name (the channel names)")
    names = rec["name"]
    names = [names] if isinstance(names, str) else [str(s) for s in np.ravel(names)]
    if len(names) != n_channels:
        raise ValueError(f"{where}: {len(names)} channel names for {n_channels} columns "
                         "of y_values.values")  # fmt: skip
    return names


def _display_units(block: dict) -> tuple[str, float, float]:
    q = block["y_values"].get("quantity") if isinstance(block["y_values"], dict) else None
    if not isinstance(q, dict):
        return "", 1.0, 0.0
    label = str(q.get("label", "")).strip()
    tr = q.get("unit_transformation")
    factor = float(np.ravel(tr.get("factor", 1.0))[0]) if isinstance(tr, dict) else 1.0
    offset = float(np.ravel(tr.get("offset", 0.0))[0]) if isinstance(tr, dict) else 0.0
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
    KeyError, ValueError
        Naming the file, the struct and the field: no FRF block, a missing field, blocks on
        different frequency axes or in different units, a channel name that is not
        response/reference, an output/input pair measured twice or not at all.
    """
    import scipy.io

    path = Path(path)
    z = scipy.io.loadmat(str(path), simplify_cells=True)
    blocks = {k: v for k, v in z.items() if not k.startswith("__") and is_lms_block(v)}
    if not blocks:
        raise KeyError(f"{path}: no Test.Lab function block (a struct with x_values and "
                       "y_values)")  # fmt: skip
    f = None
    units = None
    outs: dict[str, int] = {}
    ins: dict[str, int] = {}
    cells: dict[tuple[int, int], np.ndarray] = {}
    for var, block in blocks.items():
        where = f"{path.name}: {var}"
        rec = block.get("function_record")
        ftype = str(rec.get("type", "FRF")) if isinstance(rec, dict) else "FRF"
        if ftype.strip().upper() != "FRF":
            continue
        x = _abscissa(block, where)
        if not isinstance(block["y_values"], dict) or "values" not in block["y_values"]:
            raise KeyError(f"{where}: missing y_values.values")
        y = np.asarray(block["y_values"]["values"])
        y = y.reshape(-1, 1) if y.ndim == 1 else y
        if y.shape[0] != len(x):
            if y.shape[1] == len(x):  # stored channels x frequencies
                y = y.T
            else:
                raise ValueError(f"{where}: y_values.values has shape {y.shape}; "
                                 f"expected ({len(x)}, n_channels)")  # fmt: skip
        label, factor, offset = _display_units(block)
        y = y.astype(complex) * factor + offset
        if f is None:
            f, units = x, label
        elif len(x) != len(f) or not np.allclose(x, f, rtol=1e-9, atol=1e-12):
            raise ValueError(f"{where}: on another frequency axis than {next(iter(blocks))}")
        elif label != units:
            raise ValueError(f"{where}: unit {label!r}, other blocks {units!r}")
        for c, name in enumerate(_names(block, y.shape[1], where)):
            o_lab, i_lab = split_function_name(name, where)
            key = (outs.setdefault(o_lab, len(outs)), ins.setdefault(i_lab, len(ins)))
            if key in cells:
                raise ValueError(f"{where}: {o_lab}/{i_lab} appears twice")
            cells[key] = y[:, c]
    if f is None:
        raise KeyError(f"{path}: no block with function_record.type FRF")
    H = np.full((len(outs), len(ins), len(f)), np.nan + 0j)
    for (o, i), v in cells.items():
        H[o, i] = v
    if len(cells) < len(outs) * len(ins):
        ol, il = list(outs), list(ins)
        missing = [f"{ol[o]}/{il[i]}" for o in range(len(ol)) for i in range(len(il))
                   if (o, i) not in cells]  # fmt: skip
        raise ValueError(f"{path}: {len(missing)} output/input pairs have no FRF: "
                         f"{', '.join(missing[:10])}")  # fmt: skip
    q = quantity or quantity_of_units(units or "")
    if q is None:
        raise ValueError(f"{path}: cannot tell receptance, mobility or accelerance from the "
                         f"unit {units!r}; give the quantity")  # fmt: skip
    order = np.argsort(f, kind="stable")
    return FRFData.from_labels(f[order], H[:, :, order], list(outs), list(ins), q, units or "")
