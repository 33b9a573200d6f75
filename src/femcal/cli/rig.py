"""``femcal rig ACTION``: the virtual 7-post rig (femcal.rig).

- ``simulate DECK --actuators CSV --sensors CSV --drive DRIVE.rsp --out RESPONSE.rsp
  [--damping Z | --damping-from MODEL.npz] [--modes-to HZ] [--periodic]``: the frame on its
  actuators played with a drive file;
- ``iterate DECK --actuators CSV --sensors CSV --target TARGET.rsp --control CHANNEL...
  [--plant DECK] [inverse, weight and limit options] --out DIR``: drives that reproduce a
  target, as RPC Pro iterates them, checked against the actuators' limits;
- ``correct DECK ... --target TARGET.rsp --control CHANNEL... [--drive D --response R ...]
  --out NEXT``: one step of that iteration for a physical rig, by files;
- ``compare --model NAME=DECK ... --target TARGET.rsp --control CHANNEL... --out DIR``:
  models on the virtual rig against one target.

All time data are read and written by suffix (RPC III .rsp/.tim/.drv, CSV, NPZ).
"""

from __future__ import annotations

import argparse
import difflib
import re
import sys
import time
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import scipy.signal as ss

from ..atomic import folder_lock
from ..errors import DriveLimitError, FemcalWarning, TimeDataError
from ..io.identified import read_model
from ..io.rig import (
    IterationFacts,
    correction_dict,
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
from ..rig.inverse import describe_pattern
from ..rig.iterate import (
    IterationSettings,
    correct_drive,
    frf_on_lines,
    frf_to_lines,
    iterate_drive,
    measured_frf,
)
from ..rig.kinematics import redundant_drives
from ..rig.limits import (
    ActuatorLimits,
    LimitCheck,
    check_limits,
    read_limits,
    scale_into_limits,
)
from ..rig.plant import RigPlant, build_plant, damping_from_modes, rig_channel_names
from ..rig.quality import band_errors, band_rms, channel_stats, relative_damage
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


def _iteration_options(p: argparse.ArgumentParser, *, iterations: bool = True,
                       limits: bool = True) -> None:  # fmt: skip
    """The settings of the iteration (:class:`IterationSettings`), the channels' weights and
    the actuators' limits."""
    if iterations:
        p.add_argument("--iterations", type=int, default=_D.iterations, metavar="N",
                       help=f"corrections after the first drive (default {_D.iterations})")
    p.add_argument("--gain", type=float, default=_D.gain,
                   help=f"gain of each correction (default {_D.gain:g})")
    p.add_argument("--band", type=float, nargs=2, default=_D.band, metavar=("F1", "F2"),
                   help=f"drive band (default {_D.band[0]:g} {_D.band[1]:g} Hz)")
    p.add_argument("--noise-floor", type=float, metavar="FRACTION",
                   help="the target's noise as a fraction of each channel's RMS (default: "
                   "measured on the target above the drive band); drive directions the "
                   "control channels do not see above it are held, not amplified")  # fmt: skip
    p.add_argument("--effort", type=float, default=0.0, metavar="ALPHA",
                   help="drive-effort penalty, relative to the best-seen drive direction "
                   "(default 0)")  # fmt: skip
    p.add_argument("--roll-off", type=float, default=0.0, metavar="HZ",
                   help="roll the drive off below HZ as a fourth-order high-pass (default: "
                   "none)")  # fmt: skip
    p.add_argument("--no-frf-update", action="store_true",
                   help="keep the FRF as inverted (default: updated from each drive and "
                   "response, as RPC Pro updates its system model)")  # fmt: skip
    p.add_argument("--taper", type=float, metavar="S",
                   help="fade the target in and out over S seconds (default: one period of "
                   "the band's low edge, only when the target's ends do not join; 0: never)")
    p.add_argument("--warp", choices=("free", "minimal"), default="free",
                   help="the redundant actuators' combination (a 7-post rig's warp): driven "
                   "where the control channels see it and held where they do not (free, the "
                   "default), or held at its least everywhere (minimal)")  # fmt: skip
    p.add_argument("--weight", action="append", default=[], metavar="CHANNEL=W",
                   help="weight of a control channel (default 1; mixed control: e.g. LVDTs "
                   "at 0.5 beside accelerometers)")  # fmt: skip
    if not limits:
        return
    p.add_argument("--limits", type=Path, metavar="CSV",
                   help="actuator limits: label and any of stroke (+/-), velocity, "
                   "acceleration, in the model's length unit (default: those columns of "
                   "--actuators)")  # fmt: skip
    p.add_argument("--stroke", type=float, metavar="L",
                   help="stroke of every actuator (+/- from mid-stroke, model length unit)")
    p.add_argument("--max-velocity", type=float, metavar="V",
                   help="largest velocity of every actuator (length unit per s)")
    p.add_argument("--max-acceleration", type=float, metavar="A",
                   help="largest acceleration of every actuator (length unit per s^2)")
    p.add_argument("--on-limit", choices=("warn", "scale", "refuse"), default="refuse",
                   help="a drive beyond a limit: refuse to write it (default), scale it down "
                   "as a whole until it fits, or write it with a warning")  # fmt: skip


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
                         "a target, as RPC Pro iterates them: the FRF inverted line by line, "
                         "regularised by the target's noise floor (drive directions the "
                         "control channels do not see above it are held, and said), first "
                         "drive = inverse x target, then regularised corrections from each "
                         "response played on the plant, the FRF updated from each step. "
                         "Errors are judged in the drive band; the drive is checked against "
                         "the actuators' limits before it is written.")  # fmt: skip
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
    it.add_argument("--reference-drive", type=Path, metavar="DRIVE",
                    help="the drive that made the target, when known: compared with the one "
                    "found (in the band) and drawn beside it")  # fmt: skip
    it.add_argument("--sn-slope", type=float, default=5.0, metavar="M",
                    help="S-N slope of the relative damage, response over target, by "
                    "rainflow and Miner's sum (default 5)")  # fmt: skip
    it.add_argument("--out", type=Path, required=True, metavar="DIR", help="folder to write")

    cor = rsub.add_parser("correct", help="one iteration step for a physical rig",
                          description="The drive/response exchange of a physical rig: without "
                          "--drive, the first drive (the regularised inverse FRF x the "
                          "target); with --drive and --response pairs (each response the "
                          "control channels measured while its drive played, in the order "
                          "played), the FRF updated from every pair and the next drive after "
                          "the last. The drive is checked against the actuators' limits before "
                          "it is written.")  # fmt: skip
    _plant_options(cor)
    cor.add_argument("--target", type=Path, required=True, help=f"target file ({time_sfx})")
    cor.add_argument("--control", nargs="+", required=True, metavar="CHANNEL",
                     help="control channels (names in the target and response files)")
    cor.add_argument("--frf", type=Path, nargs="+", metavar="FILE",
                     help="invert these FRFs (femcal timedata frf of noise drives played on "
                     "the rig: inputs the actuators, LABEL or LABEL:displacement; outputs the "
                     "control channels, one unit a file) instead of the model's")  # fmt: skip
    cor.add_argument("--drive", type=Path, action="append", default=[],
                     help="a drive that was played (repeat for each step, in order)")
    cor.add_argument("--response", type=Path, action="append", default=[],
                     help="the response measured while that drive played (repeat likewise)")
    _iteration_options(cor, iterations=False)
    cor.add_argument("--sn-slope", type=float, default=5.0, metavar="M",
                     help="S-N slope of the relative damage of the last response (default 5)")
    cor.add_argument("--report", type=Path, metavar="DIR",
                     help="also write correction.json, report.html and pictures there: the "
                     "drives played and the next, the last response against the target, its "
                     "error spectra")  # fmt: skip
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
    _iteration_options(cmp, limits=False)
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
                try:
                    c = data.channel(name)
                except TimeDataError as e:
                    raise TimeDataError(f"{where}: {e}") from None
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


#: The option that sets each of :class:`IterationSettings`' fields.
_OPTIONS = {"iterations": "--iterations", "gain": "--gain", "band": "--band",
            "noise_floor": "--noise-floor", "effort": "--effort", "roll_off_hz": "--roll-off",
            "taper_s": "--taper", "warp": "--warp"}  # fmt: skip


def _iteration_settings(args: argparse.Namespace) -> IterationSettings:
    try:
        return IterationSettings(iterations=getattr(args, "iterations", 0), gain=args.gain,
                                 band=tuple(args.band), noise_floor=args.noise_floor,
                                 effort=args.effort, roll_off_hz=args.roll_off,
                                 update_frf=not args.no_frf_update,
                                 taper_s=args.taper, warp=args.warp)  # fmt: skip
    except ValueError as e:
        text = str(e).replace("drive iteration: ", "")
        for field, option in _OPTIONS.items():  # the option, not the setting's name
            if text.startswith(f"{field} = "):
                text = f"{option} {text[len(field) + 3:]}"
                break
        raise UsageError(text) from None


def _weights(args: argparse.Namespace) -> list[float]:
    """One weight per control channel from ``--weight CHANNEL=W`` (1 where none is given);
    a control channel given twice is refused (it would weigh double)."""
    twice = sorted({c for c in args.control if args.control.count(c) > 1})
    if twice:
        raise UsageError(f"--control {twice[0]} given twice; expected each control channel "
                         "once (--weight CHANNEL=W weighs one)")  # fmt: skip
    given = _pairs(args.weight, "--weight")
    for name in given:
        if name not in args.control:
            raise UsageError(f"--weight {name}=...: not a control channel; expected one of "
                             f"{', '.join(args.control)}")  # fmt: skip
    out = []
    for name in args.control:
        text = given.get(name, "1")
        try:
            w = float(text)
        except ValueError:
            w = float("nan")
        if not (np.isfinite(w) and 1e-6 <= w <= 1e6):
            raise UsageError(f"--weight {name}={text}: expected a number from 1e-6 to 1e6 "
                             "(a channel's weight beside the others' 1)")  # fmt: skip
        out.append(w)
    return out


def _limits(args: argparse.Namespace, plant: RigPlant) -> ActuatorLimits:
    """The actuators' limits: --limits (else the limit columns of --actuators), then the
    options that set one value for every actuator."""
    if args.limits is not None:
        limits = read_limits(args.limits, plant.inputs, required=True)
    else:
        limits = read_limits(args.actuators, plant.inputs)
    try:
        return limits.overridden(args.stroke, args.max_velocity, args.max_acceleration)
    except ValueError as e:
        raise UsageError(str(e)) from None


def _enforce(drive: np.ndarray, dt: float, plant: RigPlant, args: argparse.Namespace,
             target: Path) -> tuple[np.ndarray, LimitCheck, float]:  # fmt: skip
    """The drive to write, its check against the limits and the factor it was scaled by,
    as --on-limit says; a warning for a drive written beyond them, or scaled."""
    check = check_limits(drive, dt, _limits(args, plant))
    scale = 1.0
    if check.exceeded:
        lines = "; ".join(check.messages(plant.inputs, plant.input_units))
        if args.on_limit == "scale":
            drive, scale = scale_into_limits(drive, check)
            warnings.warn(f"the drive for {target} exceeded the actuators' limits ({lines}); "
                          f"scaled down by {scale:.4g} as a whole (--on-limit scale): it "
                          "reproduces the target that much smaller", FemcalWarning,
                          stacklevel=2)  # fmt: skip
        elif args.on_limit == "warn":
            warnings.warn(f"the drive written exceeds the actuators' limits: {lines} "
                          "(--on-limit warn)", FemcalWarning, stacklevel=2)  # fmt: skip
    return drive, check, scale


def _refuse(check: LimitCheck, plant: RigPlant, drive_path: Path, report: str) -> None:
    """The error of a drive refused for its limits (a stale drive file of that name is
    removed first, so that no drive beyond them is left where one is expected)."""
    removed = ""
    if drive_path.is_file():
        drive_path.unlink()
        removed = f" (the earlier {drive_path.name} there was removed)"
    raise DriveLimitError(f"the drive exceeds the actuators' limits: "
                          f"{'; '.join(check.messages(plant.inputs, plant.input_units))}; not "
                          f"written to {drive_path}{removed}. {report}--on-limit scale scales "
                          "it down as a whole, --on-limit warn writes it anyway; --roll-off or "
                          "--effort make the drive smaller where the control channels barely "
                          "see it")  # fmt: skip


def _iterate(args: argparse.Namespace) -> int:
    t0 = time.perf_counter()
    settings = _iteration_settings(args)
    output_folder(args.out, "--out")
    target_data = read_time_data(args.target)
    weights = _weights(args)
    _check_slope(args)
    _check_band(settings, target_data)  # before the modes are solved
    _check_control(args)
    model = _plant(args.deck, args, args.damping, t0)
    plant = model
    if args.plant is not None or args.plant_damping is not None:
        deck = args.plant if args.plant is not None else args.deck
        damping = args.plant_damping if args.plant_damping is not None else args.damping
        plant = _plant(deck, args, damping, t0)  # the same files: the same channels
    control = [model.outputs.index(c) for c in args.control]  # checked by _check_control
    limits = _limits(args, model)
    target = _channels(target_data, args.control, args.target, model)
    dt, n = target_data.dt, target.shape[1]
    reference = None
    if args.reference_drive is not None:
        ref = read_time_data(args.reference_drive)
        if abs(ref.dt - dt) > 1e-9 * dt or ref.n_samples < n:
            raise UsageError(f"--reference-drive {args.reference_drive}: {ref.n_samples} "
                             f"samples every {ref.dt:g} s; expected at least the target's {n} "
                             f"every {dt:g} s")  # fmt: skip
        reference = drive_channels(ref, model, args.reference_drive)[:, :n]
    if args.frf == "model":
        H = frf_on_lines(model, control, n, dt, settings.band)
        how = "the model's FRF"
    else:
        _say(t0, "measuring the FRF: noise drives on the plant")
        H = measured_frf(plant, control, n, dt, settings.band)
        how = "the FRF measured with noise drives on the plant"
    result = iterate_drive(plant, H, target, control, dt, settings, weights=weights,
                           progress=lambda m: _say(t0, m))  # fmt: skip
    out = args.out
    drive, check, scale = _enforce(result.drive, dt, model, args, args.target)
    written = not (check.exceeded and args.on_limit == "refuse")
    if scale != 1.0:  # the report is of the drive written: its last step is the scaled one
        result = _scaled(result, scale, dt, settings)
        check = check_limits(drive, dt, limits)
    response = result.response
    names = list(args.control)
    cunits = [model.output_units[c] for c in control]
    controlled = response[control]
    stats = channel_stats(result.target, controlled)
    damage = relative_damage(result.target, controlled, args.sn_slope)
    ref_error = ref_rms = None
    if reference is not None:
        ref_rms = np.sqrt(np.mean(reference**2, axis=1))
        size = band_rms(reference, dt, settings.band)
        ref_error = band_rms(drive - reference, dt, settings.band) / np.where(size > 0, size, 1)
    facts = IterationFacts(check, args.on_limit, scale, written, stats, damage, args.sn_slope,
                           ref_error, ref_rms)  # fmt: skip
    report = iteration_dict(result, plant, settings, target=str(args.target),
                            model=str(args.deck), plant_deck=str(args.plant or args.deck),
                            frf=how, facts=facts)  # fmt: skip
    with folder_lock(out):  # another run into this folder waits: one run's set, never a mix
        figures = _iteration_pictures(out, result, model, names, cunits, controlled, drive,
                                      dt, settings, check, reference)  # fmt: skip
        write_iteration_json(out / "iteration.json", report)
        write_iteration_html(out / "report.html", report, figures)
        write_time_data(out / "response.rsp",
                        TimeData(dt, response, plant.outputs, plant.output_units))  # fmt: skip
        if not written:
            _refuse(check, model, out / "drive.rsp", f"The report is in {out}. ")
        units = (model.input_units,) * len(model.inputs)
        write_time_data(out / "drive.rsp", TimeData(dt, drive, model.inputs, units))
    _say(t0, f"wrote {out}: drive.rsp, response.rsp, iteration.json, report.html, pictures")
    _print_iteration(result, names, model, check, damage, ref_error, settings.warp)
    return 0


def _scaled(result, scale: float, dt: float, settings: IterationSettings):
    """The iteration with its last step replaced by the drive scaled by ``scale`` (and the
    response, the plant being linear), its errors and state recomputed."""
    drive, response = result.drive * scale, result.response * scale
    err = band_errors(result.target, response[list(result.control)], dt, settings.band)

    def last(rows: np.ndarray, row: np.ndarray) -> np.ndarray:
        out = rows.copy()
        out[-1] = row
        return out

    status = tuple(f"scaled by {scale:.3g} as a whole to fit the limits (--on-limit scale): "
                   f"{100 * e:.3g} % in band" for e in err.in_band)  # fmt: skip
    return replace(result, drive=drive, response=response,
                   rms_error=last(result.rms_error, err.in_band),
                   out_of_band=last(result.out_of_band, err.out_of_band),
                   drives=last(result.drives, np.sqrt(np.mean(drive**2, axis=1))),
                   drive_psd=last(result.drive_psd, result.drive_psd[-1] * scale**2),
                   status=status)  # fmt: skip


def _iteration_pictures(out: Path, result, model: RigPlant, names: list[str],
                        cunits: list[str], controlled: np.ndarray, drive: np.ndarray,
                        dt: float, settings: IterationSettings, check: LimitCheck,
                        reference: np.ndarray | None) -> list[tuple[str, str, str]]:  # fmt: skip
    """The iteration's pictures, drawn into ``out``: (title, file, caption) each."""
    unit = model.input_units
    figures = [
        ("Error at each iteration", "rms_error.png", "RMS of target - response in the drive "
         "band over the target's RMS there, each control channel, after the first drive (0) "
         "and each correction."),
        ("Drives at each iteration", "drives_psd.png", "PSDs (Welch, 4 s Hann segments) of "
         "each actuator's drive, light for the first drive to dark for the last"
         + (", and the reference drive dashed." if reference is not None else ".")),
        ("Drives over time", "drives_time.png", "The first and the last drive of each "
         "actuator over the whole record, with its stroke dashed in red where one is given"
         + (" and the reference drive in grey." if reference is not None else ".")),
        ("Target and response", "target_response.png", "The control channels around the "
         "target's peak after the last step."),
        ("Target and response: PSDs", "target_response_psd.png", "Welch PSDs (4 s Hann "
         "segments) of target and response after the last step."),
        ("Error spectra", "error_psd.png", "PSD of target - response after the last step "
         "against the target's, the drive band shaded and the target's noise floor dotted."),
    ]  # fmt: skip
    pictures.error_history(out / figures[0][1], result.rms_error, names)
    ref_psd = None
    if reference is not None:
        ref_psd = np.vstack([np.interp(result.psd_hz, *_welch(r, dt)) for r in reference])
    pictures.drive_psd_history(out / figures[1][1], result.psd_hz, result.drive_psd,
                               list(model.inputs), unit, reference=ref_psd,
                               band=settings.band)  # fmt: skip
    pictures.drive_histories(out / figures[2][1], dt, drive, list(model.inputs), unit,
                             stroke=check.limit[0], reference=reference,
                             first=result.first_drive)  # fmt: skip
    pictures.target_and_response(out / figures[3][1], dt, result.target, controlled, names,
                                 cunits)  # fmt: skip
    pictures.target_and_response_psd(out / figures[4][1], dt, result.target, controlled,
                                     names, cunits, band=settings.band)  # fmt: skip
    pictures.error_spectra(out / figures[5][1], dt, result.target, controlled, names, cunits,
                           noise_fraction=None if result.noise is None
                           else result.noise.fraction, band=settings.band)  # fmt: skip
    return figures


def _welch(x: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """(frequencies, PSD) of one signal, as the iteration's drive PSDs are made."""
    m = min(len(x), max(8, round(4.0 / dt)))
    return ss.welch(x, fs=1.0 / dt, nperseg=m)


def _print_redundant(redundant: np.ndarray, unseen, model: RigPlant, warp: str) -> None:
    """Each redundant drive combination (the warp), where it is not seen, what was done."""
    for k in range(redundant.shape[1]):
        name = "the warp" if redundant.shape[1] == 1 else f"redundant combination {k + 1}"
        what = describe_pattern(redundant[:, k] / np.abs(redundant[:, k]).max(), model.inputs)
        if warp == "minimal":
            done = "held at its least everywhere (--warp minimal)"
        elif unseen[k]:
            bands = ", ".join(f"{a:.3g}-{b:.3g} Hz" for a, b in unseen[k])
            done = (f"not seen above the noise at {bands}: held at its least there; LVDTs or "
                    "load cells in the control set would see it")  # fmt: skip
        else:
            done = "seen by the control channels throughout the band"
        print(f"{name} ({what}): {done}")


def _print_iteration(result, names: list[str], model: RigPlant, check: LimitCheck,
                     damage: np.ndarray, ref_error: np.ndarray | None,
                     warp: str = "free") -> None:  # fmt: skip
    """The iteration on the console: the noise floor and taper, each control channel's
    in-band error after each step, its error outside the band, damage and state; the
    directions not seen; the drives against their limits."""
    if result.noise is not None:
        print(f"target noise floor: {result.noise.source}: "
              + ", ".join(f"{100 * v:.2g} %" for v in result.noise.fraction))
    if result.taper_s:
        print(f"the target's ends do not join: faded in and out over {result.taper_s:g} s "
              "(--taper 0 takes it as one period)")  # fmt: skip
    width = max(len(n) for n in names)
    print(f"{'control channel':<{width}}  in-band RMS error (% of target) after each step; "
          "outside the band; relative damage")  # fmt: skip
    def pct(x: float, width: int) -> str:
        return f"{100 * x:{width}.2f}" if np.isfinite(x) else f"{'-':>{width}}"

    for k, name in enumerate(names):
        print(f"{name:<{width}}  " + " ".join(pct(e, 7) for e in result.rms_error[:, k])
              + f" | {pct(result.out_of_band[-1, k], 6)} | "
              + (f"{damage[k]:6.3g}" if np.isfinite(damage[k]) else f"{'-':>6}"))
    for k, name in enumerate(names):
        print(f"  {name}: {result.status[k]}")
    n_drives = len(model.inputs)
    for u in result.unseen:
        what = ("all directions" if u.directions >= n_drives else
                f"{u.directions} direction(s), the weakest "
                f"{describe_pattern(u.pattern, model.inputs)}")  # fmt: skip
        print(f"not seen above the noise at {u.low_hz:.3g}-{u.high_hz:.3g} Hz: {what}; held")
    _print_redundant(result.redundant, result.redundant_unseen, model, warp)
    aw = max(len(a) for a in model.inputs)
    unit = model.input_units
    print(f"{'actuator':<{aw}}  {'RMS':>9} {'peak':>9} {'stroke':>9}"
          + (f" {'vs reference in band %':>23}" if ref_error is not None else ""))
    for j, a in enumerate(model.inputs):
        stroke = check.limit[0, j]
        limit = f"{stroke:9.4g}" if np.isfinite(stroke) else f"{'-':>9}"
        print(f"{a:<{aw}}  {result.drives[-1, j]:9.4g} {check.peak[0, j]:9.4g} {limit}"
              + (f" {100 * ref_error[j]:23.1f}" if ref_error is not None else "")
              + f"  ({unit})")


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
    if len(args.drive) != len(args.response):
        raise UsageError(f"{len(args.drive)} --drive and {len(args.response)} --response: they "
                         "go in pairs (each drive played and the response measured while it "
                         "played); give neither for the first drive")  # fmt: skip
    output_file(args.out, "--out", "time")
    for option, paths in (("--target", [args.target]), ("--drive", args.drive),
                          ("--response", args.response)):  # fmt: skip
        for path in paths:
            if args.out.exists() and path.exists() and args.out.samefile(path):
                raise UsageError(f"--out {args.out} is also {option} {path}: expected a new "
                                 "file for the next drive (what was played and measured is "
                                 "needed for the steps after it)")  # fmt: skip
    target_data = read_time_data(args.target)
    weights = _weights(args)  # the checks that need no model before its modes are solved
    _check_slope(args)
    if args.report is not None:
        output_folder(args.report, "--report")
    _check_band(settings, target_data)
    _check_control(args)
    model = _plant(args.deck, args, args.damping, t0)
    control = [model.outputs.index(c) for c in args.control]  # checked by _check_control
    _limits(args, model)
    target = _channels(target_data, args.control, args.target, model)
    dt, n = target_data.dt, target.shape[1]
    if args.frf is not None:
        H = _frf_files(args.frf, model, args.control, n, dt, settings.band)
    else:
        H = frf_on_lines(model, control, n, dt, settings.band)
    drives, responses = [], []
    for drive_path, response_path in zip(args.drive, args.response, strict=True):
        played, measured = read_time_data(drive_path), read_time_data(response_path)
        for path, data in ((drive_path, played), (response_path, measured)):
            if abs(data.dt - dt) > 1e-9 * dt or data.n_samples != n:
                raise UsageError(f"{path}: {data.n_samples} samples every {data.dt:g} s; "
                                 f"expected the target's {n} every {dt:g} s")  # fmt: skip
        drives.append(drive_channels(played, model, drive_path))
        responses.append(_channels(measured, args.control, response_path, model))
    step = correct_drive(H, target, dt, settings, drives=drives, responses=responses,
                         weights=weights, redundant=redundant_drives(model))  # fmt: skip
    drive, check, scale = _enforce(step.drive, dt, model, args, args.target)
    refused = check.exceeded and args.on_limit == "refuse"
    if args.report is not None:
        _correction_report(args, step, model, settings, drives, responses, drive, check,
                           scale, not refused, dt, "the FRF files given" if args.frf
                           else "the model's FRF")  # fmt: skip
    if refused:
        _refuse(check, model, args.out, "" if args.report is None
                else f"The report is in {args.report}. ")  # fmt: skip
    units = (model.input_units,) * len(model.inputs)
    write_time_data(args.out, TimeData(dt, drive, model.inputs, units))
    _say(t0, f"wrote {args.out}")
    p = step.prepared
    print(f"target noise floor: {p.noise.source}: "
          + ", ".join(f"{100 * v:.2g} %" for v in p.noise.fraction))
    if p.taper_s:
        print(f"the target's ends do not join: faded in and out over {p.taper_s:g} s (the "
              "drive starts and ends at rest; --taper 0 takes it as one period)")  # fmt: skip
    if step.frf_updates:
        print("FRF lines updated from each drive and response pair: "
              + ", ".join(str(k) for k in step.frf_updates))
    for u in step.unseen:
        what = ("all directions" if u.directions >= len(model.inputs) else
                f"{u.directions} direction(s), the weakest "
                f"{describe_pattern(u.pattern, model.inputs)}")  # fmt: skip
        print(f"not seen above the noise at {u.low_hz:.3g}-{u.high_hz:.3g} Hz: {what}; held")
    _print_redundant(p.redundant, step.redundant_unseen, model, settings.warp)
    if step.error is not None:
        width = max(len(c) for c in args.control)
        print(f"{'control channel':<{width}}  RMS error of the last response (% of target): in "
              "the band, outside it")  # fmt: skip
        for k, c in enumerate(args.control):
            e, o = step.error.in_band[k], step.error.out_of_band[k]
            print(f"{c:<{width}}  " + " ".join(f"{100 * x:7.2f}" if np.isfinite(x)
                                               else f"{'-':>7}" for x in (e, o)))  # fmt: skip
    aw = max(len(a) for a in model.inputs)
    for j, a in enumerate(model.inputs):
        stroke = check.limit[0, j]
        limit = f" of stroke {stroke:.4g}" if np.isfinite(stroke) else ""
        print(f"{a:<{aw}}  RMS {np.sqrt(np.mean(drive[j] ** 2)):.4g}, peak "
              f"{check.peak[0, j]:.4g}{limit} {model.input_units}")  # fmt: skip
    return 0


def _check_control(args: argparse.Namespace) -> None:
    """Each --control channel among the rig's outputs, named from the actuators and sensors
    files before any solve (:func:`rig_channel_names`, the plant's own naming); a wrong one
    with the nearest names."""
    names = rig_channel_names(read_points(args.actuators), read_points(args.sensors))
    for name in args.control:
        if name not in names:
            near = difflib.get_close_matches(name, names, n=3, cutoff=0.5)
            hint = f"did you mean {' or '.join(near)}? " if near else ""
            raise UsageError(f"--control {name}: not an output of the rig; {hint}(its outputs: "
                             f"{', '.join(names)})")  # fmt: skip


def _check_band(settings: IterationSettings, target: TimeData) -> None:
    if settings.band[1] >= 0.5 / target.dt:
        raise UsageError(f"--band {settings.band[0]:g} {settings.band[1]:g}: above the "
                         f"target's Nyquist frequency {0.5 / target.dt:g} Hz")  # fmt: skip


def _check_slope(args: argparse.Namespace) -> None:
    if not (np.isfinite(args.sn_slope) and args.sn_slope > 0):
        raise UsageError(f"--sn-slope {args.sn_slope:g}: expected a positive S-N slope (3 for "
                         "welded steel joints; 5 is common for components)")  # fmt: skip


def _correction_report(args: argparse.Namespace, step, model: RigPlant,
                       settings: IterationSettings, drives: list[np.ndarray],
                       responses: list[np.ndarray], drive: np.ndarray, check: LimitCheck,
                       scale: float, written: bool, dt: float, frf: str) -> None:  # fmt: skip
    """``rig correct --report``: correction.json, report.html and pictures of the drives
    played and the next one, and of the last response against the target."""
    out = args.report
    out.mkdir(parents=True, exist_ok=True)
    p = step.prepared
    names = list(args.control)
    cunits = [model.output_units[model.outputs.index(c)] for c in names]
    last = responses[-1] if responses else np.zeros_like(p.target)
    stats = channel_stats(p.target, last)
    damage = (relative_damage(p.target, last, args.sn_slope) if responses
              else np.full(len(names), np.nan))  # fmt: skip
    facts = IterationFacts(check, args.on_limit, scale, written, stats, damage, args.sn_slope)
    played = [*drives, drive]
    psd_hz = _welch(played[0][0], dt)[0]
    psd = np.stack([np.vstack([_welch(d[j], dt)[1] for j in range(d.shape[0])])
                    for d in played])  # fmt: skip
    unit = model.input_units
    figures = [("Drives played and the next", "drives_psd.png", "PSDs (Welch, 4 s Hann "
                "segments) of each drive played, light to dark, the next one darkest."),
               ("The next drive over time", "drives_time.png", "The next drive of each "
                "actuator, the last one played beside it, and its stroke dashed in red where "
                "one is given.")]  # fmt: skip
    pictures.drive_psd_history(out / figures[0][1], psd_hz, psd, list(model.inputs), unit,
                               band=settings.band)  # fmt: skip
    pictures.drive_histories(out / figures[1][1], dt, drive, list(model.inputs), unit,
                             stroke=check.limit[0], first=drives[-1] if drives else None,
                             first_label="last drive played")  # fmt: skip
    if responses:
        figures += [
            ("Target and the last response", "target_response.png", "The control channels "
             "around the target's peak."),
            ("Target and the last response: PSDs", "target_response_psd.png", "Welch PSDs "
             "(4 s Hann segments)."),
            ("Error spectra", "error_psd.png", "PSD of target - last response against the "
             "target's, the drive band shaded and the target's noise floor dotted."),
        ]  # fmt: skip
        pictures.target_and_response(out / figures[2][1], dt, p.target, last, names, cunits)
        pictures.target_and_response_psd(out / figures[3][1], dt, p.target, last, names,
                                         cunits, band=settings.band)  # fmt: skip
        pictures.error_spectra(out / figures[4][1], dt, p.target, last, names, cunits,
                               noise_fraction=p.noise.fraction, band=settings.band)
    report = correction_dict(step, model, settings, names, drives, responses, dt, facts,
                             target=str(args.target), model=str(args.deck), frf=frf)
    write_iteration_json(out / "correction.json", report)
    write_iteration_html(out / "report.html", report, figures)


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
        out_unit, _, in_unit = data.units.rpartition("/") if "/" in data.units else ("", "", "")
        to = model.output_units[model.outputs.index(name)]
        try:  # a blank unit is the model's
            scale = (unit_factor(out_unit, to, f"--frf {path}: output {name!r}")
                     / unit_factor(in_unit, model.input_units, f"--frf {path}: inputs"))
        except ValueError as e:
            raise UsageError(f"{e} (the FRF's units are {data.units!r})") from None
        try:
            lines = frf_to_lines(data.frequency_hz, data.H[[o]][:, cols], n, dt, band)[0]
        except TimeDataError as e:
            raise UsageError(f"--frf {path}: {e}") from None
        rows.append(scale * lines)
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
    for name in decks:
        if not re.fullmatch(r"[A-Za-z0-9_][A-Za-z0-9_.-]*", name) or name in (".", ".."):
            raise UsageError(f"--model {name}=...: expected a plain name (letters, digits, _, "
                             "- and ., not starting with a dot): it names the model's folder "
                             "under --out")  # fmt: skip
    values = _pairs(args.values, "--values")
    unknown = sorted(set(values) - set(decks))
    if unknown:
        raise UsageError(f"--values {unknown[0]}=...: no --model {unknown[0]}=DECK")
    if values and args.params is None:
        raise UsageError("--values needs --params (the parameters file of the calibration)")
    output_folder(args.out, "--out")
    target = read_time_data(args.target)
    weights = _weights(args)
    _check_control(args)
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
                          weights=weights,
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
