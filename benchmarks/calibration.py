"""Calibration on the hammer frame (issue 8): the time per LM iteration, per start and for
the whole run, and what the calibration finds against the hidden truth.

    make bench-calibration            # both parts, about 12 minutes on 2 cores
    .venv/bin/python benchmarks/calibration.py --part demo
    .venv/bin/python benchmarks/calibration.py --part noise-free

``demo``: the bundled study (models/truck_frame/hammer_calibration.toml: identification of the
shipped synthetic hammer test, 30 parameters, 24 starts, trust-region cycles), timed, with
each calibrated parameter set against the hidden value (hammer_test.truth.toml) and its
posterior standard deviation.

``noise-free``: a test made from the FE model with the hidden parameter values and without
the cross support (no model-form difference, no noise, modal damping 0.01 on every mode),
calibrated from the raw FRFs with the noise level given (``--noise-sigma``, default 1e-4 in
log10: the data are exact but for rounding); every parameter the posterior calls
identifiable should come back within 0.1 %; its cycles go on (at most --max-cycles) until
the informed parameters move less than 1e-5 in a step. With the noise of a real test declared
instead (``--noise-sigma 0.0087``, the log10 of 2 %) the prior rightly keeps the parameters
the test informs only to a few per cent near their nominal values: the posterior's maximum is
not the truth then, and the table shows by how many posterior standard deviations it misses.

``near-truth``: the same test, calibrated with one start from a deck whose parameters are the
hidden values moved by up to 3 % (the study's bounds): whether the trust-region cycles
converge to the truth once in its basin, apart from the global search.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import tomllib
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
FRAME = ROOT / "models" / "truck_frame"
WORK = ROOT / "benchmarks" / "_work"


def truth() -> dict[str, float]:
    """The hidden values (absolute) by parameter name."""
    t = tomllib.loads((FRAME / "hammer_test.truth.toml").read_text())
    return {p["name"]: float(p["true"]) for p in t["parameter"]}


def table(rep: dict, true_v: dict[str, float]) -> None:
    print("| parameter | nominal | calibrated | change % | true change % | error % "
          "| prior std % | posterior std % | error / posterior std | status |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for p in rep["parameters"]:
        t = true_v[p["name"]] / p["nominal"] - 1.0
        err = 100 * (p["p"] - t)
        post = 100 * p["posterior_std_p"]
        ratio = "-" if p["held"] or not post else f"{abs(err) / post:.1f}"
        status = ("held" if p["held"] else "identifiable" if p["identifiable"] else "weak")
        status += ", at a bound" if p["at_bound"] else ""
        print(f"| {p['name']} | {p['nominal']:.6g} | {p['calibrated']:.6g} | {100 * p['p']:+.2f} "
              f"| {100 * t:+.2f} | {err:+.2f} | {100 * p['prior_std_p']:.2f} | {post:.2f} "
              f"| {ratio} | {status} |")


def timing(rep: dict, seconds: float) -> None:
    starts = rep["starts"]
    it = sum(s["iterations"] for s in starts)
    sec = sum(s["seconds"] for s in starts)
    conf = rep["configurations"][0]
    print(f"\nwhole run {seconds:.0f} s ({conf['model_dof']} DOF, {len(rep['parameters'])} "
          f"parameters, {len(conf['outputs'])} x {len(conf['inputs'])} channels at "
          f"{conf['n_frequencies']} frequencies, {rep['reduction_modes']} modes in the "
          "surrogate)")
    print(f"cycle 1: {len(starts)} starts, {it} LM iterations, {sec:.0f} s of LM in all "
          f"(in parallel processes): {sec / max(it, 1):.2f} s per iteration, "
          f"{sec / len(starts):.1f} s per start")
    print(f"cycles: {len(rep['cycles'])}, settled: {rep['settled']}")


def demo() -> None:
    from femcal.calibrate.config import read_config
    from femcal.io.calibration import report_dict
    from femcal.jobs.calibration import run

    out = WORK / "calibration_demo"
    t = time.perf_counter()
    o = run(read_config(FRAME / "hammer_calibration.toml"), out, fresh=True,
            progress=lambda m: print(m, file=sys.stderr, flush=True))  # fmt: skip
    seconds = time.perf_counter() - t
    rep = report_dict(o)
    print("\n## the bundled study\n")
    timing(rep, seconds)
    print("\n| test Hz | FE before | FE after | MAC before | MAC after |\n|---|---|---|---|---|")
    for m in rep["configurations"][0]["modes"]:
        print(f"| {m['test_hz']:.3f} | {m['fe_before_hz']:.3f} | {m['fe_after_hz']:.3f} "
              f"| {m['mac_before']:.4f} | {m['mac_after']:.4f} |")
    d = rep["deviation"]
    print(f"\ndeviation {d['before']:.1f} before, {d['after']:.1f} after\n")
    table(rep, truth())


def noise_free(max_cycles: int = 40, near: float | None = None, residual: bool = False,
               enrich_hz: float | None = None, modal_hz: float | None = None,
               exact_gradient: bool = True, starts: int | None = None,
               noise_sigma: float = 1e-4) -> None:  # fmt: skip
    from femcal.calibrate.config import read_config
    from femcal.calibrate.parameters import read_parameters, with_values
    from femcal.io.calibration import report_dict
    from femcal.jobs.calibration import run
    from femcal.model import EigenRequest
    from femcal.model.build import load_model
    from femcal.response.frf import channel_matrix, modal_frf
    from femcal.solve.normal_modes import solve_normal_modes
    from femcal.testdata.data import FRFData
    from femcal.testdata.formats import read_frf
    from femcal.testdata.formats.npz import write_npz

    WORK.mkdir(parents=True, exist_ok=True)
    model = load_model(FRAME / "hammer_frame.bdf")
    params = read_parameters(FRAME / "hammer_frame.params.toml", model)
    true_v = truth()
    m = with_values(model, params, [true_v[q.name] for q in params])
    modes, _ = solve_normal_modes(m, request=EigenRequest(nd=100))
    shipped = read_frf(FRAME / "hammer_test.mat")  # its channels and frequencies
    f = shipped.frequency_hz
    if residual:  # the same FRF definition as the calibration's: + residual flexibility
        from femcal.calibrate.reduction import build_surrogate

        p_true = np.array([true_v[q.name] / q.nominal - 1.0 for q in params])
        sur, _ = build_surrogate(model, params, p_true, shipped.outputs, shipped.inputs,
                                 n_modes=100, zeta=0.01, residual=True,
                                 frf_hz=modal_hz)  # fmt: skip
        H = sur.frf(p_true, f)
    else:
        if modal_hz is not None:
            raise SystemExit("--modal-hz needs --residual (the test's FRF definition)")
        H = modal_frf(modes.shapes, modes.radians, channel_matrix(m, shipped.outputs),
                      channel_matrix(m, shipped.inputs).T, f, 0.01, "accelerance")  # fmt: skip
    write_npz(WORK / "noise_free_test.npz", FRFData(f, H, shipped.outputs, shipped.inputs,
                                                    "accelerance", "mm/s^2/N"))  # fmt: skip
    deck_path, params_path, name = (FRAME / "hammer_frame.bdf",
                                    FRAME / "hammer_frame.params.toml", "noise_free")
    if near is not None:  # the local check: the deck's values moved to near the truth
        deck_path, params_path, name = _near_truth_start(params, true_v, near)
    cfg = (FRAME / "hammer_calibration.toml").read_text()
    cfg = cfg.replace('deck = "hammer_frame.bdf"', f'deck = "{deck_path}"')
    cfg = cfg.replace('parameters = "hammer_frame.params.toml"',
                      f'parameters = "{params_path}"')  # fmt: skip
    cfg = cfg.replace('frf = "hammer_test.uff"', 'frf = "noise_free_test.npz"')
    for points in ("sensors", "inputs"):  # the frame's sensor and input files, named
        cfg = cfg.replace(f'{points} = "hammer_frame.{points}.csv"',
                          f'{points} = "{FRAME / f"hammer_frame.{points}.csv"}"')  # fmt: skip
    cfg = cfg.replace('truth = "hammer_test.truth.toml"',
                      f'truth = "{FRAME / "hammer_test.truth.toml"}"')  # the same hidden values
    head, _, tail = cfg.partition("[test.identify]")
    tail = tail[tail.index("[calibration]"):]
    tail = tail.replace('zeta0 = "median"', f"zeta0 = 0.01\nnoise_sigma = {noise_sigma!r}")
    # the check asks for 0.1 %: the cycles go on until the informed parameters move less
    # than 1e-5 in a step (the demo settles at 2e-3)
    tail = tail.replace("max_cycles = 10", f"max_cycles = {max_cycles}")
    cfg = head + tail.replace("settle = 2e-3", "settle = 1e-5")
    if near is not None:
        cfg = cfg.replace("starts = 24", "starts = 1")  # the check is local convergence
    elif starts is not None:
        cfg = cfg.replace("starts = 24", f"starts = {starts}")
        name += f"_starts{starts}"
    extra = ("residual = true\n" if residual else "") + (
        f"enrich_hz = {enrich_hz}\n" if enrich_hz is not None else "") + (
        f"modal_hz = {modal_hz}\n" if modal_hz is not None else "") + (
        "" if exact_gradient else "exact_gradient = false\n")
    if enrich_hz is not None:  # the demo's own setting gives way
        cfg = "\n".join(x for x in cfg.splitlines() if not x.startswith("enrich_hz")) + "\n"
    cfg = cfg.replace("[calibration]\n", "[calibration]\n" + extra)
    name += "_residual" if residual else ""
    name += f"_enrich{enrich_hz:g}" if enrich_hz is not None else ""
    name += f"_modal{modal_hz:g}" if modal_hz is not None else ""
    name += "" if exact_gradient else "_surrogate_gradient"
    name += f"_noise{noise_sigma:g}"
    (WORK / f"{name}.toml").write_text(cfg)
    t = time.perf_counter()
    o = run(read_config(WORK / f"{name}.toml"), WORK / f"calibration_{name}", fresh=True,
            progress=lambda msg: print(msg, file=sys.stderr, flush=True))  # fmt: skip
    seconds = time.perf_counter() - t
    rep = report_dict(o)
    print("\n## noise-free test from the hidden parameters, no model-form difference"
          + ("" if near is None else f", calibrated from within {100 * near:g} % of them")
          + "\n")  # fmt: skip
    timing(rep, seconds)
    d = rep["deviation"]
    print(f"\ndeviation {d['before']:.4g} before, {d['after']:.4g} after\n")
    table(rep, true_v)
    ok = [abs(r["calibrated"] / true_v[r["name"]] - 1) < 1e-3
          for r in rep["parameters"] if r["identifiable"]]  # fmt: skip
    print(f"\nidentifiable parameters recovered within 0.1 %: {sum(ok)} of {len(ok)}")
    json.dump(rep, (WORK / f"{name}_report.json").open("w"), indent=1)


def _near_truth_start(params, true_v: dict[str, float], near: float) -> tuple[Path, Path, str]:
    """A deck and parameter file whose nominal values are the truth moved by up to ``near``
    (relative, seeded, within the bounds); the bounds stay the study's."""
    from femcal.io.calibration import write_calibrated_deck

    rng = np.random.default_rng(7)
    start = [float(np.clip(true_v[q.name] * (1 + rng.uniform(-near, near)), q.lower, q.upper))
             for q in params]  # fmt: skip
    deck_path = WORK / "near_truth_start.bdf"
    write_calibrated_deck(FRAME / "hammer_frame.bdf", params, np.array(start), deck_path)
    lines = ["# the hammer frame's parameters with nominal values near the hidden truth"]
    for q in params:  # no nominal: the deck's, as the deck writer rounded it
        lines += ["", "[[parameter]]", f'name = "{q.name}"', f'card = "{q.card}"', f"id = {q.id}",
                  f'field = "{q.field}"', f"lower = {q.lower!r}", f"upper = {q.upper!r}"]
    params_path = WORK / "near_truth_start.params.toml"
    params_path.write_text("\n".join(lines) + "\n")
    return deck_path, params_path, "near_truth"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", choices=("demo", "noise-free", "near-truth", "all"),
                    default="all")
    ap.add_argument("--residual", action="store_true",
                    help="noise-free parts: FRFs with the residual flexibility (test and model)")
    ap.add_argument("--enrich-hz", type=float, default=None,
                    help="noise-free parts: the enrichment frequency (0: none)")
    ap.add_argument("--max-cycles", type=int, default=40,
                    help="trust-region cycles of the noise-free part (default 40)")
    ap.add_argument("--modal-hz", type=float, default=None,
                    help="noise-free parts with --residual: the FRFs sum the modes up to this "
                    "frequency (test and model), the others as residual flexibility")
    ap.add_argument("--starts", type=int, default=None,
                    help="noise-free part: Latin hypercube starts (default the demo's 24)")
    ap.add_argument("--noise-sigma", type=float, default=1e-4,
                    help="noise-free parts: the noise level given to the calibration (log10; "
                    "default 1e-4)")
    ap.add_argument("--surrogate-gradient", action="store_true",
                    help="noise-free parts: no first-order correction by the full model's "
                    "exact Jacobian (exact_gradient = false)")
    a = ap.parse_args(argv)
    kw = dict(residual=a.residual, enrich_hz=a.enrich_hz, modal_hz=a.modal_hz,
              exact_gradient=not a.surrogate_gradient, noise_sigma=a.noise_sigma)
    if a.part in ("demo", "near-truth") and a.starts is not None:
        raise SystemExit("--starts is for the noise-free part")
    if a.part in ("demo", "all"):
        demo()
    if a.part in ("noise-free", "all"):
        noise_free(a.max_cycles, starts=a.starts, **kw)
    if a.part in ("near-truth", "all"):
        noise_free(a.max_cycles, near=0.03, **kw)
    return 0


if __name__ == "__main__":
    sys.exit(main())
