"""Identified models on disk: an NPZ with the state-space model, the modes and the channel
report, and a JSON summary. Files are written atomically."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from ..atomic import write_atomic
from ..identify.workflow import IdentifiedModel
from ..response.statespace import StateSpace
from ..testdata.data import Channel

#: Keys of the model NPZ (all arrays).
NPZ_KEYS = ("A", "B", "C", "D", "residual_states", "poles", "frequency_hz", "damping_ratio",
            "shapes", "participation", "output_labels", "input_labels", "quantity", "units",
            "band", "fit_error", "suspect", "consistency")  # fmt: skip


def write_model(path: str | os.PathLike[str], model: IdentifiedModel) -> Path:
    """NPZ with the keys :data:`NPZ_KEYS` (``A``..``D`` real, ``poles`` complex (k,),
    ``shapes`` (p, k) complex, labels as strings)."""
    consistency = (model.consistency if model.consistency is not None
                   else np.full(len(model.outputs), np.nan))  # fmt: skip

    def dump(tmp: str) -> None:
        np.savez(tmp, A=model.system.A, B=model.system.B, C=model.system.C, D=model.system.D,
                 residual_states=model.residual_states, poles=model.poles,
                 frequency_hz=model.frequency_hz, damping_ratio=model.damping_ratio,
                 shapes=model.shapes, participation=model.participation,
                 output_labels=np.array([c.label for c in model.outputs]),
                 input_labels=np.array([c.label for c in model.inputs]),
                 quantity=np.array(model.quantity), units=np.array(model.units),
                 band=np.array(model.band, float), fit_error=model.fit_error,
                 suspect=model.suspect, consistency=consistency)  # fmt: skip

    return write_atomic(path, dump)


def read_model(path: str | os.PathLike[str]) -> IdentifiedModel:
    """Read what :func:`write_model` writes; KeyError names missing keys."""
    with np.load(path, allow_pickle=False) as z:
        missing = [k for k in NPZ_KEYS if k not in z]
        if missing:
            raise KeyError(f"{path}: not an identified model (missing {', '.join(missing)})")
        consistency = z["consistency"]
        return IdentifiedModel(
            StateSpace(z["A"], z["B"], z["C"], z["D"]), z["residual_states"], z["poles"],
            z["frequency_hz"], z["damping_ratio"], z["shapes"], z["participation"],
            tuple(Channel.parse(str(s)) for s in z["output_labels"]),
            tuple(Channel.parse(str(s)) for s in z["input_labels"]), str(z["quantity"]),
            str(z["units"]), (float(z["band"][0]), float(z["band"][1])), z["fit_error"],
            z["suspect"], consistency=None if np.isnan(consistency).all() else consistency,
        )  # fmt: skip


def summary(model: IdentifiedModel) -> dict:
    """JSON-ready summary: band, poles (frequency, damping, shape), parts, channels (fit
    error, consistency error, suspect)."""
    cons = model.consistency
    return {
        "band_hz": list(model.band),
        "quantity": model.quantity,
        "units": model.units,
        "n_states": int(model.system.n_states),
        "n_residual_states": int(np.sum(model.residual_states)),
        "poles": [
            {"mode": k + 1, "frequency_hz": float(f), "damping_ratio": float(z),
             "shape": {c.label: [float(v.real), float(v.imag)]
                       for c, v in zip(model.outputs, model.shapes[:, k], strict=True)}}
            for k, (f, z) in enumerate(zip(model.frequency_hz, model.damping_ratio, strict=True))
        ],
        "parts": [
            {"band_hz": list(p.band), "order": p.order, "automatic_order": p.automatic,
             "poles_hz": [float(abs(x) / (2 * np.pi)) for x in p.poles]}
            for p in model.parts
        ],
        "channels": [
            {"label": c.label, "fit_error": float(e), "suspect": bool(s),
             "consistency_error": None if cons is None else float(cons[i])}
            for i, (c, e, s) in enumerate(zip(model.outputs, model.fit_error, model.suspect,
                                              strict=True))
        ],
        "fit_error_median": float(np.median(model.fit_error)),
        "suspect_channels": [c.label for c, s in zip(model.outputs, model.suspect, strict=True)
                             if s],
    }  # fmt: skip


def write_summary(path: str | os.PathLike[str], model: IdentifiedModel) -> Path:
    """The :func:`summary` as an indented JSON file."""
    text = json.dumps(summary(model), indent=1)
    return write_atomic(path, lambda tmp: Path(tmp).write_text(text + "\n"))
