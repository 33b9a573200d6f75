"""FRF data as NumPy NPZ: ``frequency_hz``, ``H``, ``output_labels``, ``input_labels``,
``quantity`` and ``units``."""

from __future__ import annotations

import os
import zipfile
from pathlib import Path

import numpy as np

from ...atomic import write_atomic
from ..data import FRFData
from .registry import Format, register


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


register(Format("npz", "frf", (".npz",), read_npz, write_npz, "NumPy archive (femcal's keys)"))
