"""``femcal identify FRF_FILE --band F1 F2 [--split F ...] [--order N ...] [--json FILE]
[--out DIR [--geometry DECK]]``: a state-space model, its modes and a channel report from
measured FRFs."""

from __future__ import annotations

import argparse
import itertools
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from ..correlate import mac_text
from ..errors import FemcalWarning, message
from ..identify import Layout, Settings, identify
from ..identify.compare import pair_models
from ..identify.plscf import MAX_ORDER as PLSCF_MAX_ORDER
from ..identify.workflow import MAX_ORDER, METHODS
from ..io.identified import write_model, write_summary
from ..testdata.data import convert_units
from ..testdata.formats import read_frf
from ..testdata.formats.npz import write_npz
from .paths import file_in_the_way


def _order(text: str) -> int | None:
    if text.lower() == "auto":
        return None
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a whole number or 'auto'") from None
    if n < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: an order must be at least 1")
    return n


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("identify", help="identify a state-space model and modes from FRFs",
                       description="Modes of measured FRFs (any format femcal reads: .npz, "
                       ".csv, .uff/.unv, .mat) with only the band given: pLSCF (PolyMAX) or "
                       "frequency-domain subspace identification over parts chosen from the "
                       "CMIF, the stable columns of each stabilisation diagram, residues by "
                       "least squares over the whole band. Any layout: the larger side is "
                       "taken as the roving one (a roving-hammer set as measured, 1 response x "
                       "N hammer points, or transposed, N x 1: the same poles, the shapes at "
                       "the N points); the smaller side is the reference. Channels are "
                       "GRID:DIR (12:+Z, 4:-X) or free labels; a universal file names them by "
                       "its response and reference nodes (docs/identification.md).")  # fmt: skip
    p.add_argument("frf", type=Path, help="FRF file")
    p.add_argument("--band", type=float, nargs=2, required=True, metavar=("F1", "F2"),
                   help="frequency band in Hz")  # fmt: skip
    p.add_argument("--split", type=float, nargs="+", default=None, metavar="F",
                   help="split the band into parts at these frequencies (Hz); default: "
                   "chosen from the CMIF's peaks (at most --part-modes peaks a part)")
    p.add_argument("--method", choices=(*METHODS, "both"), default="plscf",
                   help="the estimator: plscf (poly-reference least-squares complex "
                   "frequency-domain, PolyMAX; default), subspace (frequency-domain "
                   "subspace, McKelvey et al. 1996), or both: pLSCF's model is written, "
                   "the subspace one beside it in OUT/subspace/, and their modes side by "
                   "side on the console and in OUT/comparison.json")
    p.add_argument("--order", type=_order, nargs="+", default=None, metavar="N",
                   help="model order: one for every part, or one per part; 'auto' (default) "
                   "takes it from each part's stabilisation diagram")  # fmt: skip
    p.add_argument("--max-order", type=int, default=None, metavar="N",
                   help="highest order of the stabilisation diagrams (default: from each "
                   "part's peaks)")
    p.add_argument("--part-modes", type=int, default=6, metavar="N",
                   help="without --split: the most CMIF peaks a part holds (default 6)")
    p.add_argument("--gamma", type=float, default=1.43,
                   help="residual pole at GAMMA times the upper band edge (default 1.43)")
    p.add_argument("--beta", type=float, default=100.0,
                   help="far residual pole at BETA times the upper band edge (default 100)")
    p.add_argument("--no-lower-residual", action="store_true",
                   help="no residual pole below the band (at F1 / GAMMA)")
    p.add_argument("--no-feedthrough", action="store_true", help="no D term")
    p.add_argument("--units", metavar="UNITS",
                   help="convert the FRFs to these units first, e.g. mm/s^2/N")
    p.add_argument("--json", type=Path, metavar="FILE", help="summary as JSON")
    p.add_argument("--out", type=Path, metavar="DIR",
                   help="write model.npz, identify.json, the identified FRFs (frf_model.npz), "
                   "the mode shapes as a universal file (identified_shapes.unv), "
                   "test-against-model overlays and the stabilisation diagrams (PNG)")  # fmt: skip
    p.add_argument("--geometry", type=Path, metavar="DECK",
                   help="with --out: the FE deck whose grids the channels name; "
                   "identified_shapes.unv then also holds the sensors' grids and a wireframe "
                   "along the mesh, and GRID:1-3 channels are taken in the grids' CD frames")


def _check(args: argparse.Namespace) -> str | None:
    """What is wrong with the arguments, as one line, or None; checked before the file is
    read so that a mistyped option costs nothing."""
    f1, f2 = args.band
    if not (np.isfinite(f1) and np.isfinite(f2) and 0 <= f1 < f2):
        return (f"--band {f1:g} {f2:g}: expected 0 <= F1 < F2 (Hz, finite; from 0 the DC "
                "line is left out)")
    bad = [x for x in args.split or () if not (np.isfinite(x) and f1 < x < f2)]
    if bad:
        return f"--split {bad[0]:g}: expected a frequency inside the band {f1:g}-{f2:g} Hz"
    if args.split is not None and any(b <= a for a, b in itertools.pairwise(args.split)):
        return (f"--split {' '.join(f'{x:g}' for x in args.split)}: expected increasing "
                "frequencies, each once")
    if (args.max_order is not None and args.method != "subspace"
            and args.max_order > PLSCF_MAX_ORDER):  # fmt: skip
        return (f"--max-order {args.max_order}: expected at most {PLSCF_MAX_ORDER} for plscf "
                "(its polynomial order)")
    if not (np.isfinite(args.gamma) and args.gamma > 1):
        return (f"--gamma {args.gamma:g}: expected a number above 1 (residual poles at GAMMA "
                "times the upper band edge and at F1 / GAMMA, outside the band)")
    if not (np.isfinite(args.beta) and args.beta > args.gamma):
        return (f"--beta {args.beta:g}: expected a number above --gamma ({args.gamma:g}): the "
                "far residual pole sits at BETA times the upper band edge")
    if args.max_order is not None and not 2 <= args.max_order <= MAX_ORDER:
        return f"--max-order {args.max_order}: expected a whole number from 2 to {MAX_ORDER}"
    if args.part_modes < 1:
        return f"--part-modes {args.part_modes}: expected a whole number of at least 1"
    if args.order is not None and len(args.order) > 1 and args.split is None:
        return (f"--order: {len(args.order)} orders without --split; expected one order for "
                "every part, or --split with one order per part")
    n_parts = len(args.split or ()) + 1
    if args.order is not None and len(args.order) not in (1, n_parts):
        return (f"--order: {len(args.order)} orders for {n_parts} parts; expected one for "
                "every part or one per part")
    if args.geometry is not None and args.out is None:
        return f"--geometry {args.geometry}: draws the shapes of --out; expected --out DIR too"
    if args.out is not None and args.out.exists() and not args.out.is_dir():
        return f"--out {args.out}: exists and is not a directory; expected a directory"
    if args.json is not None and args.json.is_dir():
        return f"--json {args.json}: is a directory; expected a file name"
    for name, path in (("--out", args.out), ("--json", args.json)):
        blocked = None if path is None else file_in_the_way(path)
        if blocked is not None:
            return f"{name} {path}: {blocked} is a file, not a directory"
    return None


def run(args: argparse.Namespace) -> int:
    t0 = time.perf_counter()

    def progress(msg: str) -> None:
        print(f"[{time.perf_counter() - t0:7.1f} s] {msg}", file=sys.stderr, flush=True)

    problem = _check(args)
    if problem:
        print(f"femcal identify: {problem}", file=sys.stderr)
        return 2
    try:
        data = read_frf(args.frf)
        if args.units:
            data = convert_units(data, args.units)
    except (KeyError, ValueError) as e:
        print(f"femcal identify: {message(e)}", file=sys.stderr)
        return 2
    geometry = None
    if args.geometry is not None:
        from ..model.build import load_model

        geometry = load_model(args.geometry)
        progress(f"read {args.geometry}: {geometry.n_grids} grids")
        channels = Layout.of(data.outputs, data.inputs).roving
        rows = geometry.node_index([c.grid or 0 for c in channels])
        lost = [c.label for c, r in zip(channels, rows, strict=True)
                if c.grid is not None and (r < 0 or not geometry.is_grid[r])]  # fmt: skip
        if lost:
            print(f"femcal identify: --geometry {args.geometry}: no GRID for channel "
                  f"{lost[0]}" + (f" ({len(lost) - 1} more)" if len(lost) > 1 else "")
                  + f" of {args.frf}; expected the deck the test's grids are in",
                  file=sys.stderr)  # fmt: skip
            return 2
    progress(f"read {args.frf}: {len(data.outputs)} outputs x {len(data.inputs)} inputs x "
             f"{len(data.frequency_hz)} frequencies ({data.quantity}, "
             f"{data.units or 'no unit given: shapes and residues in the file units'})"
             + ("" if data.coherence is None else ", with coherence (weights of the fits: "
                "pLSCF's per channel and frequency, the residues' per frequency)"))
    negative = [c.label for c in (*data.outputs, *data.inputs)
                if c.direction is not None and c.direction.startswith("-")]
    if negative:
        progress(f"{len(negative)} channel(s) measured along a negative axis ("
                 + ", ".join(negative[:6]) + (" ..." if len(negative) > 6 else "")
                 + "): shapes are given as measured; the UFF 55 shapes and correlation "
                 "turn them onto the positive axis")
    orders = args.order
    if orders is not None and len(orders) == 1:
        orders = orders[0]
    methods = METHODS if args.method == "both" else (args.method,)
    models = []
    for method in methods:
        if len(methods) > 1:
            progress(f"--- {method}")
        try:
            settings = Settings(gamma=args.gamma, beta=args.beta,
                                lower_residual=not args.no_lower_residual,
                                feedthrough=not args.no_feedthrough, max_order=args.max_order,
                                method=method, part_modes=args.part_modes)
            models.append(identify(data, tuple(args.band), splits=args.split, orders=orders,
                                   settings=settings, progress=progress))  # fmt: skip
        except ValueError as e:
            if not models:
                print(f"femcal identify: {args.frf}: {message(e)}", file=sys.stderr)
                return 2
            print(f"femcal identify: warning: {method} failed, {methods[0]}'s model is kept: "
                  f"{message(e)}", file=sys.stderr)  # fmt: skip
            methods = methods[:1]
    model = models[0]
    print_modes(model)
    from ..io.identify_page import identification_verdict

    verdict = identification_verdict(model)
    print(f"verdict: {verdict.sentence}")
    for line in verdict.all_doubts:
        print(f"doubt: {line}")
    rows = None
    if len(models) > 1:
        rows = pair_models(models[0], models[1])
        print_comparison(rows, methods)
    if args.json:
        write_summary(args.json, model)
        progress(f"wrote {args.json}")
    if args.out:
        _write_out(args.out, data, model, progress, geometry, source=args.frf,
                   geometry_path=args.geometry)  # fmt: skip
        if rows is not None:
            _write_out(args.out / methods[1], data, models[1], progress, geometry,
                       source=args.frf, geometry_path=args.geometry)  # fmt: skip
            write_comparison(args.out / "comparison.json", rows, methods)
            progress(f"wrote {args.out / 'comparison.json'}")
    return 0


def print_comparison(rows, methods) -> None:
    """The two methods' modes side by side on stdout."""
    a, b = methods
    print(f"{a + ' Hz':>14} {'damping %':>10} {b + ' Hz':>14} {'damping %':>10} "
          f"{'diff %':>8} {'MAC':>6}")

    def num(x, scale=1.0, fmt="{:.4f}"):
        return "-" if x is None else fmt.format(scale * x)

    for r in rows:
        (f1, f2), (z1, z2) = r.frequency_hz, r.damping_ratio
        diff = None if f1 is None or f2 is None else 100 * (f2 / f1 - 1)
        print(f"{num(f1):>14} {num(z1, 100):>10} {num(f2):>14} {num(z2, 100):>10} "
              f"{num(diff, fmt='{:+.3f}'):>8} {'-' if r.mac is None else mac_text(r.mac):>6}")


def write_comparison(path: Path, rows, methods) -> None:
    """The two methods' paired modes as JSON (atomically)."""
    import json

    from ..atomic import write_atomic

    table = [{"methods": list(methods), "frequency_hz": list(r.frequency_hz),
              "damping_ratio": list(r.damping_ratio), "mac": r.mac} for r in rows]
    text = json.dumps(table, indent=1) + "\n"
    write_atomic(path, lambda tmp: Path(tmp).write_text(text))


def print_modes(model) -> None:
    """The modes table (frequency, damping, MPC, MPD) and the channels' fit on stdout (the
    suspect channels are among the verdict's doubts)."""
    print(f"{'mode':>5} {'frequency (Hz)':>15} {'damping (%)':>12} {'MPC':>6} {'MPD (deg)':>9}")
    for k, (f, z) in enumerate(zip(model.frequency_hz, model.damping_ratio, strict=True)):
        print(f"{k + 1:5d} {f:15.4f} {100 * z:12.4f} {model.mpc[k]:6.3f} {model.mpd[k]:9.1f}")
    chans = model.shape_channels
    worst = int(np.argmax(model.fit_error)) if len(model.fit_error) else 0
    print(f"fit error per channel: median {np.median(model.fit_error):.4f}, worst "
          f"{model.fit_error.max():.4f} ({chans[worst].label}); FRF correlation: median "
          f"{np.median(model.frf_correlation):.4f}, lowest {model.frf_correlation.min():.4f}")


#: The universal file of the identified shapes that ``--out`` writes.
SHAPES_FILE = "identified_shapes.unv"


def _write_shapes(path: Path, model, geometry) -> str | None:
    """The identified shapes as a universal file (complex modes, dataset 55 analysis type
    3), with the sensors' grids and their wireframe when the geometry deck is given; what
    it holds, for the progress line (None, with a warning, when no channel names a grid)."""
    from ..io.uff_shapes import (
        TraceLines,
        identified_shapes,
        model_grids,
        sensor_wireframe,
        write_uff_shapes,
    )

    if not any(c.grid is not None for c in model.shape_channels):
        warnings.warn(FemcalWarning(f"no channel of the shapes names a grid (GRID:DIRECTION): "
                                    f"{path.name} not written"), stacklevel=2)  # fmt: skip
        return None
    shapes = identified_shapes(model, geometry)
    if geometry is None:
        write_uff_shapes(path, None, [shapes])
        return f"{shapes.n_modes} shapes at {len(shapes.grid_ids)} grids"
    grids = model_grids(geometry, shapes.grid_ids)
    lines = TraceLines(sensor_wireframe(geometry, shapes.grid_ids), "femcal sensor wireframe")
    write_uff_shapes(path, grids, [shapes], lines)
    return f"{shapes.n_modes} shapes, {len(grids.ids)} grids, {len(lines.pairs)} trace lines"


def _write_out(out: Path, data, model, progress, geometry=None, *, source: Path,
               geometry_path: Path | None = None) -> None:  # fmt: skip
    from ..io.html import file_facts, provenance
    from ..io.identify_page import write_identification_page
    from ..viz.frf import frf_overlay
    from ..viz.identification import indicator_plot, stabilization_diagram

    out.mkdir(parents=True, exist_ok=True)
    write_model(out / "model.npz", model)
    write_summary(out / "identify.json", model)
    what = _write_shapes(out / SHAPES_FILE, model, geometry) if len(model.poles) else None
    if what:
        progress(f"wrote {out / SHAPES_FILE}: {what}")
    sel = (data.frequency_hz >= model.band[0]) & (data.frequency_hz <= model.band[1])
    test = type(data)(data.frequency_hz[sel], data.H[:, :, sel], data.outputs, data.inputs,
                      data.quantity, data.units)  # fmt: skip
    fitted = model.frf(test.frequency_hz)
    write_npz(out / "frf_model.npz", fitted)
    # the worst-fitting channels and a spread of the others, first input and all inputs
    order = np.argsort(model.fit_error)[::-1]
    chans = list(dict.fromkeys([*order[:4], *np.linspace(0, len(order) - 1, 4).astype(int)]))
    n_ref = len(model.reference_channels)
    pairs = [(int(o), i) for o in chans[:4] for i in range(min(2, n_ref))][:8]
    if model.layout is not None and model.layout.transposed:  # (roving, reference) -> (out, in)
        pairs = [(i, o) for o, i in pairs]
    title = "test (black) and identified model (red), worst-fitting channels first"
    frf_overlay(out / "overlay.png", test, fitted, pairs=pairs, title=title, columns=2)
    indicator_plot(out / "indicators.png", test, model.band, model.frequency_hz,
                   model.peaks_hz)  # fmt: skip
    figures = [
        ("Measured and identified FRFs", out / "overlay.png",
         "Magnitude and phase of the measured FRFs (black) and the identified model's (red) "
         "against frequency (Hz), the worst-fitting channels first, in the data's units."),
        ("Mode indicator functions", out / "indicators.png",
         "The CMIF (singular values of the FRF matrix) and the MIF against frequency (Hz), "
         "with the CMIF's peaks and the identified modes marked.")]  # fmt: skip
    for k, part in enumerate(model.parts, start=1):
        if part.diagram is not None:
            path = out / f"stabilization_part{k}.png"
            stabilization_diagram(path, part.diagram, test)
            figures.append((f"Stabilisation diagram, {part.band[0]:g}-{part.band[1]:g} Hz",
                            path, "The poles of every model order (vertical) against "
                            "frequency (Hz): filled blue, stable in frequency, damping and "
                            "shape; hollow green, in frequency only; red dots, new. Each "
                            "chosen mode a vertical line with the number of orders it was "
                            "stable in; the CMIF in grey on the right-hand axis."))  # fmt: skip
    inputs = [file_facts("FRFs", source)] + ([file_facts("geometry", geometry_path)]
                                             if geometry_path else [])  # fmt: skip
    page = write_identification_page(out / "identification.html", model, figures,
                                     provenance(inputs), source=str(source))  # fmt: skip
    progress(f"wrote {out}/: model.npz, identify.json, frf_model.npz, overlay.png, "
             "indicators.png"
             + (", stabilisation diagrams" if any(p.diagram for p in model.parts) else "")
             + f", {page.name}")
