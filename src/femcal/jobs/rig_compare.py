"""The study's question on the virtual rig: which drives would each model need to reproduce a
target measured on the physical rig, and what would it predict for the channels nobody
controlled (the battery box)?

Each model is its own plant (the virtual rig): its FRF is inverted and its drives iterated
on it until its control channels follow the target (:mod:`femcal.rig.iterate`). Its drives
are then compared with the drives the physical rig used (when known) and its other outputs
with the target file's other channels (the uncontrolled ones the physical rig measured). A
model whose drives and uncontrolled responses are closer to the physical rig's stands in for
it better: the point of calibrating it.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ConfigError, TimeDataError
from ..io.rig import settings_dict
from ..model.build import load_model
from ..model.model import Model
from ..rig.iterate import Iteration, IterationSettings, frf_on_lines, iterate_drive
from ..rig.plant import RigPlant
from ..rig.quality import band_rms
from ..testdata.timedata import TimeData
from ..testdata.units import unit_factor
from .synthetic_test import hidden_values


@dataclass(frozen=True)
class ModelOnRig:
    """One model iterated on itself against the target.

    Attributes
    ----------
    name : the model's name.
    plant : the model on its rig.
    iteration : its drive iteration.
    drive_error : (n_drives,) RMS of (drive - reference drive) over the reference's RMS, in
        the drive band (None without a reference drive).
    channel_error : each uncontrolled channel the target file holds (accelerometers, then
        load cells; not the LVDTs, which read the drives) -> RMS of (response - target) over
        the target's RMS.
    """

    name: str
    plant: RigPlant
    iteration: Iteration
    drive_error: np.ndarray | None
    channel_error: dict[str, float]


def compare_models(models: Sequence[tuple[str, RigPlant]], target: TimeData,
                   control: Sequence[str], settings: IterationSettings | None = None, *,
                   reference_drive: np.ndarray | None = None,
                   weights: Sequence[float] | None = None,
                   progress: Callable[[str], None] | None = None) -> list[ModelOnRig]:  # fmt: skip
    """Iterate every model on itself against the target's ``control`` channels and compare
    (see the module docstring). ``reference_drive`` (n_drives, n): the drives the physical
    rig used, in the models' actuator order.

    Raises
    ------
    TimeDataError
        For a control channel the target or a model lacks, models with other actuators or
        outputs, or a reference drive of another shape.
    """
    s = settings or IterationSettings()
    if not models:
        raise TimeDataError("no model to compare")
    first = models[0][1]
    for name, plant in models:
        if plant.inputs != first.inputs or plant.outputs != first.outputs:
            raise TimeDataError(f"model {name}: its actuators or outputs differ from model "
                                f"{models[0][0]}'s; expected the same rig")  # fmt: skip
    for c in control:
        target.channel(c)  # the target has it (else an error naming the channels it has)
    missing = [c for c in control if c not in first.outputs]
    if missing:
        raise TimeDataError(f"control channel(s) {', '.join(missing)}: not outputs of the rig")
    idx = [first.outputs.index(c) for c in control]

    def measured(c: str) -> np.ndarray:
        """The target's channel ``c`` in the unit of the rig's output of that name."""
        r = target.channel(c)
        to = first.output_units[first.outputs.index(c)]
        return target.values[r] * unit_factor(target.units[r], to, f"target channel {c!r}")

    values = np.vstack([measured(c) for c in control])
    n, dt = values.shape[1], target.dt
    if reference_drive is not None and reference_drive.shape != (len(first.inputs), n):
        raise TimeDataError(f"a reference drive of shape {reference_drive.shape}; expected "
                            f"(actuators, samples) = ({len(first.inputs)}, {n})")  # fmt: skip
    # the uncontrolled channels the physical rig measured: accelerometers first, then load
    # cells (the LVDTs read the drives, compared above)
    others = [c for c in first.outputs if c in target.names and c not in control
              and not c.endswith(":displacement")]  # fmt: skip
    others.sort(key=lambda c: c.endswith(":force"))
    out = []
    for name, plant in models:
        if progress is not None:
            progress(f"model {name}: iterating on itself")
        H = frf_on_lines(plant, idx, n, dt, s.band)
        it = iterate_drive(plant, H, values, idx, dt, s, weights=weights,
                           progress=None if progress is None
                           else (lambda m, name=name: progress(f"model {name}: {m}")))  # fmt: skip
        drive_error = None
        if reference_drive is not None:
            drive_error = (band_rms(it.drive - reference_drive, dt, s.band)
                           / band_rms(reference_drive, dt, s.band))  # fmt: skip
        errors = {}
        for c in others:
            meas = measured(c)
            size = np.sqrt(np.mean(meas**2))
            diff = it.response[plant.outputs.index(c)] - meas
            errors[c] = float(np.sqrt(np.mean(diff**2)) / size) if size > 0 else float("nan")
        out.append(ModelOnRig(name, plant, it, drive_error, errors))
    return out


def calibrated_values(report: str | Path) -> dict[str, float]:
    """Each parameter's calibrated value (name -> value) from a calibration's report.json.

    Raises
    ------
    ConfigError
        Naming the file: not JSON, or no ``parameters`` list of names and calibrated values.
    """
    try:
        doc = json.loads(Path(report).read_text())
        return {str(p["name"]): float(p["calibrated"]) for p in doc["parameters"]}
    except (ValueError, KeyError, TypeError) as e:
        raise ConfigError(f"{report}: not a calibration report (report.json with parameters, "
                          f"each with a name and a calibrated value): {e}") from None


def model_with_values(deck: Path, params: Path | None, given: dict[str, float] | None) -> Model:
    """The deck's model, with ``given`` values (name -> value) set through the parameters
    file ``params`` when given (every parameter of the file must have one)."""
    model = load_model(deck)
    if given is None:
        return model
    if params is None:
        raise ConfigError("values for the parameters need the parameters file")
    return hidden_values(model, params, 0.0, np.random.default_rng(0), given)[0]


def comparison_dict(runs: Sequence[ModelOnRig], settings: IterationSettings, *, target: str,
                    control: Sequence[str]) -> dict:  # fmt: skip
    """The comparison as JSON: per model the control error after each step, each drive's
    error against the reference (when known) and each uncontrolled channel's error."""
    models = []
    for r in runs:
        entry = {"name": r.name,
                 "control_rms_error": [float(v) for v in r.iteration.rms_error[-1]],
                 "uncontrolled_rms_error": r.channel_error}
        if r.drive_error is not None:
            entry["drive_rms_error"] = {a: float(v) for a, v in
                                        zip(r.plant.inputs, r.drive_error, strict=True)}
        models.append(entry)
    return {"target": target, "control": list(control),
            "settings": settings_dict(settings),
            "actuators": list(runs[0].plant.inputs) if runs else [],
            "models": models}  # fmt: skip


def comparison_lines(report: dict) -> list[str]:
    """The comparison as console lines: per model the worst control error, the drives'
    median and worst error and the uncontrolled channels' median and worst error."""
    lines = [f"{'model':<16} {'control err %':>13} {'drive err % (median, worst)':>28} "
             f"{'uncontrolled err % (median, worst)':>35}"]
    for m in report["models"]:
        d = list(m.get("drive_rms_error", {}).values())
        u = [v for v in m["uncontrolled_rms_error"].values() if np.isfinite(v)]
        drive = f"{100 * np.median(d):.2f}, {100 * max(d):.2f}" if d else "-"
        other = f"{100 * np.median(u):.2f}, {100 * max(u):.2f}" if u else "-"
        lines.append(f"{m['name']:<16} {100 * max(m['control_rms_error']):13.2f} "
                     f"{drive:>28} {other:>35}")
    return lines
