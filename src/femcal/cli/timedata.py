"""``femcal timedata ACTION``: time histories of a rig test (MTS RPC III .rsp, .tim, .drv; CSV
with a time column; NPZ: the formats registered for time histories, read by
:func:`femcal.testdata.formats.read_time_data`).

- ``info FILE [--json OUT]``: step, length and every channel's name, unit and range;
- ``frf FILE --inputs NAME... --outputs NAME... [--period S] [--segment S] [--band F1 F2]
  [--estimator H1|H2|Hv] [--points CSV...] --out FILE.npz|.uff|.mat|.csv [--pictures DIR]``:
  FRFs as the study processed its rig test (:mod:`femcal.testdata.estimate`);
- ``plot FILE --out DIR [--channels NAME...] [--seconds S] [--inputs ... --outputs ...]``:
  time histories and PSDs, and with inputs and outputs the drives' singular values, the
  coherences and the FRFs.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from ..atomic import write_lines
from ..model.build import load_model
from ..rig.plant import column_stiffness
from ..testdata.data import FRFData
from ..testdata.estimate import FRFSettings, RigFRF, channel_labels, estimate_frfs
from ..testdata.formats import formats, read_time_data, suffixes, write_frf
from ..testdata.points import read_points
from ..testdata.signal import ESTIMATORS, cross_spectra, input_condition_number
from ..testdata.timedata import TimeData
from ..viz import timedata as pictures
from .paths import UsageError, output_file, output_folder


def add_parser(sub: argparse._SubParsersAction) -> None:
    kinds = "; ".join(f"{f.description} ({', '.join(f.suffixes)})" for f in formats("time"))
    p = sub.add_parser("timedata", help="time histories (RPC III, CSV, NPZ): summaries",
                       description=f"Time-history files of a rig test: {kinds}.")  # fmt: skip
    tsub = p.add_subparsers(dest="action", required=True, metavar="ACTION")
    info = tsub.add_parser("info", help="step, length and each channel's name, unit and range")
    info.add_argument("file", type=Path,
                      help=f"time-history file ({', '.join(suffixes('time'))})")  # fmt: skip
    info.add_argument("--json", type=Path, metavar="OUT", help="also write the summary as JSON")

    frf = tsub.add_parser("frf", help="FRFs from time histories (H1, H2, Hv), as the study did",
                          description="Estimate FRFs of output channels on input channels: "
                          "cycle averaging (--period), detrending, a zero-phase FIR band-pass "
                          "(--band, --order), Welch spectra (--segment, --overlap) and the "
                          "estimator; the band is written as FRF data with the multiple "
                          "coherence of each output.")  # fmt: skip
    frf.add_argument("file", type=Path, help=f"time-history file ({', '.join(suffixes('time'))})")
    _channel_options(frf, required=True)
    _estimate_options(frf)
    frf.add_argument("--estimator", default="H1", metavar="|".join(ESTIMATORS),
                     help="H1 (noise on the outputs; default), H2 (noise on the inputs: one "
                     "input, or as many outputs as inputs) or Hv (total least squares), in "
                     "any case")  # fmt: skip
    frf.add_argument("--points", type=Path, nargs="+", default=[], metavar="CSV",
                     help="sensors and actuators files: label the FRFs GRID:AXIS (LABEL:+Z -> "
                     "the sensor's grid; LABEL:displacement|force -> the actuator's grid and "
                     "stroke) so that identify and calibrate place them")  # fmt: skip
    frf.add_argument("--per-force", type=Path, metavar="DECK",
                     help="inputs that are actuator displacements (LABEL:displacement, the "
                     "actuators file among --points): divide each by its oil column's "
                     "stiffness in DECK, giving FRFs per newton at the actuator's frame grid, "
                     "as femcal frf and the calibration compute them for the deck")  # fmt: skip
    frf.add_argument("--no-detrend", action="store_true", help="keep each channel's trend")
    frf.add_argument("--out", type=Path, required=True, metavar="FILE",
                     help=f"FRF file ({', '.join(suffixes('frf', writable=True))})")
    frf.add_argument("--pictures", type=Path, metavar="DIR",
                     help="also draw the input PSDs, their singular values, the coherences "
                     "and the FRFs into DIR")  # fmt: skip

    plot = tsub.add_parser("plot", help="pictures: time histories, PSDs, coherence, FRFs")
    plot.add_argument("file", type=Path, help=f"time-history file ({', '.join(suffixes('time'))})")
    plot.add_argument("--channels", nargs="+", metavar="NAME",
                      help="channels to draw (default: the first 12)")
    plot.add_argument("--seconds", type=float, metavar="S",
                      help="time histories over the first S seconds (default: a record up "
                      "to 5 s whole, a longer one over 5 s around its largest peak)")
    _channel_options(plot, required=False)
    _estimate_options(plot)
    plot.add_argument("--out", type=Path, required=True, metavar="DIR", help="folder to write")


def _channel_options(p: argparse.ArgumentParser, *, required: bool) -> None:
    p.add_argument("--inputs", nargs="+", required=required, metavar="NAME",
                   help="input channels by name (the drives or forces)")
    p.add_argument("--outputs", nargs="+", required=required, metavar="NAME",
                   help="output channels by name (the responses)")


def _estimate_options(p: argparse.ArgumentParser) -> None:
    d = FRFSettings()
    p.add_argument("--period", type=float, metavar="S",
                   help="the drive's period: average the record's whole cycles first")
    p.add_argument("--segment", type=float, default=d.segment_s, metavar="S",
                   help=f"Welch segment length (default {d.segment_s:g} s: "
                   f"{1 / d.segment_s:g} Hz resolution)")  # fmt: skip
    p.add_argument("--overlap", type=float, default=d.overlap,
                   help=f"segment overlap, a fraction in [0, 1) (default {d.overlap:g})")
    p.add_argument("--band", type=float, nargs=2, metavar=("F1", "F2"),
                   help="band-pass every channel to F1-F2 Hz (zero-phase FIR) and keep that "
                   "band (the study: 0.5 30)")  # fmt: skip
    p.add_argument("--order", type=int, default=d.order,
                   help=f"order of the band-pass FIR (default {d.order})")
    p.add_argument("--rate", type=float, metavar="HZ",
                   help="resample the channels to HZ first (anti-alias filtered)")


def _settings(args: argparse.Namespace) -> FRFSettings:
    return FRFSettings(period_s=args.period, segment_s=args.segment, overlap=args.overlap,
                       band=tuple(args.band) if args.band else None, order=args.order,
                       estimator=getattr(args, "estimator", "H1"),
                       detrend=not getattr(args, "no_detrend", False),
                       rate_hz=args.rate)  # fmt: skip


def summary(data: TimeData) -> dict:
    """``{"dt", "n_samples", "channels": [{"name", "unit", "max", "min", "mean", "rms"}]}``."""
    v = data.values
    return {
        "dt": data.dt,
        "n_samples": data.n_samples,
        "channels": [
            {"name": data.names[c], "unit": data.units[c], "max": float(v[c].max()),
             "min": float(v[c].min()), "mean": float(v[c].mean()),
             "rms": float(np.sqrt(np.mean(v[c] ** 2)))}
            for c in range(data.n_channels)
        ],
    }  # fmt: skip


def run(args: argparse.Namespace) -> int:
    return {"info": _info, "frf": _frf, "plot": _plot}[args.action](args)


def _info(args: argparse.Namespace) -> int:
    data = read_time_data(args.file)
    s = summary(data)
    print(f"{args.file}: {data.n_channels} channels x {data.n_samples} samples, dt = "
          f"{data.dt:g} s ({1 / data.dt:g} Hz), {data.n_samples * data.dt:g} s")
    width = max([4, *(len(n) for n in data.names)])
    unit = max([4, *(len(u) for u in data.units)])
    print(f"{'#':>3} {'name':<{width}} {'unit':<{unit}} {'min':>12} {'max':>12} {'mean':>12} "
          f"{'rms':>12}")  # fmt: skip
    for k, c in enumerate(s["channels"], 1):
        print(f"{k:>3} {c['name']:<{width}} {c['unit']:<{unit}} {c['min']:12.5g} "
              f"{c['max']:12.5g} {c['mean']:12.5g} {c['rms']:12.5g}")
    if args.json:
        write_lines(args.json, [json.dumps(s, indent=1)])
    return 0


def _frf(args: argparse.Namespace) -> int:
    t0 = time.perf_counter()
    settings = _settings(args)
    output_file(args.out, "--out", "frf")
    if args.pictures is not None:
        output_folder(args.pictures, "--pictures")
    channel_labels([*args.inputs, *args.outputs], args.points)  # the position files first
    data = read_time_data(args.file)
    _say(t0, f"read {args.file}: {data.n_channels} channels x {data.n_samples} samples at "
         f"{1 / data.dt:g} Hz")  # fmt: skip
    result = estimate_frfs(data, args.inputs, args.outputs, settings, points=args.points)
    frf = result.frf
    if args.per_force is not None:
        frf = _per_force(frf, args.per_force, args.inputs, args.points, t0)
    write_frf(args.out, frf)
    _say(t0, f"wrote {args.out}")
    if args.pictures is not None:
        for path in _draw(args.pictures, result, args.inputs, args.outputs, settings):
            _say(t0, f"wrote {path}")
    f = frf.frequency_hz
    cond = input_condition_number(result.spectra)
    in_band = (result.spectra.frequency_hz >= f[0]) & (result.spectra.frequency_hz <= f[-1])
    averaged = f"{result.cycles} cycles averaged, " if settings.period_s else ""
    print(f"{frf.H.shape[0]} outputs x {frf.H.shape[1]} inputs x {len(f)} lines "
          f"({f[0]:g}-{f[-1]:g} Hz, {f[1] - f[0] if len(f) > 1 else 0:g} Hz apart), "
          f"{result.estimate.estimator}, {averaged}{result.spectra.segments} segments; "
          f"{frf.quantity} in {frf.units}")  # fmt: skip
    print(f"input condition number in the band: median {np.median(cond[in_band]):.3g}, "
          f"worst {np.max(cond[in_band]):.3g} (1: independent drives of equal power)")
    width = max([6, *(len(n) for n in args.outputs)])
    print(f"{'output':<{width}} {'label':<14} {'multiple coherence: median':>27} {'min':>6}")
    for o, name in enumerate(args.outputs):
        c = frf.coherence[o]
        print(f"{name:<{width}} {frf.outputs[o].label:<14} {np.median(c):27.3f} {c.min():6.3f}")
    return 0


def _per_force(frf: FRFData, deck: Path, inputs: list[str], points: list[Path],
               t0: float) -> FRFData:  # fmt: skip
    """The FRFs per newton at each actuator's frame grid: each input column over its oil
    column's stiffness in ``deck``."""
    rows = {}
    for path in points:
        for label, grid, code in read_points(path):
            rows.setdefault(label, (label, grid, code))
    acts = []
    for name in inputs:
        label, _, what = name.rpartition(":")
        if what != "displacement" or label not in rows:
            raise UsageError(f"--per-force: input {name!r} is not an actuator's displacement "
                             "(LABEL:displacement with LABEL in an actuators file of --points)")
        acts.append(rows[label])
    _say(t0, f"reading {deck} for the oil columns' stiffness")
    k = column_stiffness(load_model(deck), acts)
    out_unit = frf.units.rsplit("/", 1)[0]
    return FRFData(frf.frequency_hz, frf.H / k[None, :, None], frf.outputs, frf.inputs,
                   frf.quantity, f"{out_unit}/N", frf.coherence)  # fmt: skip


def _plot(args: argparse.Namespace) -> int:
    t0 = time.perf_counter()
    if (args.inputs is None) != (args.outputs is None):
        raise UsageError("--inputs and --outputs go together (for coherence and FRF pictures)")
    settings = _settings(args)
    output_folder(args.out, "--out")
    data = read_time_data(args.file)
    chans = [data.channel(n) for n in args.channels] if args.channels else None
    if args.seconds is not None and not (np.isfinite(args.seconds) and args.seconds > 0):
        raise UsageError(f"--seconds {args.seconds:g}: expected a positive duration")
    args.out.mkdir(parents=True, exist_ok=True)
    shown = chans if chans is not None else list(range(data.n_channels))
    paths = pictures.time_histories(args.out / "time.png", data, shown, seconds=args.seconds,
                                    title=f"{args.file.name}: time histories")  # fmt: skip
    start, n = pictures.time_window(data, shown, args.seconds)
    if n < data.n_samples:
        _say(t0, f"time histories over {start * data.dt:.4g}-{(start + n - 1) * data.dt:.4g} s "
                 f"of {data.n_samples * data.dt:.4g} s" + ("" if args.seconds else
                 " (around the largest peak; --seconds S for the first S seconds)"))
    psd_path = args.out / "psd.png"
    paths.append(psd_path)
    segment = min(round(settings.segment_s / data.dt), data.n_samples)
    x = data.values[shown]
    spectra = cross_spectra(x, x[:1], data.dt, segment, settings.overlap)
    psd = np.einsum("fii->if", spectra.Gxx).real
    pictures.power_spectra(psd_path, spectra.frequency_hz, psd,
                           [data.names[c] for c in shown], [data.units[c] for c in shown],
                           band=settings.band,
                           title=f"{args.file.name}: power spectral densities")  # fmt: skip
    if args.inputs is not None:
        result = estimate_frfs(data, args.inputs, args.outputs, settings)
        paths += _draw(args.out, result, args.inputs, args.outputs, settings)
    for p in paths:
        _say(t0, f"wrote {p}")
    return 0


def _draw(folder: Path, result: RigFRF, inputs: list[str], outputs: list[str],
          settings: FRFSettings) -> list[Path]:  # fmt: skip
    """The input PSDs, their singular values, the coherences and the FRFs in ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    s, est, band = result.spectra, result.estimate, settings.band
    psd = np.einsum("fii->if", s.Gxx).real
    units = [result.frf.units.split("/", 1)[-1]] * len(inputs)
    paths = [folder / n for n in ("input_psd.png", "singular_values.png", "coherence.png",
                                  "frf.png")]  # fmt: skip
    pictures.power_spectra(paths[0], s.frequency_hz, psd, inputs, units, band=band,
                           title="Input PSDs")  # fmt: skip
    pictures.singular_values_plot(paths[1], s, band=band)
    pictures.coherence_plot(paths[2], est, outputs, band=band)
    pictures.frf_plot(paths[3], est, outputs, inputs, result.frf.units, band=band)
    return paths


def _say(t0: float, msg: str) -> None:
    print(f"[{time.perf_counter() - t0:7.1f} s] {msg}", file=sys.stderr, flush=True)
