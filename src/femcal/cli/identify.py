"""``femcal identify FRF_FILE --band F1 F2 [--split F ...] [--order N ...] [--json FILE]
[--out DIR]``: a state-space model, its modes and a channel report from measured FRFs."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from ..errors import message
from ..identify import Settings, identify
from ..io.identified import write_model, write_summary
from ..testdata.data import convert_units
from ..testdata.formats import read_frf
from ..testdata.formats.npz import write_npz


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
                       description="Frequency-domain subspace identification of measured FRFs "
                       "(any format femcal reads: .npz, .csv, .uff/.unv, .mat), band by band, "
                       "joined and refined over the whole band.")  # fmt: skip
    p.add_argument("frf", type=Path, help="FRF file")
    p.add_argument("--band", type=float, nargs=2, required=True, metavar=("F1", "F2"),
                   help="frequency band in Hz")  # fmt: skip
    p.add_argument("--split", type=float, nargs="+", default=[], metavar="F",
                   help="split the band into parts at these frequencies (Hz)")  # fmt: skip
    p.add_argument("--order", type=_order, nargs="+", default=None, metavar="N",
                   help="model order: one for every part, or one per part; 'auto' (default) "
                   "takes it from each part's stabilisation diagram")  # fmt: skip
    p.add_argument("--max-order", type=int, default=24, metavar="N",
                   help="highest order of the stabilisation diagrams (default 24)")
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
                   "test-against-model overlays and the stabilisation diagrams (PNG)")  # fmt: skip


def run(args: argparse.Namespace) -> int:
    t0 = time.perf_counter()

    def progress(msg: str) -> None:
        print(f"[{time.perf_counter() - t0:7.1f} s] {msg}", file=sys.stderr, flush=True)

    try:
        data = read_frf(args.frf)
        if args.units:
            data = convert_units(data, args.units)
    except (KeyError, ValueError) as e:
        print(f"femcal identify: {message(e)}", file=sys.stderr)
        return 2
    progress(f"read {args.frf}: {len(data.outputs)} outputs x {len(data.inputs)} inputs x "
             f"{len(data.frequency_hz)} frequencies ({data.quantity}, "
             f"{data.units or 'no unit'})")  # fmt: skip
    n_parts = len(args.split) + 1
    orders = args.order
    if orders is not None and len(orders) == 1:
        orders = orders * n_parts
    settings = Settings(gamma=args.gamma, beta=args.beta,
                        lower_residual=not args.no_lower_residual,
                        feedthrough=not args.no_feedthrough, max_order=args.max_order)  # fmt: skip
    try:
        model = identify(data, tuple(args.band), splits=args.split, orders=orders,
                         settings=settings, progress=progress)  # fmt: skip
    except ValueError as e:
        print(f"femcal identify: {e}", file=sys.stderr)
        return 2
    print(f"{'mode':>5} {'frequency (Hz)':>15} {'damping (%)':>12}")
    for k, (f, z) in enumerate(zip(model.frequency_hz, model.damping_ratio, strict=True)):
        print(f"{k + 1:5d} {f:15.4f} {100 * z:12.3f}")
    print(f"fit error per channel: median {np.median(model.fit_error):.4f}, worst "
          f"{model.fit_error.max():.4f} ({model.outputs[int(np.argmax(model.fit_error))].label})")
    for i in np.flatnonzero(model.suspect):
        cons = "" if model.consistency is None else f", consistency {model.consistency[i]:.3f}"
        print(f"suspect channel {model.outputs[i].label}: fit error {model.fit_error[i]:.3f}"
              f"{cons}")  # fmt: skip
    if args.json:
        write_summary(args.json, model)
        progress(f"wrote {args.json}")
    if args.out:
        _write_out(args.out, data, model, progress)
    return 0


def _write_out(out: Path, data, model, progress) -> None:
    from ..viz.frf import frf_overlay
    from ..viz.identification import stabilization_diagram

    out.mkdir(parents=True, exist_ok=True)
    write_model(out / "model.npz", model)
    write_summary(out / "identify.json", model)
    sel = (data.frequency_hz >= model.band[0]) & (data.frequency_hz <= model.band[1])
    test = type(data)(data.frequency_hz[sel], data.H[:, :, sel], data.outputs, data.inputs,
                      data.quantity, data.units)  # fmt: skip
    fitted = model.frf(test.frequency_hz)
    write_npz(out / "frf_model.npz", fitted)
    # the worst-fitting channels and a spread of the others, first input and all inputs
    order = np.argsort(model.fit_error)[::-1]
    chans = list(dict.fromkeys([*order[:4], *np.linspace(0, len(order) - 1, 4).astype(int)]))
    pairs = [(int(o), i) for o in chans[:6] for i in range(min(2, len(data.inputs)))][:12]
    title = "test (black) and identified model (red), worst-fitting channels first"
    frf_overlay(out / "overlay.png", test, fitted, pairs=pairs, title=title)
    for k, part in enumerate(model.parts, start=1):
        if part.diagram is not None:
            stabilization_diagram(out / f"stabilization_part{k}.png", part.diagram, test)
    progress(f"wrote {out}/: model.npz, identify.json, frf_model.npz, overlay.png"
             + (", stabilisation diagrams" if any(p.diagram for p in model.parts) else ""))
