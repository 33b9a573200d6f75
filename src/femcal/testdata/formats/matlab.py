"""FRF data as MATLAB .mat files: femcal's variables, or the LMS Test.Lab export layout
(:mod:`femcal.testdata.formats.lms`)."""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path

import numpy as np

from ...atomic import write_atomic
from ..data import FRFData, FRFError, frf_of
from .lms import load_mat, read_lms_mat
from .registry import Format, register


def write_mat(path: str | os.PathLike[str], data: FRFData) -> Path:
    """MATLAB .mat (version 5, scipy.io) with the NPZ's variables: ``frequency_hz`` (1 x
    n_freq), ``H`` (n_out x n_in x n_freq complex), ``output_labels`` and ``input_labels``
    (cell arrays of char), ``quantity`` and ``units``, and ``coherence`` (n_out x n_freq, or
    n_out x n_in x n_freq) when the data have one."""
    import scipy.io

    def dump(tmp: str) -> None:
        cells = lambda chs: np.array([c.label for c in chs], dtype=object)  # noqa: E731
        extra = {} if data.coherence is None else {"coherence": np.asarray(data.coherence)}
        scipy.io.savemat(tmp, {
            "frequency_hz": np.asarray(data.frequency_hz, float)[None, :],
            "H": np.asarray(data.H, complex), "output_labels": cells(data.outputs),
            "input_labels": cells(data.inputs), "quantity": data.quantity,
            "units": data.units, **extra,
        }, do_compression=True)  # fmt: skip

    return write_atomic(path, dump)


#: The variables of femcal's own layout (``units`` is optional).
_VARIABLES = ("frequency_hz", "H", "input_labels", "output_labels", "quantity")


def read_mat(path: str | os.PathLike[str], *, quantity: str | None = None) -> FRFData:
    """Read a MATLAB file (version 5 to 7.2): what :func:`write_mat` writes, or the LMS
    Test.Lab export layout (structs with ``x_values`` and ``y_values``; see
    :mod:`femcal.testdata.formats.lms`, where ``quantity`` is used).

    Raises
    ------
    FRFError
        Naming the file and the variable: not a MATLAB file, a missing variable, or values
        that do not make an FRF set (see :func:`~femcal.testdata.data.frf_of`).
    """
    z = load_mat(path, squeeze_me=True)
    missing = set(_VARIABLES) - set(z)
    if missing:
        if not any(isinstance(v, np.ndarray) and v.dtype.names and "x_values" in v.dtype.names
                   and "y_values" in v.dtype.names for v in z.values()):  # fmt: skip
            raise FRFError(f"{path}: missing {', '.join(sorted(missing))} (and no Test.Lab "
                           "struct with x_values and y_values)")  # fmt: skip
        return read_lms_mat(path, quantity=quantity)
    f = np.atleast_1d(np.asarray(z["frequency_hz"]))
    outs = np.atleast_1d(np.asarray(z["output_labels"], dtype=object))
    ins = np.atleast_1d(np.asarray(z["input_labels"], dtype=object))
    H = np.asarray(z["H"])
    shape = (len(outs), len(ins), len(f))
    if H.shape not in (shape, tuple(n for n in shape if n != 1)):  # squeeze_me drops 1s
        raise FRFError(f"{path}: H has shape {H.shape}; expected (outputs, inputs, "
                       f"frequencies) = {shape}")  # fmt: skip
    texts = {k: str(z[k]) if np.size(z[k]) else "" for k in ("quantity", "units") if k in z}
    data = frf_of(str(path), f, H.reshape(shape), outs, ins, texts["quantity"],
                  texts.get("units", ""))  # fmt: skip
    if "coherence" not in z:
        return data
    coherence = np.asarray(z["coherence"])

    def squeezed(s: tuple[int, ...]) -> tuple[int, ...]:  # as squeeze_me reads it
        return tuple(n for n in s if n != 1)

    per_output, per_frf = (shape[0], shape[2]), shape
    if coherence.shape in (per_output, squeezed(per_output)):
        coherence = coherence.reshape(per_output)
    elif coherence.shape in (per_frf, squeezed(per_frf)):
        coherence = coherence.reshape(per_frf)
    else:
        raise FRFError(f"{path}: coherence has shape {coherence.shape}; expected (outputs, "
                       f"frequencies) = ({shape[0]}, {shape[2]}) or (outputs, inputs, "
                       f"frequencies) = {shape}")  # fmt: skip
    try:
        return replace(data, coherence=coherence)
    except FRFError as e:
        raise FRFError(f"{path}: {e}") from None


register(Format("mat", "frf", (".mat",), read_mat, write_mat,
                "MATLAB v5 (femcal's variables, or LMS Test.Lab structs)"))
