"""A calibration's files: ``report.json`` (the typed result as JSON), the calibrated deck,
and ``report.html`` with its pictures (:mod:`femcal.viz.calibration`). Every file is
written atomically."""

from __future__ import annotations

import html
import json
import os
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..atomic import write_atomic, write_lines
from ..calibrate.config import Config
from ..calibrate.parameters import Parameter
from ..calibrate.result import CalibrationResult, Cycle


def calibrated_deck_name(cfg: Config) -> str:
    """The calibrated deck's file name: the deck's stem with ``_calibrated.bdf``."""
    return f"{cfg.deck.stem}_calibrated.bdf"


def _finite(v: float | None) -> float | None:
    return None if v is None or not np.isfinite(v) else float(v)


def _cycle(c: Cycle) -> dict:
    """A cycle as the report lists it (its starts are listed for cycle 1 only)."""
    f = [float(x) for x in c.center]
    if c.cycle == 1:
        return {"cycle": 1, "center": f, "best_start": c.best_start,
                "p": [float(x) for x in c.p], "deviation": c.deviation,
                "exact_deviation_at_center": c.exact_deviation_at_center, "moved": c.moved,
                "accepted": c.accepted, "radius": c.radius}  # fmt: skip
    out = {"cycle": c.cycle, "candidate": [float(x) for x in c.candidate], "rho": c.rho,
           "accepted": c.accepted, "radius": c.radius, "from_search": c.from_search,
           "exact_deviation_at_candidate": c.exact_deviation_at_candidate,
           "moved_informed": c.moved_informed, "center": f, "searched": c.searched}  # fmt: skip
    if c.searched:
        out["search_best_deviation"] = c.search_best_deviation
    return {**out, "p": [float(x) for x in c.p], "deviation": c.deviation,
            "best_start": c.best_start}


def noise_level(result: CalibrationResult) -> float | None:
    """The test's noise in the metric's units (log10), from the identification's median fit
    error (a relative complex error e spreads e / (sqrt(2) ln 10) on each of the metric's
    parts); None without an identified model."""
    ident = result.identified
    if ident is None or not len(ident.fit_error):
        return None
    return float(np.median(ident.fit_error) / (np.sqrt(2.0) * np.log(10.0)))


def misfit_sigma(result: CalibrationResult) -> float:
    """The standard deviation of one residual after calibration (log10 units)."""
    return float(np.sqrt(result.deviation_after / result.likelihood.m))


def summary_lines(result: CalibrationResult) -> list[str]:
    """The trust summary that leads the report and ends the console output: whether the
    search settled, what was calibrated, held, identifiable or left on a bound, and whether
    the misfit points at something the model lacks."""
    rs = result.parameters
    held = [r.parameter.name for r in rs if r.held]
    ident = [r.parameter.name for r in rs if r.identifiable]
    bound = [r.parameter.name for r in rs if r.at_bound]
    lines = [("The search settled: the identifiable parameters stopped moving." if result.settled
              else "The search did not settle: the identifiable parameters were still moving "
              "when the cycles ran out."),
             f"{len(rs) - len(held)} of {len(rs)} parameters calibrated, {len(held)} held at "
             "their nominal values (the test cannot inform them); identifiable: "
             f"{', '.join(ident) or 'none'}."]  # fmt: skip
    if bound:
        lines.append(f"Warning: {', '.join(bound)} ended on a bound: the test asks for more "
                     "than the bounds allow, which usually means the parameter stands in for "
                     "something the model lacks.")  # fmt: skip
    else:
        lines.append("No parameter ended on a bound.")
    noise = noise_level(result)
    after = misfit_sigma(result)
    if noise is not None and after > 3.0 * noise:
        lines.append(f"Model-form warning: the misfit after calibration (sigma {after:.3g} in "
                     f"log10) is {after / noise:.0f} times the test's noise ({noise:.2g}): the "
                     "model lacks something the structure has (a joint, a support, a mass), "
                     "which the parameters cannot stand for without bias.")  # fmt: skip
    elif noise is not None:
        lines.append(f"The misfit after calibration (sigma {after:.3g}) is within 3 times the "
                     f"test's noise ({noise:.2g}).")  # fmt: skip
    dev = (f"Deviation {result.deviation_before:.6g} before, {result.deviation_after:.6g} "
           "after.")
    lines.append(dev)
    return lines


def report_dict(result: CalibrationResult) -> dict:
    """``report.json``'s content: the run's inputs and settings, the trust summary, every
    parameter (nominal, calibrated, bounds, held or identifiable and why, prior and
    posterior standard deviations, at a bound, and the error against the truth of a synthetic
    test), the paired modes, the deviation, the prior and likelihood, the posterior's bands
    and correlation, the cycles and the first cycle's starts."""
    cfg = result.config
    params = []
    for r in result.parameters:
        par = r.parameter
        row = {"name": par.name, "description": par.description, "card": par.card,
               "id": par.id, "field": par.field, "nominal": par.nominal,
               "calibrated": r.calibrated, "lower": par.lower, "upper": par.upper, "p": r.p,
               "held": r.held, "identifiable": r.identifiable, "at_bound": r.at_bound,
               "prior_std_p": r.prior_std_p, "posterior_std_p": r.posterior_std_p,
               "posterior_std": r.posterior_std, "ratio": r.ratio,
               "crlb": _finite(r.crlb), "crlb_p": _finite(r.crlb_p),
               "reason": r.reason}  # fmt: skip
        if r.true is not None:
            row.update({"true": r.true, "true_p": r.true_p, "error_pct": r.error_pct,
                        "error_over_std": r.error_over_std})  # fmt: skip
        params.append(row)
    modes = [{"test_mode": m.test_mode, "test_hz": m.test_hz, "fe_before_mode": m.fe_before,
              "fe_before_hz": m.fe_before_hz, "mac_before": m.mac_before,
              "fe_after_mode": m.fe_after, "fe_after_hz": m.fe_after_hz,
              "mac_after": m.mac_after,
              "frequency_error_before_pct": m.frequency_error_before_pct,
              "frequency_error_after_pct": m.frequency_error_after_pct,
              "pseudo_orthogonality_after": m.pseudo_orthogonality_after}
             for m in result.modes]  # fmt: skip
    lik, post = result.likelihood, result.posterior
    return {
        "deck": str(cfg.deck), "parameters_file": str(cfg.parameters),
        "test": str(cfg.test_frf or cfg.test_model),
        "truth": str(cfg.test_truth) if cfg.test_truth is not None else None,
        "band_hz": list(cfg.band), "zeta0": result.zeta0, "metric": cfg.metric,
        "n_frequencies": len(result.freq), "outputs": [c.label for c in result.outputs],
        "inputs": [c.label for c in result.inputs],
        "excluded_channels": [c.label for c in result.excluded],
        "summary": summary_lines(result), "parameters": params, "modes": modes,
        "deviation": {"before": result.deviation_before, "after": result.deviation_after,
                      "surrogate_history": [c.deviation for c in result.cycles]},
        "prior": {"bounds_sigma": cfg.bounds_sigma,
                  "std_p": [float(x) for x in result.prior.std],
                  "from_confidence": [bool(x) for x in result.prior.from_confidence]},
        "likelihood": {"sigma": lik.sigma, "residuals": lik.m,
                       "effective_observations": lik.n_eff, "estimated": lik.estimated,
                       "misfit_sigma_after": misfit_sigma(result),
                       "noise_sigma": noise_level(result)},
        "posterior": {"hold_ratio": cfg.hold_ratio,
                      "identifiable_below": cfg.identifiable_ratio,
                      "collinearity_identifiable": result.identifiability.collinearity,
                      "per_band": [{"band_hz": list(b.band_hz),
                                    "std_p": [float(x) for x in b.std]}
                                   for b in result.band_bounds],
                      "correlation": [[_finite(v) for v in row] for row in post.correlation]},
        "cycles": [_cycle(c) for c in result.cycles],
        "starts": [s.to_dict() for s in result.cycles[0].starts],
        "settled": result.settled, "restarts": result.restarts,
        "restart_fall": cfg.restart_fall, "reduction_modes": cfg.reduction_modes,
        "surrogate": cfg.surrogate, "enrich_hz": cfg.enrich_hz,
        "enrich_vectors": cfg.enrich_vectors, "residual": cfg.residual,
        "modal_hz": cfg.modal_hz, "frf_modes": result.frf_modes,
        "exact_gradient": cfg.exact_gradient, "model_dof": result.model.n_dof,
        "seconds": result.seconds, "calibrated_deck": calibrated_deck_name(cfg),
    }  # fmt: skip


def write_report_json(path: str | os.PathLike[str], result: CalibrationResult) -> Path:
    """:func:`report_dict` as an indented JSON file."""
    return write_lines(path, [json.dumps(report_dict(result), indent=1)])


def write_calibrated_deck(deck_path: str | os.PathLike[str], params: list[Parameter],
                          values: np.ndarray, out: str | os.PathLike[str]) -> Path:  # fmt: skip
    """Read the deck again, set the parameters' card fields to ``values`` and write it
    (large field, atomically) to ``out``."""
    from ..deck import read_deck, write_deck  # the edge writes decks; nothing below it

    deck = read_deck(deck_path)
    for par, v in zip(params, np.asarray(values, float), strict=True):
        spec = par.spec
        if spec.kind == "record":
            recs = deck.records[spec.card]
            for i, r in enumerate(recs.items):
                if r.pid == par.id:
                    vals = list(getattr(r, spec.column))
                    vals[spec.index] = float(v)
                    recs.items[i] = replace(r, **{spec.column: tuple(vals)})
            continue
        table = deck.tables[spec.card]
        key = {"property": "pid", "material": "mid", "element": "eid"}[spec.kind]
        rows = np.flatnonzero(table.columns[key] == par.id)
        table.columns[spec.column][rows] = float(v)
    return write_deck(deck, out)


def _table(rows: list[list[str]], head: list[str]) -> str:
    h = "".join(f"<th>{html.escape(x)}</th>" for x in head)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in r) + "</tr>"
                   for r in rows)  # fmt: skip
    return f"<table><tr>{h}</tr>{body}</table>"


def _f(v, spec: str) -> str:
    return "-" if v is None else format(v, spec)


def write_html(path: Path, report: dict, pictures: dict[str, str], mode_pictures: list[str]
               ) -> Path:  # fmt: skip
    """The HTML page: tables of parameters, modes, deviation and runs, and the pictures."""
    def status(p: dict) -> str:
        s = "held" if p["held"] else ("identifiable" if p["identifiable"] else "weakly informed")
        return s + (" (at a bound!)" if p["at_bound"] else "")

    prm = [[p["name"], p["description"], f"{p['card']} {p['id']} {p['field']}",
            _f(p["nominal"], ".6g"), _f(p["calibrated"], ".6g"), f"{100 * p['p']:+.2f}",
            f"[{p['lower']:.6g}, {p['upper']:.6g}]", f"{100 * p['prior_std_p']:.2f}",
            "-" if p["held"] else f"{100 * p['posterior_std_p']:.2f}", f"{p['ratio']:.2f}",
            status(p)] for p in report["parameters"]]  # fmt: skip
    prm_head = ["name", "description", "field", "nominal", "calibrated", "change %", "bounds",
                "prior std %", "posterior std %", "posterior / prior", "status"]  # fmt: skip
    truth = report.get("truth")
    if truth:  # a synthetic test: each parameter's error against its known value
        for row, p in zip(prm, report["parameters"], strict=True):
            row += [_f(p["true"], ".6g"), _f(p["error_pct"], "+.2f"),
                    _f(p["error_over_std"], ".1f")]  # fmt: skip
        prm_head += ["true", "error %", "|error| / posterior std"]
    why = "".join(f"<li><b>{html.escape(p['name'])}</b>: {html.escape(p['reason'])}</li>"
                  for p in report["parameters"])  # fmt: skip
    summary = "".join(f"<li>{html.escape(line)}</li>" for line in report["summary"])
    lik = report["likelihood"]
    modes = [[f"{m['test_hz']:.3f}", _f(m["fe_before_hz"], ".3f"), _f(m["fe_after_hz"], ".3f"),
              _f(m["frequency_error_before_pct"], "+.2f"),
              _f(m["frequency_error_after_pct"], "+.2f"), _f(m["mac_before"], ".4f"),
              _f(m["mac_after"], ".4f")] for m in report["modes"]]  # fmt: skip
    cyc = [[c["cycle"], "multi-start" if c["cycle"] == 1 else
            ("kept" if c["accepted"] else "rejected")
            + (" (search candidate)" if c.get("from_search") else ""),
            _f(c.get("exact_deviation_at_candidate", c.get("exact_deviation_at_center")), ".6g"),
            _f(c.get("rho"), ".2f"), _f(c.get("radius"), ".3g"),
            _f(c.get("moved_informed", c.get("moved")), ".2e"),
            _f(c.get("search_best_deviation"), ".6g") if c.get("searched") else ""]
           for c in report["cycles"]]  # fmt: skip
    starts = [[s["start"] + 1, f"{s['history'][0]:.6g}", f"{s['deviation']:.6g}",
               s["iterations"], f"{s['seconds']:.1f}", s["message"]]
              for s in report["starts"]]  # fmt: skip
    dev = report["deviation"]
    imgs = "".join(f"<h2>{html.escape(t)}</h2><img src='{html.escape(src)}'>"
                   for t, src in pictures.items())  # fmt: skip
    mimgs = "".join(f"<img class='mode' src='{html.escape(s)}'>" for s in mode_pictures)
    deck = html.escape(report["calibrated_deck"])
    page = f"""<!DOCTYPE html><html><head><meta charset="utf-8"><title>femcal calibration</title>
<style>body{{font-family:sans-serif;margin:2em;max-width:1500px}}table{{border-collapse:collapse;
margin:1em 0}}td,th{{border:1px solid #bbb;padding:3px 8px;text-align:right}}th{{background:#eee}}
img{{max-width:100%;display:block;margin:0.5em 0}}img.mode{{max-width:48%;display:inline-block}}
ul.summary{{background:#f4f4f4;padding:0.8em 2em;font-size:1.05em}}
</style></head><body>
<h1>femcal calibration</h1>
<h2>Summary</h2><ul class="summary">{summary}</ul>
<p>Deck {html.escape(report['deck'])}; test {html.escape(report['test'])}; band
{report['band_hz'][0]:g}-{report['band_hz'][1]:g} Hz; metric {report['metric']} at
{report['n_frequencies']} frequencies; damping equalised to zeta0 = {report['zeta0']:.4f};
{len(report['outputs'])} outputs x {len(report['inputs'])} inputs; channels left out:
{html.escape(', '.join(report['excluded_channels']) or 'none')}.
Calibrated deck: <a href="{deck}">{deck}</a>.
Run time {report['seconds']:.0f} s.</p>
<h2>Deviation</h2><p>before {dev['before']:.6g}, after {dev['after']:.6g}
(full model, log10 FRF residuals squared and summed){'' if report['settled'] else
'; the parameters had not settled when the cycles ran out'}.</p>
<h2>Parameters</h2>{_table(prm, prm_head)}
<p>The estimate is the posterior's maximum: the prior is each parameter's standard deviation
(the bounds at {report['prior']['bounds_sigma']:g} standard deviations, or the parameter file's
confidence), the likelihood counts the {lik['residuals']} residuals as
{lik['effective_observations']:.0f} independent observations of sigma {lik['sigma']:.3g}
({'from the nominal model' if lik['estimated'] else 'the given noise level'}). Identifiable:
the posterior standard deviation below {100 * report['posterior']['identifiable_below']:g} % of
the prior's; held: the test cannot narrow the prior by more than
{100 * (1 - report['posterior']['hold_ratio']):g} %.{
f" True values: {html.escape(truth)} (a synthetic test)." if truth else ""}</p>
<ul>{why}</ul>
<h2>Modes</h2>{_table(modes, ["test Hz", "FE before Hz", "FE after Hz", "error before %",
 "error after %", "MAC before", "MAC after"])}
<h2>Runs</h2><p>Cycle 1 runs Levenberg-Marquardt from every start on the nominal model's
surrogate; each later cycle rebuilds the surrogate at the candidate point, where it is the full
model, keeps the step if the full model's cost fell (trust region) and runs LM again inside the
trust radius. When a kept step lowers the cost by less than {
100 * report.get('restart_fall', 0):g} %, or the cycles settle, the multi-start search runs again
on the current surrogate ({report.get('restarts', 0)} times here); a lower minimum elsewhere is
the next candidate.</p>{_table(cyc, ["cycle", "step", "full-model deviation at the candidate",
 "actual / predicted fall", "trust radius", "largest change (informed parameters)",
 "search again: best deviation (surrogate)"])}
{_table(starts, ["start", "deviation at start", "deviation", "iterations", "seconds", "stop"])}
{imgs}<h2>Paired modes after calibration</h2>{mimgs}
</body></html>
"""
    return write_atomic(path, lambda tmp: Path(tmp).write_text(page))


def write_report(result: CalibrationResult, out: str | os.PathLike[str], *,
                 progress: Callable[[str], None] | None = None) -> Path:  # fmt: skip
    """The pictures (``out/pictures``: FRFs, CRLB, history, MAC, paired shapes, renderings of
    the calibrated paired modes) and ``out/report.html``; returns the page's path."""
    from ..viz import calibration as pictures_of
    from ..viz.render import render_modes

    say = progress or (lambda _m: None)
    out = Path(out)
    pics = out / "pictures"
    pics.mkdir(parents=True, exist_ok=True)
    pictures = pictures_of.report_pictures(result, pics)
    say("rendering the calibrated model's paired modes")
    which = sorted({m.fe_after - 1 for m in result.modes if m.fe_after is not None})
    mode_pngs = []
    if which:
        mode_pngs = render_modes(result.modes_after, result.model, pics / "modes",
                                 title="calibrated", which=which, window=(960, 600))  # fmt: skip
    rel = {t: str(p.relative_to(out)) for t, p in pictures.items()}
    page = write_html(out / "report.html", report_dict(result), rel,
                      [str(p.relative_to(out)) for p in mode_pngs])  # fmt: skip
    say(f"wrote {page} and {len(pictures) + len(mode_pngs)} pictures")
    return page
