"""Time histories as NumPy NPZ: ``dt`` (the step in s, one number), ``values`` (channels x
samples), ``names`` and ``units`` (one string per channel; ``units`` may be left out).

The arrays are stored as given (float64 samples round trip exactly); the reader gives float64
samples. :attr:`TimeData.header <femcal.testdata.timedata.TimeData.header>` is not stored.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ...atomic import write_atomic
from ...errors import TimeDataError
from ..timedata import TimeData
from .npz import load_arrays
from .registry import Format, register

#: The arrays a time-history archive must hold (``units`` is optional).
KEYS = ("dt", "values", "names")


def write_time_npz(path: str | os.PathLike[str], data: TimeData) -> Path:
    """Write ``data`` as an NPZ archive with the keys ``dt``, ``values``, ``names`` and
    ``units`` (uncompressed, atomically)."""
    names = np.array(data.names, dtype=np.str_).reshape(-1)
    units = np.array(data.units, dtype=np.str_).reshape(-1)

    def dump(tmp: str) -> None:
        np.savez(tmp, dt=np.float64(data.dt), values=np.asarray(data.values), names=names,
                 units=units)  # fmt: skip

    return write_atomic(path, dump)


def read_time_npz(path: str | os.PathLike[str]) -> TimeData:
    """Read what :func:`write_time_npz` writes (``units`` optional: no units then).

    Raises
    ------
    TimeDataError
        Naming the file and the key: not an NPZ archive (or a damaged one), a missing key,
        ``dt`` that is not one number > 0, ``values`` that are not a 2-d array of real
        finite numbers, ``names`` or ``units`` that are not one string per channel (a row
        of ``values``).
    """
    path = Path(path)
    expected = f"; expected the arrays {', '.join(KEYS)} (and units)"
    arrays = load_arrays(path, KEYS, ("units",), TimeDataError,
                         lambda absent, held: f"no {', '.join(absent)} array"
                         f"{'s' * (len(absent) > 1)} (it holds {', '.join(held) or 'nothing'})"
                         f"{expected}", expected)  # fmt: skip
    dt = arrays["dt"]
    if dt.size != 1 or dt.dtype.kind not in "iuf":
        raise TimeDataError(f"{path}: dt is a {dt.dtype} array of shape {dt.shape}; expected "
                            "one number, the sampling step in s")  # fmt: skip
    step = float(dt.reshape(-1)[0])
    if not (np.isfinite(step) and step > 0):
        raise TimeDataError(f"{path}: dt = {step!r}; expected a step > 0 s")
    v = arrays["values"]
    if v.ndim != 2 or v.dtype.kind not in "iuf":
        raise TimeDataError(f"{path}: values is a {v.dtype} array of shape {v.shape}; expected "
                            "real numbers of shape (channels, samples)")  # fmt: skip
    n_ch = v.shape[0]
    if n_ch == 0 or v.shape[1] == 0:
        raise TimeDataError(f"{path}: values of shape {v.shape}; expected at least one channel "
                            "and one sample")  # fmt: skip
    names = _strings(arrays["names"], "names", n_ch, path)
    units = _strings(arrays["units"], "units", n_ch, path) if "units" in arrays else ("",) * n_ch
    values = np.asarray(v, dtype=np.float64)
    finite = np.isfinite(values)
    if not finite.all():
        c = int(np.flatnonzero(~finite.all(axis=1))[0])
        k = int(np.flatnonzero(~finite[c])[0])
        raise TimeDataError(f"{path}: values: channel {names[c]!r} (row {c}) sample {k} is "
                            f"{float(values[c, k])!r}; expected finite numbers")  # fmt: skip
    return TimeData(step, values, names, units)


def _strings(value: np.ndarray, key: str, n_ch: int, path: Path) -> tuple[str, ...]:
    """One string per channel; TimeDataError naming the key otherwise."""
    if value.dtype.kind not in "US" or value.shape != (n_ch,):
        raise TimeDataError(f"{path}: {key} is a {value.dtype} array of shape {value.shape}; "
                            f"expected {n_ch} strings, one per channel (row of "
                            "values)")  # fmt: skip
    if value.dtype.kind == "S":
        return tuple(b.decode("utf-8", "replace") for b in value.tolist())
    return tuple(str(s) for s in value.tolist())


register(Format("npz", "time", (".npz",), read_time_npz, write_time_npz,
                "NumPy archive of dt, values, names, units"))  # fmt: skip
