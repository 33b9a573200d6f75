"""FRF data as NumPy NPZ: ``frequency_hz``, ``H``, ``output_labels``, ``input_labels``,
``quantity`` and ``units``, and ``coherence`` ((n_out, n_freq) or (n_out, n_in, n_freq)) for
FRFs estimated from time histories."""

from __future__ import annotations

import os
import zipfile
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np

from ...atomic import write_atomic
from ..data import FRFData, FRFError, frf_of
from .registry import Format, register


def write_npz(path: str | os.PathLike[str], data: FRFData) -> Path:
    """NPZ with keys ``frequency_hz``, ``H``, ``input_labels``, ``output_labels``,
    ``quantity`` and ``units``, and ``coherence`` when the data have one."""

    def dump(tmp: str) -> None:
        extra = {} if data.coherence is None else {"coherence": data.coherence}
        np.savez(tmp, frequency_hz=data.frequency_hz, H=data.H,
                 output_labels=np.array([c.label for c in data.outputs]),
                 input_labels=np.array([c.label for c in data.inputs]),
                 quantity=np.array(data.quantity), units=np.array(data.units),
                 **extra)  # fmt: skip

    return write_atomic(path, dump)


#: The arrays an FRF archive must hold (``units`` is optional).
_KEYS = ("frequency_hz", "H", "output_labels", "input_labels", "quantity")


def load_arrays(path: str | os.PathLike[str], required: tuple[str, ...],
                optional: tuple[str, ...], error: type[Exception],
                missing: Callable[[list[str], list[str]], str],
                expected: str = "") -> dict[str, np.ndarray]:  # fmt: skip
    """The ``required`` and (those present of) the ``optional`` arrays of an NPZ archive.

    Raises ``error`` naming the file: for a file that is not an archive of arrays (a single
    .npy array: ``expected`` is added to that message), for required arrays it lacks
    (``missing(absent, held)`` gives the message after the file's name), or for a member
    that cannot be read (a damaged archive). Members are read (and decompressed) only once
    the required ones are known to be there.
    """
    try:
        z = np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError, zipfile.BadZipFile):
        raise error(f"{path}: not an NPZ archive of arrays") from None
    if not hasattr(z, "files"):  # a single .npy array, not an archive
        raise error(f"{path}: not an NPZ archive of arrays{expected}")
    with z:
        absent = [k for k in required if k not in z.files]
        if absent:
            raise error(f"{path}: {missing(absent, list(z.files))}")
        arrays = {}
        for key in (*required, *optional):
            if key not in z.files:
                continue
            try:
                arrays[key] = z[key]
            except Exception as e:  # a damaged member can fail in many ways
                raise error(f"{path}: array {key!r} cannot be read ({type(e).__name__}: "
                            f"{e}); the archive is damaged") from e  # fmt: skip
        return arrays


def read_npz(path: str | os.PathLike[str]) -> FRFData:
    """Read what :func:`write_npz` writes (``units`` and ``coherence`` optional).

    Raises
    ------
    FRFError
        Naming the file: not an NPZ archive (or a damaged one), a missing key, or arrays
        that do not make an FRF set (see :func:`~femcal.testdata.data.frf_of`: real or
        non-finite H, frequencies not increasing, shapes that do not agree...).
    """
    arrays = load_arrays(path, _KEYS, ("units", "coherence"), FRFError,
                         lambda absent, _held: f"missing {', '.join(sorted(absent))}; expected "
                         f"the arrays {', '.join(_KEYS)} (and units)")  # fmt: skip
    text = {k: _text(arrays[k], k, path) for k in ("quantity", "units") if k in arrays}
    data = frf_of(str(path), arrays["frequency_hz"], arrays["H"], arrays["output_labels"],
                  arrays["input_labels"], text["quantity"], text.get("units", ""))  # fmt: skip
    if "coherence" not in arrays:
        return data
    try:
        return replace(data, coherence=arrays["coherence"])
    except FRFError as e:
        raise FRFError(f"{path}: {e}") from None


def _text(value: np.ndarray, key: str, path: str | os.PathLike[str]) -> str:
    """One string stored as a 0-d (or one-element) array; FRFError naming the key otherwise."""
    if value.dtype.kind not in "US" or value.size != 1:
        raise FRFError(f"{path}: {key} is a {value.dtype} array of shape {value.shape}; "
                       "expected one string")  # fmt: skip
    return str(value.reshape(-1)[0])


register(Format("npz", "frf", (".npz",), read_npz, write_npz, "NumPy archive (femcal's keys)"))
