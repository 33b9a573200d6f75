"""FRF data as MATLAB .mat files: femcal's variables, or the LMS Test.Lab export layout
(:mod:`femcal.testdata.formats.lms`)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ...atomic import write_atomic
from ..data import FRFData
from .lms import read_lms_mat
from .registry import Format, register


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
    :mod:`femcal.testdata.formats.lms`, where ``quantity`` is used). KeyError names a missing
    variable."""
    import scipy.io

    z = scipy.io.loadmat(str(path), squeeze_me=True)
    missing = {"frequency_hz", "H", "input_labels", "output_labels", "quantity"} - set(z)
    if missing:
        if not any(isinstance(v, np.ndarray) and v.dtype.names and "x_values" in v.dtype.names
                   and "y_values" in v.dtype.names for v in z.values()):  # fmt: skip
            raise KeyError(f"{path}: missing {', '.join(sorted(missing))} (and no Test.Lab "
                           "struct with x_values and y_values)")  # fmt: skip
        return read_lms_mat(path, quantity=quantity)
    f = np.atleast_1d(np.asarray(z["frequency_hz"], float))
    labels = lambda v: [str(s) for s in np.atleast_1d(v)]  # noqa: E731
    outs, ins = labels(z["output_labels"]), labels(z["input_labels"])
    H = np.asarray(z["H"], complex).reshape(len(outs), len(ins), len(f))
    units = str(z["units"]) if "units" in z and np.size(z["units"]) else ""
    return FRFData.from_labels(f, H, outs, ins, str(z["quantity"]), units)


register(Format("mat", "frf", (".mat",), read_mat, write_mat,
                "MATLAB v5 (femcal's variables, or LMS Test.Lab structs)"))
