"""``femcal rig ACTION``: the virtual 7-post rig (femcal.rig).

- ``simulate DECK --actuators CSV --sensors CSV --drive DRIVE.rsp --out RESPONSE.rsp
  [--damping Z | --damping-from MODEL.npz] [--modes-to HZ] [--periodic]``: the frame on its
  actuators played with a drive file;
- ``iterate DECK --actuators CSV --sensors CSV --target TARGET.rsp --control CHANNEL...
  [--plant DECK] [--iterations N] [--gain G] --out DIR``: drives that reproduce a target, as
  RPC Pro iterates them.

All time data are read and written by suffix (RPC III .rsp/.tim/.drv, CSV, NPZ).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from ..errors import TimeDataError
from ..io.identified import read_model
from ..io.rig import (
    iteration_dict,
    write_comparison_html,
    write_iteration_html,
    write_iteration_json,
)
from ..jobs.rig_compare import (
    calibrated_values,
    compare_models,
    comparison_dict,
    comparison_lines,
    model_with_values,
)
from ..model.build import load_model
from ..rig.iterate import (
    IterationSettings,
    correct_drive,
    frf_on_lines,
    frf_to_lines,
    iterate_drive,
    measured_frf,
)
from ..rig.plant import RigPlant, build_plant, damping_from_modes
from ..rig.simulate import simulate
from ..testdata.formats import read_frf, read_time_data, suffixes, write_time_data
from ..testdata.points import read_points
from ..testdata.timedata import TimeData
from ..testdata.units import unit_factor
from ..viz import rig as pictures
from .console import Console
from .paths import UsageError, output_file, output_folder

_D = IterationSettings()


def _plant_options(p: argparse.ArgumentParser, *, deck: bool = True) -> None:
    """The frame on its rig: the deck (unless each model names its own), actuators,
    sensors, damping (and with a deck, the damping of an identified model) and modes."""
    if deck:
        p.add_argument("deck", type=Path, help="NASTRAN deck of the frame on its oil columns")
    p.add_argument("--actuators", type=Path, required=True,
                   help="actuators CSV (label, grid of the oil column's frame end, direction)")
    p.add_argument("--sensors", type=Path, required=True, help="accelerometers CSV")
    p.add_argument("--damping", type=float, default=0.02, metavar="Z",
                   help="modal damping ratio of every mode (default 0.02)")
    if deck:
        p.add_argument("--damping-from", type=Path, metavar="MODEL.npz",
                       help="an identified model (femcal identify --out): each mode within "
                       "5 %% of an identified one takes its damping, the others "
                       "--damping")  # fmt: skip
    p.add_argument("--modes-to", type=float, default=200.0, metavar="HZ",
                   help="modes kept (default up to 200 Hz; the others enter statically)")


def _iteration_options(p: argparse.ArgumentParser, *, iterations: bool = True) -> None:
    """The settings of the iteration (:class:`IterationSettings`)."""
    if iterations:
        p.add_argument("--iterations", type=int, default=_D.iterations, metavar="N",
                       help=f"corrections after the first drive (default {_D.iterations})")
    p.add_argument("--gain", type=float, default=_D.gain,
                   help=f"gain of each correction (default {_D.gain:g})")
    p.add_argument("--rcond", type=float, default=_D.rcond,
                   help=f"singular values below RCOND x the largest are left out of the "
                   f"inverse (default {_D.rcond:g})")  # fmt: skip
    p.add_argument("--band", type=float, nargs=2, default=_D.band, metavar=("F1", "F2"),
                   help=f"drive band (default {_D.band[0]:g} {_D.band[1]:g} Hz)")


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("rig", help="the virtual 7-post rig: simulate, iterate drives",
                       description="The frame on its displacement-driven actuators: play a "
                       "drive file, or iterate drives that reproduce a target.")  # fmt: skip
    rsub = p.add_subparsers(dest="action", required=True, metavar="ACTION")
    sim = rsub.add_parser("simulate", help="play a drive file on the frame",
                          description="Simulate the frame on its actuators driven by a drive "
                          "file (one channel per actuator, named by its label, in the model's "
                          "length unit); writes every LVDT, load cell and "
                          "accelerometer.")  # fmt: skip
    _plant_options(sim)
    time_sfx = ", ".join(suffixes("time"))
    sim.add_argument("--drive", type=Path, required=True, help=f"drive file ({time_sfx})")
    sim.add_argument("--out", type=Path, required=True, metavar="FILE",
                     help=f"response file ({time_sfx})")
    sim.add_argument("--periodic", action="store_true",
                     help="take the drive as one period of a looped drive (steady state)")

    it = rsub.add_parser("iterate", help="iterate drives to reproduce a target",
                         description="Find the drives that make the control channels follow "
                         "a target: the model's FRF inverted (regularised SVD), first drive = "
                         "inverse x target, then drive += gain x inverse x (target - "
                         "response), each response played on the plant.")  # fmt: skip
    _plant_options(it)
    it.add_argument("--target", type=Path, required=True, help=f"target file ({time_sfx})")
    it.add_argument("--control", nargs="+", required=True, metavar="CHANNEL",
                    help="control channels: names in the target file and in the rig's outputs "
                    "(LABEL:+Z, LABEL:force, LABEL:displacement)")  # fmt: skip
    it.add_argument("--plant", type=Path, metavar="DECK",
                    help="the deck that plays the drives (the stand-in for the physical rig; "
                    "default the model's)")  # fmt: skip
    it.add_argument("--plant-damping", type=float, metavar="Z",
                    help="modal damping of the plant (default --damping)")
    it.add_argument("--frf", choices=("model", "measured"), default="model",
                    help="invert the model's FRF (default), or the FRF measured by playing "
                    "noise drives on the plant, as a rig does")  # fmt: skip
    _iteration_options(it)
    it.add_argument("--out", type=Path, required=True, metavar="DIR", help="folder to write")

    cor = rsub.add_parser("correct", help="one iteration step for a physical rig",
                          description="The drive/response exchange of a physical rig: without "
                          "--drive, the first drive (the model's inverse FRF x the target); "
                          "with --drive and --response (the control channels measured while "
                          "--drive played), the next drive = drive + gain x inverse x (target "
                          "- response).")  # fmt: skip
    _plant_options(cor)
    cor.add_argument("--target", type=Path, required=True, help=f"target file ({time_sfx})")
    cor.add_argument("--control", nargs="+", required=True, metavar="CHANNEL",
                     help="control channels (names in the target and response files)")
    cor.add_argument("--frf", type=Path, nargs="+", metavar="FILE",
                     help="invert these FRFs (femcal timedata frf of noise drives played on "
                     "the rig: inputs the actuators, LABEL or LABEL:displacement; outputs the "
                     "control channels, one unit a file) instead of the model's")  # fmt: skip
    cor.add_argument("--drive", type=Path, help="the drive that was played")
    cor.add_argument("--response", type=Path, help="the response measured while it played")
    _iteration_options(cor, iterations=False)
    cor.add_argument("--out", type=Path, required=True, metavar="DRIVE",
                     help=f"the next drive ({time_sfx})")

    cmp = rsub.add_parser("compare", help="models on the virtual rig against one target",
                          description="Iterate each model on itself (the virtual rig) until "
                          "its control channels follow the target; compare its drives with "
                          "the reference drive and its other outputs with the target's "
                          "uncontrolled channels.")  # fmt: skip
    cmp.add_argument("--model", action="append", required=True, metavar="NAME=DECK",
                     help="a model to compare (repeat); the first is drawn first")
    cmp.add_argument("--values", action="append", default=[], metavar="NAME=REPORT.json",
                     help="give model NAME a calibration's values (femcal calibrate's "
                     "report.json, matched by parameter name through --params)")  # fmt: skip
    cmp.add_argument("--params", type=Path, metavar="TOML",
                     help="the parameters file the calibration used (for --values)")
    _plant_options(cmp, deck=False)
    cmp.add_argument("--target", type=Path, required=True,
                     help="the physical rig's measured channels: the control channels and "
                     "any uncontrolled ones to compare")  # fmt: skip
    cmp.add_argument("--control", nargs="+", required=True, metavar="CHANNEL",
                     help="control channels (names in the target and the rig's outputs)")
    cmp.add_argument("--reference-drive", type=Path, metavar="DRIVE",
                     help="the drives the physical rig used, to compare the models' with")
    _iteration_options(cmp)
    cmp.add_argument("--out", type=Path, required=True, metavar="DIR", help="folder to write")


def _say(t0: float, msg: str) -> None:
    print(f"[{time.perf_counter() - t0:7.1f} s] {msg}", file=sys.stderr, flush=True)


def _plant(deck: Path, args: argparse.Namespace, damping: float, t0: float) -> RigPlant:
    if not (np.isfinite(damping) and 0 <= damping < 1):
        raise UsageError(f"damping {damping:g}: expected a ratio 0 <= Z < 1 (0.02 is 2 %)")
    if not (np.isfinite(args.modes_to) and args.modes_to > 0):
        raise UsageError(f"--modes-to {args.modes_to:g}: expected a frequency above 0 Hz")
    _say(t0, f"reading {deck}")
    plant = build_plant(load_model(deck), read_points(args.actuators),
                        read_points(args.sensors), modes_to=args.modes_to, damping=damping,
                        progress=lambda m: _say(t0, m))  # fmt: skip
    if args.damping_from is not None:
        try:
            ident = read_model(args.damping_from)
        except (KeyError, ValueError, OSError) as e:
            raise UsageError(f"--damping-from {args.damping_from}: {e}") from None
        zeta, taken = damping_from_modes(plant, ident.frequency_hz, ident.damping_ratio,
                                         damping)  # fmt: skip
        plant = plant.with_damping(zeta)
        _say(t0, f"{taken} of {plant.n_modes} modes take the identified damping")
    _say(t0, f"{plant.n_modes} modes up to {args.modes_to:g} Hz, {len(plant.inputs)} "
         f"actuators, {len(plant.outputs)} outputs")  # fmt: skip
    return plant


def drive_channels(data: TimeData, plant: RigPlant, where: Path) -> np.ndarray:
    """The drive (n_actuators, n) from a file's channels named by the actuators' labels (or
    ``LABEL:displacement``), converted to the model's length unit (a blank unit is taken to
    be the model's).

    Raises
    ------
    TimeDataError
        Naming the file and the actuator whose channel is missing, or a channel whose unit
        is not a length femcal converts.
    """
    rows = []
    for label in plant.inputs:
        for name in (label, f"{label}:displacement"):
            if name in data.names:
                c = data.names.index(name)
                break
        else:
            raise TimeDataError(f"{where}: no drive channel for actuator {label!r} (expected a "
                                f"channel named {label!r}); the channels are "
                                f"{', '.join(map(repr, data.names))}")  # fmt: skip
        factor = unit_factor(data.units[c], plant.input_units,
                             f"{where}: channel {data.names[c]!r}")  # fmt: skip
        rows.append(data.values[c] * factor)
    return np.vstack(rows)


def _simulate(args: argparse.Namespace) -> int:
    t0 = time.perf_counter()
    output_file(args.out, "--out", "time")
    drive_data = read_time_data(args.drive)
    plant = _plant(args.deck, args, args.damping, t0)
    drive = drive_channels(drive_data, plant, args.drive)
    n = drive.shape[1]
    _say(t0, f"playing {n} samples ({n * drive_data.dt:g} s at {1 / drive_data.dt:g} Hz)")
    console = Console(t0=t0)
    try:
        y = simulate(plant, drive, drive_data.dt, periodic=args.periodic, progress=console)
    finally:
        console.close()
    write_time_data(args.out, TimeData(drive_data.dt, y, plant.outputs, plant.output_units))
    _say(t0, f"wrote {args.out}")
    width = max(len(n) for n in plant.outputs)
    print(f"{'channel':<{width}} {'unit':<8} {'rms':>12} {'peak':>12}")
    for name, unit, v in zip(plant.outputs, plant.output_units, y, strict=True):
        print(f"{name:<{width}} {unit:<8} {np.sqrt(np.mean(v**2)):12.5g} "
              f"{np.abs(v).max():12.5g}")  # fmt: skip
    return 0


def _iteration_settings(args: argparse.Namespace) -> IterationSettings:
    try:
        return IterationSettings(iterations=getattr(args, "iterations", 0), gain=args.gain,
                                 rcond=args.rcond, band=tuple(args.band))  # fmt: skip
    except ValueError as e:
        raise UsageError(str(e)) from None


def _iterate(args: argparse.Namespace) -> int:
    t0 = time.perf_counter()
    settings = _iteration_settings(args)
    output_folder(args.out, "--out")
    target_data = read_time_data(args.target)
    model = _plant(args.deck, args, args.damping, t0)
    plant = model
    if args.plant is not None or args.plant_damping is not None:
        deck = args.plant if args.plant is not None else args.deck
        damping = args.plant_damping if args.plant_damping is not None else args.damping
        plant = _plant(deck, args, damping, t0)
        if plant.outputs != model.outputs or plant.inputs != model.inputs:
            raise UsageError(f"--plant {deck}: its actuators and outputs differ from the "
                             "model's")  # fmt: skip
    control = []
    for name in args.control:
        if name not in model.outputs:
            raise UsageError(f"--control {name}: not an output of the rig; expected one of "
                             f"{', '.join(model.outputs)}")  # fmt: skip
        control.append(model.outputs.index(name))
    target = _channels(target_data, args.control, args.target, model)
    dt, n = target_data.dt, target.shape[1]
    if settings.band[1] >= 0.5 / dt:
        raise UsageError(f"--band {settings.band[0]:g} {settings.band[1]:g}: above the "
                         f"target's Nyquist frequency {0.5 / dt:g} Hz")  # fmt: skip
    if args.frf == "model":
        H = frf_on_lines(model, control, n, dt, settings.band)
        how = "the model's FRF"
    else:
        _say(t0, "measuring the FRF: noise drives on the plant")
        H = measured_frf(plant, control, n, dt, settings.band)
        how = "the FRF measured with noise drives on the plant"
    result = iterate_drive(plant, H, target, control, dt, settings,
                           progress=lambda m: _say(t0, m))  # fmt: skip
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    units = (model.input_units,) * len(model.inputs)
    write_time_data(out / "drive.rsp", TimeData(dt, result.drive, model.inputs, units))
    write_time_data(out / "response.rsp",
                    TimeData(dt, result.response, plant.outputs, plant.output_units))  # fmt: skip
    names = list(args.control)
    cunits = [model.output_units[c] for c in control]
    response = result.response[control]
    figures = [
        ("Error at each iteration", "rms_error.png", "RMS of target - response over the "
         "target's RMS, each control channel, after the first drive (0) and each correction."),
        ("Target and response", "target_response.png", "The control channels around the "
         "target's peak after the last step."),
        ("Target and response: PSDs", "target_response_psd.png", "Welch PSDs (4 s Hann "
         "segments) of target and response after the last step."),
    ]  # fmt: skip
    pictures.error_history(out / figures[0][1], result.rms_error, names)
    pictures.target_and_response(out / figures[1][1], dt, target, response, names, cunits)
    pictures.target_and_response_psd(out / figures[2][1], dt, target, response, names, cunits,
                                     band=settings.band)  # fmt: skip
    report = iteration_dict(result, plant, settings, target=str(args.target),
                            model=str(args.deck), plant_deck=str(args.plant or args.deck),
                            frf=how)  # fmt: skip
    write_iteration_json(out / "iteration.json", report)
    write_iteration_html(out / "report.html", report, figures)
    _say(t0, f"wrote {out}: drive.rsp, response.rsp, iteration.json, report.html, pictures")
    width = max(len(n) for n in names)
    print(f"{'control channel':<{width}}  RMS error (% of target) after each step")
    for k, name in enumerate(names):
        print(f"{name:<{width}}  " + " ".join(f"{100 * e:7.2f}" for e in result.rms_error[:, k]))
    return 0


def _channels(data: TimeData, names: list[str], where: Path, plant: RigPlant) -> np.ndarray:
    """The channels ``names`` of a file (n, samples), each converted to the unit of the rig's
    output of that name (a blank unit is taken to be the model's)."""
    rows = []
    for name in names:
        try:
            c = data.channel(name)
        except TimeDataError as e:
            raise TimeDataError(f"{where}: {e}") from None
        to = plant.output_units[plant.outputs.index(name)]
        rows.append(data.values[c] * unit_factor(data.units[c], to, f"{where}: channel "
                                                 f"{name!r}"))  # fmt: skip
    return np.vstack(rows)


def _correct(args: argparse.Namespace) -> int:
    t0 = time.perf_counter()
    settings = _iteration_settings(args)
    if (args.drive is None) != (args.response is None):
        raise UsageError("--drive and --response go together (the drive played and the "
                         "response measured); give neither for the first drive")
    output_file(args.out, "--out", "time")
    target_data = read_time_data(args.target)
    model = _plant(args.deck, args, args.damping, t0)
    control = [model.outputs.index(c) if c in model.outputs else -1 for c in args.control]
    if -1 in control:
        bad = args.control[control.index(-1)]
        raise UsageError(f"--control {bad}: not an output of the rig; expected one of "
                         f"{', '.join(model.outputs)}")  # fmt: skip
    target = _channels(target_data, args.control, args.target, model)
    dt, n = target_data.dt, target.shape[1]
    if args.frf is not None:
        H = _frf_files(args.frf, model, args.control, n, dt, settings.band)
    else:
        H = frf_on_lines(model, control, n, dt, settings.band)
    drive = response = None
    if args.drive is not None:
        played, measured = read_time_data(args.drive), read_time_data(args.response)
        for path, data in ((args.drive, played), (args.response, measured)):
            if abs(data.dt - dt) > 1e-9 * dt or data.n_samples != n:
                raise UsageError(f"{path}: {data.n_samples} samples every {data.dt:g} s; "
                                 f"expected the target's {n} every {dt:g} s")  # fmt: skip
        drive = drive_channels(played, model, args.drive)
        response = _channels(measured, args.control, args.response, model)
    nxt = correct_drive(H, target, settings.rcond, drive, response, settings.gain)
    units = (model.input_units,) * len(model.inputs)
    write_time_data(args.out, TimeData(dt, nxt, model.inputs, units))
    _say(t0, f"wrote {args.out}")
    if response is not None:
        size = np.sqrt(np.mean(target**2, axis=1))
        err = np.sqrt(np.mean((target - response) ** 2, axis=1)) / np.where(size > 0, size, 1)
        width = max(len(c) for c in args.control)
        print(f"{'control channel':<{width}}  RMS error of the response (% of target)")
        for c, e in zip(args.control, err, strict=True):
            print(f"{c:<{width}}  {100 * e:7.2f}")
    return 0


def _frf_files(paths: list[Path], model: RigPlant, control: list[str], n: int, dt: float,
               band: tuple[float, float]) -> np.ndarray:  # fmt: skip
    """The FRF from the drives to the control channels on the target's lines, each control
    channel from the first file that has it as an output (an FRF file holds outputs of one
    unit: accelerations in one, forces in another)."""
    files = [(path, read_frf(path)) for path in paths]
    rows = []
    for name in control:
        found = [(path, data) for path, data in files
                 if name in [c.label for c in data.outputs]]  # fmt: skip
        if not found:
            raise UsageError(f"--frf: no file has the output {name!r}")
        path, data = found[0]
        ins = [c.label for c in data.inputs]
        cols = []
        for label in model.inputs:
            match = [k for k, i in enumerate(ins) if i in (label, f"{label}:displacement")]
            if not match:
                raise UsageError(f"--frf {path}: no input for actuator {label!r}; its inputs "
                                 f"are {', '.join(ins)}")  # fmt: skip
            cols.append(match[0])
        o = [c.label for c in data.outputs].index(name)
        rows.append(frf_to_lines(data.frequency_hz, data.H[[o]][:, cols], n, dt, band)[0])
    return np.stack(rows)


def _pairs(items: list[str], option: str) -> dict[str, str]:
    out = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or not name or not value:
            raise UsageError(f"{option} {item!r}: expected NAME=VALUE")
        if name in out:
            raise UsageError(f"{option}: {name!r} given twice")
        out[name] = value
    return out


def _compare(args: argparse.Namespace) -> int:
    t0 = time.perf_counter()
    settings = _iteration_settings(args)
    decks = _pairs(args.model, "--model")
    values = _pairs(args.values, "--values")
    unknown = sorted(set(values) - set(decks))
    if unknown:
        raise UsageError(f"--values {unknown[0]}=...: no --model {unknown[0]}=DECK")
    if values and args.params is None:
        raise UsageError("--values needs --params (the parameters file of the calibration)")
    output_folder(args.out, "--out")
    target = read_time_data(args.target)
    reference = None
    if args.reference_drive is not None:
        ref = read_time_data(args.reference_drive)
        if abs(ref.dt - target.dt) > 1e-9 * target.dt:
            raise UsageError(f"--reference-drive {args.reference_drive}: step {ref.dt:g} s, "
                             f"the target's is {target.dt:g} s")  # fmt: skip
    models = []
    for name, deck in decks.items():
        given = None
        if name in values:
            given = calibrated_values(values[name])
        model = model_with_values(Path(deck), args.params, given)
        _say(t0, f"model {name}: {deck}" + (f" with the values of {values[name]}"
                                            if given else ""))  # fmt: skip
        plant = build_plant(model, read_points(args.actuators), read_points(args.sensors),
                            modes_to=args.modes_to, damping=args.damping)  # fmt: skip
        models.append((name, plant))
    if args.reference_drive is not None:
        reference = drive_channels(ref, models[0][1], args.reference_drive)
    runs = compare_models(models, target, args.control, settings, reference_drive=reference,
                          progress=lambda m: _say(t0, m))  # fmt: skip
    report = comparison_dict(runs, settings, target=str(args.target), control=args.control)
    figures = _compare_pictures(args.out, runs, target, args.control, reference, settings)
    for run in runs:
        folder = args.out / run.name
        folder.mkdir(parents=True, exist_ok=True)
        p = run.plant
        write_time_data(folder / "drive.rsp", TimeData(target.dt, run.iteration.drive,
                                                       p.inputs, (p.input_units,) * len(p.inputs)))
        write_time_data(folder / "response.rsp",
                        TimeData(target.dt, run.iteration.response, p.outputs, p.output_units))
    write_iteration_json(args.out / "compare.json", report)
    write_comparison_html(args.out / "compare.html", report, figures)
    _say(t0, f"wrote {args.out}: compare.json, compare.html, pictures, each model's drive and "
         "response")  # fmt: skip
    for line in comparison_lines(report):
        print(line)
    return 0


def _compare_pictures(folder: Path, runs, target: TimeData, control: list[str],
                      reference: np.ndarray | None,
                      settings: IterationSettings) -> list[tuple[str, str, str]]:  # fmt: skip
    figures = []
    others = list(runs[0].channel_error)
    if others:
        shown = others[: pictures.MAX_PANELS]
        series = {"measured": _channels(target, shown, Path("target"), runs[0].plant)}
        for run in runs:
            series[run.name] = run.iteration.response[[run.plant.outputs.index(c)
                                                       for c in shown]]  # fmt: skip
        units = [runs[0].plant.output_units[runs[0].plant.outputs.index(c)] for c in shown]
        pictures.overlay_psd(folder / "uncontrolled_psd.png", target.dt, shown, units, series,
                             band=settings.band,
                             title="Uncontrolled channels: measured and each model's")  # fmt: skip
        figures.append(("Uncontrolled channels", "uncontrolled_psd.png",
                        "PSDs of the channels nobody controlled: as measured on the physical "
                        "rig, and as each model predicts them with its own iterated drives."))
    p = runs[0].plant
    series = {} if reference is None else {"reference": reference}
    for run in runs:
        series[run.name] = run.iteration.drive
    pictures.overlay_psd(folder / "drives_psd.png", target.dt, list(p.inputs),
                         [p.input_units] * len(p.inputs), series, band=settings.band,
                         title="Drives: each model's" + (" and the reference"
                                                          if reference is not None else ""))
    figures.append(("Drives", "drives_psd.png", "PSDs of each model's iterated drives"
                    + (", and of the drives the physical rig used." if reference is not None
                       else ".")))  # fmt: skip
    return figures


def run(args: argparse.Namespace) -> int:
    actions = {"simulate": _simulate, "iterate": _iterate, "correct": _correct,
               "compare": _compare}  # fmt: skip
    return actions[args.action](args)
