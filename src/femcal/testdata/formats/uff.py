"""FRF data as universal files (UFF dataset 58, ASCII or binary 58b), through pyuff."""

from __future__ import annotations

import gc
import os
import re
import warnings
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ...atomic import write_atomic
from ...errors import FemcalWarning
from ..data import Channel, FRFData, FRFError, check_frequencies, frf_of, pair_names
from .registry import Format, register

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
    about 2.5 times smaller), complex ordinates, and each FRF's coherence when the data have
    one (function type 6; a multiple coherence per output is left out with a warning:
    pyuff writes no function type 26); channels must be ``GRID:DIR`` (direction
    codes 1-6 or signed axes), and there must be 2 frequencies at least. The frequencies
    keep 6 significant digits (the format's E13.5 fields) unless they are unevenly spaced
    and ``binary``.

    Raises
    ------
    ValueError
        For a channel that names no grid and direction; FRFError for fewer than 2
        frequencies, or frequencies that become one in 6 significant digits.
    """
    import pyuff

    path = Path(path)
    sets = []
    f = np.asarray(data.frequency_hz, float)
    if len(f) < 2:  # pyuff takes the abscissa step from the first two
        raise FRFError(f"{path}: {len(f)} frequency; a UFF 58 file (as pyuff writes it) "
                       "needs at least 2")  # fmt: skip
    df = np.diff(f)
    even = len(f) > 1 and np.allclose(df, df[0], rtol=1e-9, atol=0)
    _check_abscissa(f, even, binary, path)
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
    coherence = None if data.coherence is None else np.asarray(data.coherence, float)
    if coherence is not None and coherence.ndim == 2:
        warnings.warn(FemcalWarning(f"{path}: the multiple coherence is not written (pyuff "
                                    "writes no function type 26); keep it in .npz or .mat"),
                      stacklevel=2)  # fmt: skip
        coherence = None
    pairs = [] if coherence is None else [
        (o, co, i, ci) for o, co in enumerate(data.outputs) for i, ci in enumerate(data.inputs)]
    for o, co, i, ci in pairs:
        sets.append(pyuff.prepare_58(
            binary=int(binary), id1=f"Coherence {co.label} / {ci.label}", id2="NONE",
            id3="coherence", id4="femcal", id5="NONE", func_type=6,
            rsp_node=co.grid if co.grid is not None else 0, rsp_dir=_uff_direction(co),
            ref_node=ci.grid if ci.grid is not None else 0, ref_dir=_uff_direction(ci),
            ord_data_type=4, abscissa_spacing=1 if even else 0,
            abscissa_spec_data_type=18, ordinate_spec_data_type=0,
            orddenom_spec_data_type=0, data=coherence[o, i], x=f,
        ))  # fmt: skip

    return write_uff_sets(path, sets)


def write_uff_sets(path: str | os.PathLike[str], sets: list[dict]) -> Path:
    """Write datasets prepared with pyuff (``pyuff.prepare_*``) as one universal file,
    atomically (:func:`femcal.atomic.write_atomic`)."""
    import pyuff

    def dump(tmp: str) -> None:
        Path(tmp).unlink()  # pyuff adds to a file that exists: start from none
        # pyuff leaves each set's file object to the garbage collector, which closes (and
        # flushes) it with a ResourceWarning; collected here, before the file is renamed
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ResourceWarning)
            pyuff.UFF(tmp).write_sets(sets, mode="add")
            gc.collect()

    return write_atomic(Path(path), dump)


def _e13_5(x: np.ndarray) -> np.ndarray:
    """Values as a UFF E13.5 field gives them back: 6 significant digits."""
    return np.array([float(f"{v:.5e}") for v in np.atleast_1d(x)])


def _check_abscissa(f: np.ndarray, even: bool, binary: bool, path: Path) -> None:
    """Refuse frequencies that UFF 58 cannot tell apart: the header's abscissa start and
    step, and the abscissae of unevenly spaced ASCII data, are E13.5 fields (6 significant
    digits); frequencies that become one there would make a file no reader takes."""
    if even:
        written = _e13_5(f[0])[0] + _e13_5(f[1] - f[0])[0] * np.arange(len(f))
    else:
        written = f if binary else _e13_5(f)
    same = np.flatnonzero(np.diff(written) <= 0)
    if same.size:
        k = int(same[0])
        a, b = float(f[k]), float(f[k + 1])
        raise FRFError(f"{path}: frequencies {a!r} and {b!r} Hz become one ({written[k]:g} "
                       "Hz) in UFF 58's 6 significant digits; expected frequencies that "
                       "differ in them (or a .npz, .csv or .mat file)")


#: A dataset delimiter as pyuff finds one: ``    -1`` at the end of a line (or of the file),
#: or followed by 74 blanks and more.
_DELIMITER = re.compile(rb"    -1(?=\n|\r|\Z| {74}.)", re.DOTALL)


@dataclass(frozen=True)
class _Dataset:
    """One dataset of a universal file: its number (1-based), its type (58 for ``58`` and
    ``58b``; None if the type line is not a number) and the line of its opening
    delimiter."""

    number: int
    type: int | None
    line: int

    def where(self, path: Path) -> str:
        """``file:line: dataset N``, how messages name it."""
        return f"{path}:{self.line}: dataset {self.number}"


def _datasets(raw: bytes, path: Path) -> list[_Dataset]:
    """The datasets of a universal file, delimited as pyuff delimits them.

    Raises
    ------
    FRFError
        For an odd number of delimiters (the file ends inside its last dataset: cut short),
        naming the dataset and the line where it starts; or for text outside the datasets
        (before the first, between two, after the last: the rest of a dataset whose
        delimiter was lost), naming its line.
    """
    starts = np.array([m.start() for m in _DELIMITER.finditer(raw)], dtype=np.int64)
    newlines = np.flatnonzero(np.frombuffer(raw, np.uint8) == 10)
    lines = np.searchsorted(newlines, starts) + 1
    if len(starts) % 2:
        n = len(starts) // 2 + 1
        raise FRFError(f"{path}:{lines[-1]}: dataset {n} has no closing '    -1' line: the "
                       "file ends inside it (cut short?); expected every dataset closed")
    if len(starts):  # text before, between or after the datasets: a dataset cut short?
        outside = zip(np.append(0, starts[1::2] + 6), np.append(starts[::2], len(raw)),
                      strict=True)  # fmt: skip
        for a, b in outside:
            chunk = raw[a:b]
            if chunk.strip():
                at = a + len(chunk) - len(chunk.lstrip())
                raise FRFError(f"{path}:{np.searchsorted(newlines, at) + 1}: text outside any "
                               "dataset (a dataset without its opening '    -1', or one cut "
                               "short?); expected datasets between '    -1' lines")
    out = []
    for k, (a, b) in enumerate(zip(starts[::2], starts[1::2], strict=True)):
        head = raw[a:min(b, a + 200)].splitlines()
        text = head[1][:6].strip() if len(head) > 1 else b""
        try:
            kind = int(text)
        except ValueError:
            kind = None
        out.append(_Dataset(k + 1, kind, int(lines[2 * k])))
    return out


def _interruption(error: BaseException) -> BaseException | None:
    """A KeyboardInterrupt (or another BaseException that is not an Exception) that pyuff's
    bare ``except:`` turned into an Exception, found in the chain of ``error``."""
    seen = set()
    e: BaseException | None = error
    while e is not None and id(e) not in seen:
        seen.add(id(e))
        if not isinstance(e, Exception):
            return e
        e = e.__cause__ or e.__context__
    return None


def _pyuff_failure(error: Exception, where: str) -> FRFError:
    """femcal's error for an exception pyuff raised while reading ``where``; an interruption
    (Ctrl-C) hidden in it is raised again instead."""
    hidden = _interruption(error)
    if hidden is not None:
        raise hidden
    cause = error  # pyuff re-raises as bare Exceptions: the first one tells what went wrong
    while cause.__context__ is not None and cause.__context__ is not cause:
        cause = cause.__context__
    return FRFError(f"{where}: pyuff cannot read it ({type(cause).__name__}: {cause}); "
                    "expected a dataset 58 as the universal file format defines it")


def _integer(dset: dict, key: str, where: str) -> int:
    """A header field of a dataset read by pyuff as an integer; FRFError naming it."""
    value = dset.get(key)
    if isinstance(value, (int, np.integer)):
        return int(value)
    raise FRFError(f"{where}: header field {key} is {value!r}; expected an integer")


def read_uff(path: str | os.PathLike[str]) -> FRFData:
    """FRFs of every dataset 58 with function type 4 (FRF) in a universal file, arranged as
    outputs x inputs (labels ``GRID:DIR``), with their coherence when the file holds one
    for every FRF (function type 6, ordinary coherence) or every response (26, multiple
    coherence). Other datasets are skipped; a dataset 58 of another function type is skipped
    with a :class:`~femcal.errors.FemcalWarning`, and so is an ordinate type that names no
    FRF quantity (the FRFs are then taken as receptance).

    Raises
    ------
    FRFError
        Naming the file, the line and the dataset: a file cut short inside a dataset, a
        dataset pyuff cannot read, a header whose number of points the data do not have,
        real ordinates (an FRF must be complex), frequencies that are not finite and
        increasing, values that are not finite, datasets on different frequency axes or of
        different quantities, a pair given twice, or output/input pairs that no dataset
        gives (naming them).
    """
    import pyuff

    path = Path(path)
    sets = _datasets(path.read_bytes(), path)
    try:
        uff = pyuff.UFF(str(path))
        n_sets = uff.get_n_sets()
    except Exception as e:  # pyuff raises bare Exceptions
        raise _pyuff_failure(e, str(path)) from e
    if n_sets != len(sets):  # both split at the same delimiters
        raise FRFError(f"{path}: pyuff finds {n_sets} datasets, femcal {len(sets)}; "
                       "expected a universal file of complete datasets")  # fmt: skip
    f: np.ndarray | None = None
    first: _Dataset | None = None
    quantity_code = 0
    units = ""
    outs: dict[str, int] = {}
    ins: dict[str, int] = {}
    cells: dict[tuple[int, int], tuple[np.ndarray, _Dataset]] = {}
    coherences: list[tuple[int, dict, _Dataset]] = []
    for ds in sets:
        where = ds.where(path)
        if ds.type is None:
            raise FRFError(f"{where}: the dataset type (the line after '    -1') is not a "
                           "number; expected e.g. 58 or 58b")  # fmt: skip
        if ds.type != 58:
            continue
        try:
            s = uff.read_sets(ds.number - 1)
        except Exception as e:  # pyuff raises bare Exceptions
            raise _pyuff_failure(e, where) from e
        kind = _integer(s, "func_type", where)
        if kind in _COHERENCE:
            coherences.append((kind, s, ds))
            continue
        if kind != 4:
            warnings.warn(f"{where}: a dataset 58 of function type {s['func_type']}, not an "
                          "FRF (4) or a coherence (6, 26): skipped", FemcalWarning,
                          stacklevel=2)  # fmt: skip
            continue
        x, h = _frf_values(s, where)
        o_lab = _uff_label(_integer(s, "rsp_node", where), _integer(s, "rsp_dir", where))
        i_lab = _uff_label(_integer(s, "ref_node", where), _integer(s, "ref_dir", where))
        code = _integer(s, "ordinate_spec_data_type", where)
        if f is None or first is None:
            f, first, quantity_code = x, ds, code
            units = str(s.get("id2", "")).strip()
        else:
            if len(x) != len(f) or not np.allclose(x, f, rtol=1e-9, atol=1e-12):
                raise FRFError(f"{where}: its {len(x)} frequencies ({x[0]:g}-{x[-1]:g} Hz) "
                               f"are not those of dataset {first.number} ({len(f)}, "
                               f"{f[0]:g}-{f[-1]:g} Hz); expected one frequency axis")
            if code != quantity_code:
                raise FRFError(f"{where}: ordinate type {code}, dataset {first.number} "
                               f"{quantity_code}; expected one quantity in a file")
        o = outs.setdefault(o_lab, len(outs))
        i = ins.setdefault(i_lab, len(ins))
        if (o, i) in cells:
            raise FRFError(f"{where}: output {o_lab} / input {i_lab} again (first in dataset "
                           f"{cells[o, i][1].number}); expected each pair once")  # fmt: skip
        bad = np.flatnonzero(~np.isfinite(h))
        if bad.size:
            raise FRFError(f"{where}: output {o_lab} / input {i_lab} at {x[bad[0]]:g} Hz: H "
                           f"is {h[bad[0]]}; expected finite values")  # fmt: skip
        cells[o, i] = (h, ds)
    if f is None:
        raise FRFError(f"{path}: no dataset 58 FRF (function type 4)")
    if len(cells) < len(outs) * len(ins):
        have = np.zeros((len(outs), len(ins)), bool)
        have[tuple(np.array(list(cells)).T)] = True
        channels = lambda labels: [Channel.parse(c) for c in labels]  # noqa: E731
        raise FRFError(f"{path}: {int((~have).sum())} of {have.size} output/input pairs have "
                       "no dataset: " + pair_names(channels(outs), channels(ins),
                                                   np.argwhere(~have))
                       + "; expected an FRF for every output and input")  # fmt: skip
    H = np.empty((len(outs), len(ins), len(f)), complex)
    for (o, i), (h, _) in cells.items():
        H[o, i] = h
    quantity = _UFF_QUANTITY.get(quantity_code)
    if quantity is None:
        warnings.warn(FemcalWarning(
            f"{path}: ordinate data type {quantity_code} (record 8) names no response per "
            "force (8 displacement, 11 velocity, 12 acceleration); the FRFs are taken as "
            "receptance: check the units"), stacklevel=2)  # fmt: skip
        quantity = "receptance"
    data = frf_of(str(path), f, H, list(outs), list(ins), quantity,
                  "" if units == "NONE" else units)  # fmt: skip
    coherence = _coherence(coherences, f, outs, ins, path)
    return data if coherence is None else replace(data, coherence=coherence)


#: Function types of the coherence datasets read with FRFs: 6 ordinary coherence (of each
#: response and reference), 26 multiple coherence (of each response).
_COHERENCE = (6, 26)
_UFF_QUANTITY = {v: k for k, v in _UFF_ORDINATE.items()}


def _coherence(sets: list[tuple[int, dict, _Dataset]], f: np.ndarray, outs: dict[str, int],
               ins: dict[str, int], path: Path) -> np.ndarray | None:  # fmt: skip
    """The coherence of the FRFs from the file's coherence datasets: (n_out, n_in, K) when
    every FRF has an ordinary coherence, else (n_out, K) when every response has a multiple
    coherence, else None (with a warning when some are there but not all)."""
    if not sets:
        return None
    pair = np.full((len(outs), len(ins), len(f)), np.nan)
    multiple = np.full((len(outs), len(f)), np.nan)
    for kind, s, ds in sets:
        where = ds.where(path)
        x = np.asarray(s.get("x"), dtype=float).reshape(-1)
        y = np.asarray(s.get("data")).reshape(-1)
        if len(x) != len(f) or not np.allclose(x, f, rtol=1e-9, atol=1e-12):
            raise FRFError(f"{where}: a coherence on {len(x)} frequencies, not on the FRFs' "
                           f"{len(f)}; expected one frequency axis")  # fmt: skip
        if np.iscomplexobj(y):
            y = y.real
        if not (np.isfinite(y).all() and (y >= -1e-6).all() and (y <= 1 + 1e-6).all()):
            raise FRFError(f"{where}: a coherence outside [0, 1]; expected values from 0 to 1")
        o = outs.get(_uff_label(_integer(s, "rsp_node", where), _integer(s, "rsp_dir", where)))
        if o is None:
            continue
        if kind == 6:
            i = ins.get(_uff_label(_integer(s, "ref_node", where), _integer(s, "ref_dir", where)))
            if i is not None:
                pair[o, i] = np.clip(y, 0.0, 1.0)
        else:
            multiple[o] = np.clip(y, 0.0, 1.0)
    if np.isfinite(pair).all():
        return pair
    if np.isfinite(multiple).all():
        return multiple
    warnings.warn(FemcalWarning(f"{path}: coherence datasets for some FRFs only: "
                                "the coherence is not used"), stacklevel=3)  # fmt: skip
    return None


def _frf_values(dset: dict, where: str) -> tuple[np.ndarray, np.ndarray]:
    """(frequencies, complex values) of one dataset 58 as pyuff read it, checked against
    its header; FRFError naming the field otherwise."""
    kind = _integer(dset, "ord_data_type", where)
    if kind in (2, 4):
        raise FRFError(f"{where}: ordinate data type {kind} is real; expected complex "
                       "FRFs (type 5 or 6): identification and calibration need the phase, "
                       "which magnitudes alone do not give")  # fmt: skip
    if kind not in (5, 6):
        raise FRFError(f"{where}: ordinate data type {kind}; expected 5 or 6 (complex)")
    x = np.asarray(dset.get("x"), dtype=float).reshape(-1)
    h = np.asarray(dset.get("data")).reshape(-1)
    n = _integer(dset, "num_pts", where)
    if len(x) != n or len(h) != n:
        raise FRFError(f"{where}: the header gives {n} points (record 7), the data hold "
                       f"{len(h)}; expected as many as the header says (a line lost?)")
    if n == 0:
        raise FRFError(f"{where}: no points; expected at least one frequency")
    check_frequencies(x, where)
    return x, h.astype(complex)


register(Format("uff", "frf", (".uff", ".unv"), read_uff, write_uff, "universal file, dataset 58"))
