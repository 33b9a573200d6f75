"""Identified models on disk: an NPZ with the state-space model, the modes and the channel
report, and a JSON summary. Files are written atomically."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from ..atomic import write_atomic
from ..identify.layout import Layout
from ..identify.workflow import IdentifiedModel
from ..response.statespace import StateSpace
from ..testdata.data import Channel

#: Keys of the model NPZ (all arrays).
NPZ_KEYS = ("A", "B", "C", "D", "residual_states", "poles", "frequency_hz", "damping_ratio",
            "shapes", "participation", "output_labels", "input_labels", "quantity", "units",
            "band", "fit_error", "suspect", "consistency")  # fmt: skip
#: The quality arrays of the NPZ (read when present).
QUALITY_KEYS = ("mpc", "mpd", "complexity", "frf_correlation", "peaks_hz")
#: Keys read when present (a model written before the layout was kept has none of them).
OPTIONAL_KEYS = ("transposed", "method", *QUALITY_KEYS, "warnings")


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
                 suspect=model.suspect, consistency=consistency,
                 transposed=np.array(bool(model.layout and model.layout.transposed)),
                 method=np.array(model.method), warnings=np.array(model.warnings, dtype=str),
                 **{k: getattr(model, k) for k in QUALITY_KEYS
                    if getattr(model, k) is not None})  # fmt: skip

    return write_atomic(path, dump)


def read_model(path: str | os.PathLike[str]) -> IdentifiedModel:
    """Read what :func:`write_model` writes; KeyError names missing keys, ValueError a file
    that is not a NumPy archive."""
    try:
        archive = np.load(path, allow_pickle=False)
    except (ValueError, OSError) as e:
        if isinstance(e, FileNotFoundError | IsADirectoryError | PermissionError):
            raise
        raise ValueError(f"{path}: not an identified model (femcal identify's model.npz, a "
                         "NumPy archive)") from None  # fmt: skip
    if not hasattr(archive, "files"):  # one array (.npy), not an archive
        raise ValueError(f"{path}: not an identified model (femcal identify's model.npz)")
    with archive as z:
        missing = [k for k in NPZ_KEYS if k not in z]
        if missing:
            raise KeyError(f"{path}: not an identified model (missing {', '.join(missing)})")
        consistency = z["consistency"]
        outputs = tuple(Channel.parse(str(s)) for s in z["output_labels"])
        inputs = tuple(Channel.parse(str(s)) for s in z["input_labels"])
        # a model written before the layout was kept has its shapes at the outputs
        flipped = "transposed" in z and bool(z["transposed"])
        layout = Layout(flipped, *((inputs, outputs) if flipped else (outputs, inputs)))
        extra = {k: z[k] for k in QUALITY_KEYS if k in z}
        return IdentifiedModel(
            StateSpace(z["A"], z["B"], z["C"], z["D"]), z["residual_states"], z["poles"],
            z["frequency_hz"], z["damping_ratio"], z["shapes"], z["participation"],
            outputs, inputs, str(z["quantity"]),
            str(z["units"]), (float(z["band"][0]), float(z["band"][1])), z["fit_error"],
            z["suspect"], consistency=None if np.isnan(consistency).all() else consistency,
            layout=layout, method=str(z["method"]) if "method" in z else "",
            warnings=tuple(str(w) for w in z["warnings"]) if "warnings" in z else (),
            **extra,
        )  # fmt: skip


def _optional(values: np.ndarray | None, k: int) -> float | None:
    return None if values is None else float(values[k])


def summary(model: IdentifiedModel) -> dict:
    """JSON-ready summary: band, method, layout (which side the shapes are on), poles
    (frequency, damping, MPC, MPD, complexity, shape at the roving channels, participation
    of the references), parts, channels (fit error, FRF correlation, consistency error,
    suspect), CMIF peaks and warnings."""
    cons = model.consistency
    layout = model.layout or Layout(False, model.outputs, model.inputs)
    corr = model.frf_correlation
    return {
        "band_hz": list(model.band),
        "method": model.method,
        "quantity": model.quantity,
        "units": model.units,
        "layout": {"kind": layout.kind, "transposed": layout.transposed,
                   "description": layout.describe(),
                   "shape_channels": [c.label for c in layout.roving],
                   "reference_channels": [c.label for c in layout.references]},
        "n_states": int(model.system.n_states),
        "n_residual_states": int(np.sum(model.residual_states)),
        "poles": [
            {"mode": k + 1, "frequency_hz": float(f), "damping_ratio": float(z),
             "mpc": _optional(model.mpc, k), "mpd_deg": _optional(model.mpd, k),
             "complexity_percent": _optional(model.complexity, k),
             "shape": {c.label: [float(v.real), float(v.imag)]
                       for c, v in zip(layout.roving, model.shapes[:, k], strict=True)},
             "participation": {c.label: [float(v.real), float(v.imag)]
                               for c, v in zip(layout.references, model.participation[:, k],
                                               strict=True)}}
            for k, (f, z) in enumerate(zip(model.frequency_hz, model.damping_ratio, strict=True))
        ],
        "parts": [
            {"band_hz": list(p.band), "order": p.order, "automatic_order": p.automatic,
             "poles_hz": [float(abs(x) / (2 * np.pi)) for x in p.poles]}
            for p in model.parts
        ],
        "channels": [
            {"label": c.label, "fit_error": float(e), "suspect": bool(s),
             "frf_correlation": _optional(corr, i),
             "consistency_error": None if cons is None else float(cons[i])}
            for i, (c, e, s) in enumerate(zip(layout.roving, model.fit_error, model.suspect,
                                              strict=True))
        ],
        "fit_error_median": float(np.median(model.fit_error)),
        "suspect_channels": [c.label for c, s in zip(layout.roving, model.suspect, strict=True)
                             if s],
        "cmif_peaks_hz": [] if model.peaks_hz is None else [float(x) for x in model.peaks_hz],
        "warnings": list(model.warnings),
    }  # fmt: skip


def write_summary(path: str | os.PathLike[str], model: IdentifiedModel) -> Path:
    """The :func:`summary` as an indented JSON file."""
    text = json.dumps(summary(model), indent=1)
    return write_atomic(path, lambda tmp: Path(tmp).write_text(text + "\n"))
