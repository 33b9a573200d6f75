"""FRF data as universal files (UFF dataset 58, ASCII or binary 58b), through pyuff."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ...atomic import write_atomic
from ..data import Channel, FRFData
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


register(Format("uff", "frf", (".uff", ".unv"), read_uff, write_uff, "universal file, dataset 58"))
