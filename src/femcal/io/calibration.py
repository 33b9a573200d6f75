"""A calibration's files: ``report.json`` (the typed result as JSON), the calibrated deck
with its changed cards, ``report.html`` and ``report.pdf`` with their pictures
(:mod:`femcal.viz.calibration`, :mod:`femcal.viz.report_pdf`). The page and the PDF can be
sent on alone: a header names femcal's version, when they were made, the command and every
input file with its size and SHA-256 digest, and every figure is numbered, captioned and
embedded (the PNG files in ``pictures/`` are written too, for other tools). Every file is
written atomically."""

from __future__ import annotations

import html
import json
import os
import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..atomic import write_atomic, write_lines
from ..calibrate.augment import AddedElement
from ..calibrate.channels import STANDOUT_FACTOR, SuspectChannel
from ..calibrate.config import Config, Configuration
from ..calibrate.modelform import NOISE_FACTOR, USEFUL_FALL
from ..calibrate.parameters import Parameter
from ..calibrate.result import CalibrationResult, CaseResult, Cycle
from ..correlate import mac_text
from ..model.units import length_unit
from ..parallel.cluster import result_of
from ..parallel.executors import beside
from .html import (
    PAGE_STYLE,
    embedded_figure,
    file_facts,
    html_header,
    html_number,
    html_table,
    provenance,
)
from .identify_page import OWN_BANDS

if TYPE_CHECKING:
    from ..deck.deck import Deck
    from ..viz.report_pdf import ReportTexts


def calibrated_deck_name(conf: Configuration, cfg: Config) -> str:
    """A configuration's calibrated deck's file name: the deck's stem with
    ``_calibrated.bdf``, after the configuration's name where another configuration's deck
    has the same stem."""
    stem = conf.deck.stem
    clash = sum(c.deck.stem == stem for c in cfg.configurations) > 1
    return f"{conf.name}_{stem}_calibrated.bdf" if clash else f"{stem}_calibrated.bdf"


def calibrated_changes_name(deck: str | os.PathLike[str]) -> str:
    """The file name of a calibrated deck's changed cards: its stem with ``.changes.bdf``
    (``hammer_frame_calibrated.changes.bdf``), beside it."""
    return f"{Path(deck).stem}.changes.bdf"


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


def misfit_sigma(case: CaseResult) -> float:
    """The standard deviation of one of a configuration's residuals after calibration (log10
    units)."""
    return float(np.sqrt(case.deviation_after / case.likelihood.m))


def _worst(modes: list[dict], key: str) -> tuple[float, int] | None:
    """(the largest |frequency error| in %, its test mode) of ``key`` (before or after), of
    the paired modes as the report lists them (:func:`_modes`)."""
    errs = [(abs(v), m["test_mode"]) for m in modes
            if (v := m[f"frequency_error_{key}_pct"]) is not None]  # fmt: skip
    return max(errs) if errs else None


def _lowest(modes: list[dict], key: str) -> tuple[float, int] | None:
    """(the lowest MAC, its test mode) of ``key`` (before or after), as :func:`_worst`."""
    macs = [(v, m["test_mode"]) for m in modes if (v := m[f"mac_{key}"]) is not None]
    return min(macs) if macs else None


def verdict_lines(result: CalibrationResult) -> list[str]:
    """What an engineer decides from, first on the page and the console: per configuration
    the worst frequency error and the lowest MAC of the paired modes before and after, the
    misfit before and after; the parameters that moved most; the suspect channels."""
    several = len(result.cases) > 1
    lines = []
    for case in result.cases:
        at = f"{case.name}: " if several else ""
        modes = _modes(case)
        wb, wa = _worst(modes, "before"), _worst(modes, "after")
        lb, la = _lowest(modes, "before"), _lowest(modes, "after")
        paired = sum(m["fe_after_mode"] is not None for m in modes)
        if wb and wa and lb and la:
            lines.append(f"{at}Frequencies: the worst error {wb[0]:.2f} % before (test mode "
                         f"{wb[1]}), {wa[0]:.2f} % after (test mode {wa[1]}); MAC: the lowest "
                         f"{mac_text(lb[0])} before, {mac_text(la[0])} after; {paired} of "
                         f"{len(modes)} test modes paired.")  # fmt: skip
        elif not modes:
            lines.append(f"{at}No identified test modes: the FRFs alone were compared.")
        m = _misfit(case)
        lines.append(f"{at}Misfit (log10 of the FRF; 0.1 is a factor 1.26): root mean square "
                     f"{m['rms_before']:.3g} before, {m['rms_after']:.3g} after"
                     + (f"; typical (robust) {m['typical_before']:.3g} before, "
                        f"{m['typical_after']:.3g} after" if m["typical_after"] is not None
                        else "")
                     + (f"; the test's noise {m['noise']:.2g}." if m["noise"] else "."))
    moved = sorted((r for r in result.parameters if not r.held), key=lambda r: -abs(r.p))[:3]
    if moved:
        lines.append("Moved most: " + ", ".join(
            f"{r.parameter.name} {100 * r.p:+.2f} % (posterior std {100 * r.posterior_std_p:.2g}"
            f" %, {'identifiable' if r.identifiable else 'weakly informed'})"
            for r in moved) + ".")  # fmt: skip
    for case in result.cases:
        at = f"{case.name}: " if several else ""
        lines += [f"{at}Suspect channel (misfit over {STANDOUT_FACTOR:g} times the median "
                  f"channel's): {x.describe()}" for x in case.suspects]
    return lines


def summary_lines(result: CalibrationResult) -> list[str]:
    """The trust summary that leads the report and ends the console output: the verdict
    (:func:`verdict_lines`), whether the search settled, what was calibrated, held,
    identifiable or left on a bound, and whether the misfit points at something the model
    lacks."""
    rs = result.parameters
    held = [r.parameter.name for r in rs if r.held]
    ident = [r.parameter.name for r in rs if r.identifiable]
    bound = [r.parameter.name for r in rs if r.at_bound]
    lines = verdict_lines(result)
    lines += [("The search settled: the identifiable parameters stopped moving." if result.settled
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
    several = len(result.cases) > 1
    for case in result.cases:
        form = case.model_form
        if form is None:
            continue
        at = f"{case.name}: " if several else ""
        noise = form.noise_sigma
        if form.warning:
            lines.append(f"{at}Model-form warning: the typical misfit after calibration "
                         f"(robust standard deviation {form.typical_after:.3g} in log10) is "
                         f"{form.typical_after / noise:.3g} times the test's noise "
                         f"({noise:.2g}): the model lacks something the structure has, which "
                         "the parameters cannot stand for without bias.")  # fmt: skip
            useful = [c for c in form.candidates if c.fall >= USEFUL_FALL]
            if useful:
                lines.append(f"{at}Where: {useful[0].describe()} would remove about "
                             f"{100 * useful[0].fall:.0f} % of it (see the model-form "
                             "section).")  # fmt: skip
        elif noise is not None:
            lines.append(f"{at}The typical misfit after calibration (robust standard deviation "
                         f"{form.typical_after:.3g} in log10) is {form.typical_after / noise:.3g} "
                         f"times the test's noise ({noise:.2g}): within {NOISE_FACTOR:g} times, "
                         "no sign of a feature the model lacks (one the parameters can mimic "
                         "does not show in the misfit; the held-out prediction tests for "
                         "that)."
                         + (f" No missing element stands out either: the best removes "
                            f"{100 * form.candidates[0].fall:.1f} % of the remaining "
                            "deviation." if form.candidates
                            and form.candidates[0].fall < USEFUL_FALL else ""))  # fmt: skip
    ho = result.holdout
    if ho is not None:
        what = {"inputs": "each input's FRFs", "sensors": "each group of sensors",
                "configurations": "each configuration"}[ho.kind]  # fmt: skip
        worse = [f.name for f in ho.folds if not f.better]
        if ho.better:
            lines.append(f"Held-out prediction: calibrated without {what} in turn, the model "
                         "predicts the held-out data better than the nominal one (deviation "
                         f"{ho.deviation_calibrated:.5g} against {ho.deviation_nominal:.5g})"
                         + (f", though not for {', '.join(worse)}." if worse else "."))
        else:
            lines.append(f"Warning: calibrated without {what} in turn, the model predicts the "
                         "held-out data worse than the nominal one (deviation "
                         f"{ho.deviation_calibrated:.5g} against {ho.deviation_nominal:.5g}): "
                         "the calibrated values fit this test rather than the structure.")
    lines.append(f"Deviation (the sum of the squared log10 residuals, no unit; 0 is a perfect "
                 f"fit) {result.deviation_before:.6g} before, {result.deviation_after:.6g} "
                 "after.")  # fmt: skip
    if result.augmented is not None:
        lines += augmented_lines(result)
    if result.augment_error is not None:
        lines.append(f"Model form: the element the search named could not be added to the "
                     f"deck and calibrated ({result.augment_error}); add it by hand as the "
                     "model-form section says.")  # fmt: skip
    return lines


def augmented_lines(result: CalibrationResult) -> list[str]:
    """The summary's lines on the calibration run again with the model-form element added:
    what was added, what it was calibrated to, and whether the data prefer it."""
    a = result.augmented
    if a is None:
        return []
    r = a.result
    par, row = a.added.parameter, a.parameter_result
    status = ("held: the test cannot inform it" if row.held else
              f"posterior std {row.posterior_std:.2g}, "
              + ("identifiable" if row.identifiable else "weakly informed"))  # fmt: skip
    lines = [f"Model form tested: the calibration ran again with {a.added.describe()} added "
             f"as parameter {par.name}. It was calibrated to {row.calibrated:.4g} ({status}"
             f"{', at a bound' if row.at_bound else ''}); the deviation after calibration is "
             f"{r.deviation_after:.6g} with it, {result.deviation_after:.6g} without; "
             f"{a.reason}."]  # fmt: skip
    if a.better:
        lines.append(f"The data prefer the model with the added element: its calibration is "
                     f"in {AUGMENTED_FOLDER}/ (report.json, the deck with the element and its "
                     "calibrated copy). Look on the structure for what it stands for (a "
                     "component, a mount, a support) and model that"
                     + ("; its model-form warning remains, so something else is missing too."
                        if a.warning_remains else "."))  # fmt: skip
    elif a.better is None:
        lines.append(f"Whether the data prefer the model with the added element is not "
                     f"judged (no held-out data): both calibrations are reported, its own in "
                     f"{AUGMENTED_FOLDER}/; validate on held-out data (holdout) to decide.")
    else:
        lines.append("The data do not prefer the model with the added element: the "
                     "calibration without it stands, and the misfit has another cause (see "
                     "the model-form section).")  # fmt: skip
    return lines


def _modes(case: CaseResult) -> list[dict]:
    return [{"test_mode": m.test_mode, "test_hz": m.test_hz, "fe_before_mode": m.fe_before,
             "fe_before_hz": m.fe_before_hz, "mac_before": m.mac_before,
             "fe_after_mode": m.fe_after, "fe_after_hz": m.fe_after_hz,
             "mac_after": m.mac_after,
             "frequency_error_before_pct": m.frequency_error_before_pct,
             "frequency_error_after_pct": m.frequency_error_after_pct,
             "pseudo_orthogonality_after": m.pseudo_orthogonality_after}
            for m in case.modes]  # fmt: skip


def _model_form(case: CaseResult) -> dict | None:
    """A configuration's model-form diagnostics as the report lists them."""
    form = case.model_form
    if form is None:
        return None
    edges = form.band_edges_hz
    return {
        "length_unit": length_unit(case.model),
        "noise_sigma": form.noise_sigma, "misfit_before": form.misfit_before,
        "misfit_after": form.misfit_after, "typical_misfit_before": form.typical_before,
        "typical_misfit_after": form.typical_after, "warning": form.warning,
        "suggestions": list(form.suggestions),
        "outputs": [{"channel": ch.label, "name": case.channel_names.get(ch.label),
                     "rms_before": float(form.output_rms_before[o]),
                     "rms_after": float(form.output_rms_after[o]),
                     "typical_before": float(form.output_typical_before[o]),
                     "typical_after": float(form.output_typical_after[o])}
                    for o, ch in enumerate(case.outputs)],
        "bands": [{"band_hz": [float(edges[k]), float(edges[k + 1])],
                   "rms_before": _finite(form.band_rms_before[k]),
                   "rms_after": _finite(form.band_rms_after[k]),
                   "typical_before": _finite(form.band_typical_before[k]),
                   "typical_after": _finite(form.band_typical_after[k])}
                  for k in range(len(edges) - 1)],
        "candidates": [{"kind": c.kind, "grid": c.grid, "component": c.component,
                        "xyz": [float(x) for x in c.xyz], "fall": c.fall, "value": c.value,
                        "unit": c.unit, "text": c.describe()} for c in form.candidates],
    }  # fmt: skip


def _holdout(result: CalibrationResult) -> dict | None:
    """The hold-out validation as the report lists it."""
    ho = result.holdout
    if ho is None:
        return None
    names = [p.name for p in result.params]
    return {"kind": ho.kind, "deviation_nominal": ho.deviation_nominal,
            "deviation_calibrated": ho.deviation_calibrated, "better": ho.better,
            "folds": [{"name": f.name, "configuration": result.cases[f.case].name,
                       "residuals": int(f.rows.sum()),
                       "deviation_nominal": f.deviation_nominal,
                       "deviation_calibrated": f.deviation_calibrated, "better": f.better,
                       "p": {n: float(x) for n, x, h in zip(names, f.p, f.held, strict=True)
                             if not h}} for f in ho.folds]}  # fmt: skip


def _misfit(case: CaseResult) -> dict:
    """The configuration's misfit in log10 of the FRF, by one definition each: the root mean
    square of the residuals (what the deviation sums), and the typical residual (the robust
    standard deviation, which a few bad channels or antiresonances do not move)."""
    m = case.likelihood.m
    form = case.model_form
    return {"rms_before": float(np.sqrt(case.deviation_before / m)),
            "rms_after": misfit_sigma(case),
            "typical_before": form.typical_before if form else None,
            "typical_after": form.typical_after if form else None,
            "noise": form.noise_sigma if form else None}  # fmt: skip


def _suspect(s: SuspectChannel) -> dict:
    """A suspect channel as the report lists it."""
    return {"channel": s.label, "name": s.name, "misfit_before": _finite(s.misfit_before),
            "misfit_after": s.misfit_after, "median_before": _finite(s.median_before),
            "median_after": s.median_after, "level": s.level, "reasons": list(s.reasons),
            "notes": list(s.notes), "worse_after": s.worse_after,
            "out_before": s.out_before, "out_after": s.out_after,
            "text": s.describe(), "brief": s.brief()}  # fmt: skip


def _configuration(conf: Configuration, case: CaseResult, cfg: Config) -> dict:
    """One configuration's part of the report."""
    lk = case.likelihood
    return {
        "name": case.name, "deck": str(conf.deck), "parameters_file": str(conf.parameters),
        "test": str(conf.test_frf or conf.test_model),
        "truth": str(conf.test_truth) if conf.test_truth is not None else None,
        "band_hz": list(case.band), "zeta0": case.zeta0, "n_frequencies": len(case.freq),
        "identify_band_hz": ([float(x) for x in case.identified.band]
                             if case.identified is not None else None),
        "outputs": [c.label for c in case.outputs], "inputs": [c.label for c in case.inputs],
        "excluded_channels": [c.label for c in case.excluded],
        "parameters": [int(i) for i in case.index], "modes": _modes(case),
        "deviation": {"before": case.deviation_before, "after": case.deviation_after},
        "likelihood": {"sigma": lk.sigma, "residuals": lk.m,
                       "effective_observations": lk.n_eff, "estimated": lk.estimated,
                       "misfit_sigma_after": misfit_sigma(case),
                       "noise_sigma": case.model_form.noise_sigma if case.model_form else None},
        "misfit": _misfit(case),
        "suspects": [_suspect(x) for x in case.suspects],
        "model_form": _model_form(case),
        "frf_modes": case.frf_modes, "model_dof": case.model.n_dof,
        "calibrated_deck": calibrated_deck_name(conf, cfg),
    }  # fmt: skip


def report_dict(result: CalibrationResult) -> dict:
    """``report.json``'s content: the trust summary, every parameter (nominal, calibrated,
    bounds, held or identifiable and why, prior and posterior standard deviations, at a
    bound, and the error against the truth of a synthetic test), per configuration its test,
    channels, paired modes, deviation and likelihood, the prior, the posterior's bands and
    correlation, the settings, the cycles and the first cycle's starts."""
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
    post = result.posterior
    summary = summary_lines(result)
    return {
        "summary": summary, "trust": summary[len(verdict_lines(result)):],
        "metric": cfg.metric, "loss": cfg.loss,
        "huber_c": cfg.huber_c if cfg.loss == "huber" else None,
        "configurations": [_configuration(conf, case, cfg) for conf, case
                           in zip(cfg.configurations, result.cases, strict=True)],
        "parameters": params, "holdout": _holdout(result),
        "deviation": {"before": result.deviation_before, "after": result.deviation_after,
                      "surrogate_history": [c.deviation for c in result.cycles]},
        "prior": {"bounds_sigma": cfg.bounds_sigma,
                  "std_p": [float(x) for x in result.prior.std],
                  "from_confidence": [bool(x) for x in result.prior.from_confidence]},
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
        "modal_hz": cfg.modal_hz, "exact_gradient": cfg.exact_gradient,
        "augment_fall": cfg.augment_fall, "augmented": _augmented(result),
        "augment_error": result.augment_error,
        "seconds": result.seconds,
    }  # fmt: skip


#: The folder of a calibration's output that holds its run with the model-form element added
#: (:mod:`femcal.jobs.calibration`).
AUGMENTED_FOLDER = "augmented"


def _augmented(result: CalibrationResult) -> dict | None:
    """report.json's account of the calibration with the model-form element added."""
    a = result.augmented
    if a is None:
        return None
    r = a.result
    par, row = a.added.parameter, a.parameter_result
    c = a.added.candidate
    ho = r.holdout
    return {
        "configuration": a.added.configuration, "element": a.added.describe(),
        "kind": c.kind, "grid": c.grid, "component": c.component,
        "xyz": [float(x) for x in c.xyz], "search_fall": c.fall,
        "cards": element_cards(a.added), "deck": f"{AUGMENTED_FOLDER}/{a.deck.name}",
        "report": f"{AUGMENTED_FOLDER}/report.json",
        "parameter": {"name": par.name, "card": par.card, "id": par.id, "field": par.field,
                      "nominal": par.nominal, "lower": par.lower, "upper": par.upper,
                      "calibrated": row.calibrated, "held": row.held,
                      "identifiable": row.identifiable, "at_bound": row.at_bound,
                      "posterior_std": row.posterior_std},
        "deviation_after": r.deviation_after,
        "heldout_calibrated": ho.deviation_calibrated if ho else None,
        "model_form_warning": a.warning_remains,
        "better": a.better, "reason": a.reason,
        "parameters": {q.parameter.name: q.calibrated for q in r.parameters},
    }  # fmt: skip


def write_report_json(path: str | os.PathLike[str], result: CalibrationResult) -> Path:
    """:func:`report_dict` as an indented JSON file."""
    return write_lines(path, [json.dumps(report_dict(result), indent=1)])


def write_calibrated_deck(deck_path: str | os.PathLike[str], params: list[Parameter],
                          values: np.ndarray, out: str | os.PathLike[str], *,
                          config: str | os.PathLike[str] | None = None,
                          version: str | None = None,
                          keep: Iterable[str | os.PathLike[str]] = ()) -> list[Path]:  # fmt: skip
    """Write the deck with the parameters' card fields set to ``values`` to ``out``: the
    engineer's deck with those fields' text changed and every other byte kept
    (:mod:`femcal.deck.edit`: INCLUDE files holding a changed card are written beside it, the
    INCLUDEs pointed at them), a header of comments at its top (femcal's ``version``, today's
    date, the ``config`` file, how many fields and cards changed), and the changed cards
    alone in :func:`calibrated_changes_name` beside it. Each value takes as many significant
    digits as its field holds (at most 7 in an 8-character field, 10 in a 16-character one;
    fewer where an exponent takes room: ``.0021999``); a value that reads as the deck's own is
    left as written. ``keep`` are files an INCLUDE copy must not write over
    (another configuration's, written into the same folder before). Every file is written
    atomically. Returns the files written, ``out`` first.

    Raises
    ------
    DeckEditError
        Naming file:line, card, id and field, for a field that is not where the deck says or a
        value that does not fit it (a ValueError too).
    """
    import datetime

    from .. import __version__
    from ..deck.edit import FieldEdit, edit_deck, write_edited_deck

    out = Path(out)
    edits = [FieldEdit(p.card, p.id, p.field, float(v), p.name)
             for p, v in zip(params, np.asarray(values, float), strict=True)]  # fmt: skip
    edited = edit_deck(deck_path, edits)
    changes = out.with_name(calibrated_changes_name(out))
    n_cards = len(edited.cards)
    header = [f"$ femcal {version or __version__} calibrated deck, "
              f"{datetime.date.today().isoformat()}",
              *([f"$ config: {config}"] if config is not None else []),
              f"$ changed: {len(edited.changes)} field{'s' * (len(edited.changes) != 1)} on "
              f"{n_cards} card{'s' * (n_cards != 1)} (see {changes.name})"]  # fmt: skip
    return write_edited_deck(edited, out, header=header, changes=changes, tag="calibrated",
                             keep=keep)  # fmt: skip


def element_cards(added: AddedElement) -> list[str]:
    """The bulk data lines (small free field) of an added element: ``CONM2,eid,grid,,M``, or
    ``CELAS1,eid,pid,grid,C`` and ``PELAS,pid,K``."""
    from ..deck.edit import format_real

    value = format_real(added.parameter.nominal, 8)
    c = added.candidate
    if c.kind == "point mass":
        return [f"CONM2,{added.element_id},{c.grid},,{value}"]
    return [f"CELAS1,{added.element_id},{added.property_id},{c.grid},{c.component}",
            f"PELAS,{added.property_id},{value}"]  # fmt: skip


def unread_card_ids(deck: Deck) -> tuple[list[int], list[int]]:
    """The ids of the deck's cards femcal reads but does not model (dampers, gaps, plot
    elements, rigid elements of other kinds and their properties): (element ids, property
    ids), so that an added element takes neither. Generous: any unread card named C... (not
    CORD...), R... or PLOTEL with a whole number first is taken as an element, any P... as a
    property; a number taken for nothing only moves the new id up."""
    elements: list[int] = []
    properties: list[int] = []
    for card in deck.unused.items:
        first = card.fields[0].strip() if card.fields else ""
        if not first.isdigit():
            continue
        name = card.name.upper()
        if name.startswith("P") and name != "PLOTEL":
            properties.append(int(first))
        elif name.startswith(("C", "R", "PLOTEL")) and not name.startswith("CORD"):
            elements.append(int(first))
    return elements, properties


def field_value(value: float) -> float:
    """``value`` as a small free field holds it (7 significant digits at most): an added
    element's size before it is written, so that its parameter's nominal is the deck's."""
    from ..deck.edit import format_real
    from ..deck.fields import parse_real

    return parse_real(format_real(value, 8))


def write_augmented_deck(deck_path: str | os.PathLike[str], cards: Iterable[str],
                         out: str | os.PathLike[str], *, why: str = "",
                         deck: Deck | None = None) -> Path:  # fmt: skip
    """Write the deck at ``deck_path`` to ``out`` with the bulk data lines ``cards`` added
    before its ENDDATA (every other byte kept; its INCLUDEs pointed at the deck's own files
    from ``out``'s folder) and a header of comments saying what was added and ``why``: no
    date, so that the same element makes the same file (its content enters the resume
    fingerprint). ``deck``: the deck as read from ``deck_path`` (read here when not given).
    Atomic; returns ``out``.

    Raises
    ------
    DeckEditError
        When ``out`` would replace one of the deck's own files, or an INCLUDE cannot name
        its file from there (a ValueError too).
    """
    from ..deck.edit import edit_deck, write_edited_deck

    cards = list(cards)
    header = ["$ femcal: the deck with the model-form element added",
              f"$ from: {Path(deck_path).name}",
              *([f"$ why: {why}"] if why else []),
              *(f"$ added: {c}" for c in cards)]  # fmt: skip
    return write_edited_deck(edit_deck(deck_path, [], deck=deck), out, header=header,
                             tag="augmented", added=cards)[0]  # fmt: skip


_table, _f = html_table, html_number


@dataclass(frozen=True)
class ReportFigure:
    """A figure of the report as the page and the PDF show it: its number (in the page's
    order), title, PNG file, caption, the configuration it belongs to (None: the whole
    calibration) and whether it is a rendering of a calibrated mode (shown two by two)."""

    number: int
    title: str
    path: Path
    caption: str
    case: str | None = None
    mode: bool = False


def _figure(f: ReportFigure) -> str:
    return embedded_figure(f.title, f.path, f.caption, number=f.number,
                           css_class="mode" if f.mode else "")  # fmt: skip


def report_inputs(result: CalibrationResult) -> list[dict]:
    """The files a calibration read, for the report's header (:func:`femcal.io.html.file_facts`:
    role, path, size, SHA-256): the configuration file, and per configuration its deck, the
    files the deck INCLUDEs, the parameter, test, sensor, input and truth files; each file
    once, with every role it has (``bare: deck, loaded: deck``)."""
    cfg = result.config
    several = len(cfg.configurations) > 1
    seen: dict[str, dict] = {}
    out: list[dict] = []

    def add(role: str, path: object, must: bool = True) -> None:
        """``must``: listed even when it cannot be read (else only an existing file)."""
        if path is None:
            return
        key = os.path.abspath(str(path))
        if key in seen:
            if role not in seen[key]["role"].split(", "):
                seen[key]["role"] += f", {role}"
            return
        if not must and not os.path.isfile(key):
            return
        seen[key] = file_facts(role, path)
        out.append(seen[key])

    add("configuration", cfg.path, must=False)
    for conf, case in zip(cfg.configurations, result.cases, strict=True):
        at = f"{conf.name}: " if several else ""
        add(f"{at}deck", conf.deck)
        deck = os.path.abspath(conf.deck)
        for f in case.model.files:
            if os.path.abspath(f) != deck:
                add(f"{at}deck INCLUDE", f, must=False)
        add(f"{at}parameters", conf.parameters)
        add(f"{at}test FRFs", conf.test_frf)
        add(f"{at}test model", conf.test_model)
        add(f"{at}sensors", conf.sensors)
        add(f"{at}inputs", conf.inputs)
        add(f"{at}truth", conf.test_truth)
    return out


def model_form_tables(form: dict) -> list[tuple[str, list[str], list[list[str]]]]:
    """The model-form tables, each (what it shows, header, rows): the residual by band, the
    channels that fit worst, the missing-element candidates (if any)."""
    bands = [[f"{b['band_hz'][0]:.1f}-{b['band_hz'][1]:.1f}", _f(b["typical_before"], ".3g"),
              _f(b["typical_after"], ".3g"), _f(b["rms_after"], ".3g")]
             for b in form["bands"]]  # fmt: skip
    worst = sorted(form["outputs"], key=lambda o: -o["typical_after"])[:8]
    outs = [[o["name"] or o["channel"], o["channel"], f"{o['typical_before']:.3g}",
             f"{o['typical_after']:.3g}", f"{o['rms_after']:.3g}"] for o in worst]  # fmt: skip
    cands = [[c["kind"], str(c["grid"]), str(c["component"] or "1-3"),
              ", ".join(f"{x:.6g}" for x in c["xyz"]),
              f"{c['value']:.3g}" + (f" {c['unit']}" if c.get("unit") else ""),
              f"{100 * c['fall']:.1f}"] for c in form["candidates"]]  # fmt: skip
    out = [("The residual (log10) by band: its typical size (robust standard deviation) before "
            "and after calibration, what the warning sets against the test's noise "
            f"({_f(form['noise_sigma'], '.2g')}), and its root mean square after (dominated by "
            "the antiresonances):", ["band Hz", "typical before", "typical after", "RMS after"],
            bands),
           ("The channels that fit worst after calibration (by the typical residual):",
            ["sensor", "channel", "typical before", "typical after", "RMS after"], outs)]
    if cands:
        stands_out = form["candidates"][0]["fall"] >= USEFUL_FALL
        what = ("Missing elements the misfit asks for most" if form["warning"] and stands_out
                else "For reference only: the single elements that would lower the misfit "
                "most" + ("; none stands out" if not stands_out else "; with no model-form "
                          "warning they are no evidence of a missing feature"))  # fmt: skip
        out.append((f"{what} (each added exactly to the calibrated model and sized to lower "
                    "the Huber-weighted deviation most; one that removes less than "
                    f"{100 * USEFUL_FALL:g} % points at nothing):",
                    ["element", "grid", "component",
                     "x, y, z" + (f" ({form['length_unit']})" if form.get("length_unit") else ""),
                     "size", "misfit removed %"], cands))  # fmt: skip
    return out


def _model_form_html(form: dict | None) -> str:
    """The model-form part of a configuration's section: what the misfit says, by band, the
    worst sensors, the missing-element candidates."""
    if form is None:
        return ""
    says = "".join(f"<li>{html.escape(x)}</li>" for x in form["suggestions"])
    return f"<h3>Model form</h3><ul>{says}</ul>" + "".join(
        f"<p>{html.escape(text)}</p>{_table(rows, head)}"
        for text, head, rows in model_form_tables(form))


#: The held-out validation table's header.
HOLDOUT_HEAD = ["held out", "residuals", "deviation, nominal",
                "deviation, calibrated without it", ""]  # fmt: skip


def holdout_parts(ho: dict) -> tuple[str, list[list[str]]]:
    """The held-out validation's text and table rows."""
    what = {"inputs": "each input's FRFs", "sensors": "each group of sensor positions",
            "configurations": "each configuration"}[ho["kind"]]  # fmt: skip
    rows = [[f["name"], str(f["residuals"]), f"{f['deviation_nominal']:.6g}",
             f"{f['deviation_calibrated']:.6g}", "better" if f["better"] else "WORSE"]
            for f in ho["folds"]]  # fmt: skip
    verdict = ("better" if ho["better"] else
               "WORSE: the calibrated values fit this test rather than the structure")
    return (f"The calibration was repeated without {what} in turn (likelihood, held parameters "
            "and search as for the whole test), and the full model at those parameters "
            "predicts the held-out residuals; the nominal model's deviation on them is the "
            f"reference. In all: {ho['deviation_calibrated']:.6g} calibrated against "
            f"{ho['deviation_nominal']:.6g} nominal ({verdict}).", rows)  # fmt: skip


def _holdout_html(ho: dict | None) -> str:
    """The hold-out validation's section."""
    if ho is None:
        return ""
    text, rows = holdout_parts(ho)
    return (f"<h2 id='holdout'>Validation on held-out data</h2><p>{html.escape(text)}</p>"
            + _table(rows, HOLDOUT_HEAD))


def _augmented_html(report: dict) -> str:
    """The section on the calibration run again with the model-form element added: the
    element, and each parameter without and with it."""
    a = report.get("augmented")
    if a is None:
        return ""
    q = a["parameter"]
    first = {p["name"]: p for p in report["parameters"]}
    rows = [[name, _f(first[name]["calibrated"], ".6g") if name in first else "(not in the model)",
             _f(value, ".6g")] for name, value in a["parameters"].items()]  # fmt: skip
    cards = "<br>".join(html.escape(c) for c in a["cards"])
    verdict = {True: "The data prefer the model with it",
               False: "The data do not prefer it: the calibration without it stands",
               None: "Not judged: no held-out data"}[a["better"]]  # fmt: skip
    return f"""<h2>Model form tested: the calibration with the missing element added</h2>
<p>The model-form search named {html.escape(a['element'])} in configuration
{html.escape(a['configuration'])}, removing about {100 * a['search_fall']:.0f} % of the
deviation left after calibration. It was added to the deck (<code>{cards}</code>, in
<code>{html.escape(a['deck'])}</code>) with parameter <b>{html.escape(q['name'])}</b> on its
{html.escape(q['card'])} {html.escape(q['field'])} (bounds {q['lower']:.4g} to {q['upper']:.4g})
and the calibration ran again: {html.escape(q['name'])} = {q['calibrated']:.4g}; deviation after
calibration {a['deviation_after']:.6g} against {report['deviation']['after']:.6g} without;
{html.escape(a['reason'])}. <b>{verdict}</b>{
'; its model-form warning remains' if a['model_form_warning'] else ''}. Its own report:
<code>{html.escape(a['report'])}</code>.</p>
{_table(rows, ["parameter", "calibrated without it", "calibrated with it"])}"""


def test_text(c: dict) -> str:
    """A configuration's test, as the page and the PDF say it."""
    return (f"Deck {c['deck']}; test {c['test']}; band {c['band_hz'][0]:g}-"
            f"{c['band_hz'][1]:g} Hz at {c['n_frequencies']} frequencies; damping equalised "
            f"to zeta0 = {c['zeta0']:.4f}; {len(c['outputs'])} outputs x {len(c['inputs'])} "
            f"inputs; channels left out: {', '.join(c['excluded_channels']) or 'none'}. "
            + (f"The test's modes and suspect channels come from its identification over "
               f"{c['identify_band_hz'][0]:g}-{c['identify_band_hz'][1]:g} Hz ({OWN_BANDS}). "
               if c.get("identify_band_hz") else "")
            + f"Calibrated deck: {c['calibrated_deck']} (beside this report).")  # fmt: skip


def misfit_text(c: dict) -> str:
    """A configuration's misfit, each quantity once and defined where it is given."""
    m, lk = c["misfit"], c["likelihood"]
    typical = ("" if m["typical_after"] is None else
               f"; typical (the robust standard deviation, 1.4826 times the median "
               f"residual's size, which a few bad channels or antiresonances do not move) "
               f"{m['typical_before']:.3g} before, {m['typical_after']:.3g} after")  # fmt: skip
    noise = ("" if m["noise"] is None else
             f"; the test's noise (the measured FRFs' scatter about the identified model) "
             f"{m['noise']:.2g}")  # fmt: skip
    weigh = (" (estimated: the root mean square of the residuals at the nominal model as the "
             "loss counts them)" if lk["estimated"] else " (the given noise level)")
    return (f"Misfit, in log10 of the FRF (0.1 is a factor 1.26, 1 a factor 10): root mean "
            f"square {m['rms_before']:.3g} before, {m['rms_after']:.3g} after calibration"
            f"{typical}{noise}. The deviation, the sum of the {lk['residuals']} squared "
            f"residuals (no unit): {c['deviation']['before']:.6g} before, "
            f"{c['deviation']['after']:.6g} after. The likelihood weighs each residual with "
            f"sigma = {lk['sigma']:.3g}{weigh} and counts the residuals as "
            f"{lk['effective_observations']:.0f} independent observations.")  # fmt: skip


def suspects_text(c: dict) -> str:
    """What the suspect-channel table shows, or that no channel stands out."""
    sus = c.get("suspects") or []
    if not sus:
        return (f"No channel stands out (none has a misfit over {STANDOUT_FACTOR:g} times the "
                "median channel's).")  # fmt: skip
    return (f"Channels whose misfit (root mean square, log10) is over {STANDOUT_FACTOR:g} "
            f"times the median channel's ({_f(sus[0]['median_before'], '.3g')} before, "
            f"{sus[0]['median_after']:.3g} after calibration), with the likely reason: each "
            "alternative (the test's level as a constant factor, the opposite sign, another "
            "axis, a nearby grid) is tried on the calibrated model and given where it removes "
            "at least half of the misfit. A wrong channel pulls the parameters: check it, or "
            "leave it out and calibrate again.")  # fmt: skip


#: The suspect-channel table's header.
SUSPECT_HEAD = ["sensor", "channel", "misfit before", "misfit after", "test / model level",
                "likely reason", "also"]  # fmt: skip


def suspect_rows(c: dict) -> list[list[str]]:
    """The suspect-channel table's rows."""
    return [[x["name"] or "-", x["channel"], _f(x["misfit_before"], ".3g"),
             f"{x['misfit_after']:.3g}", f"{x['level']:.3g}",
             "; ".join(x["reasons"]) or "no simple mistake explains it",
             "; ".join(x["notes"])] for x in c.get("suspects") or []]  # fmt: skip


def _misfit_html(c: dict) -> str:
    return f"<p>{html.escape(misfit_text(c))}</p>{_suspects_html(c)}"


def _suspects_html(c: dict) -> str:
    """The configuration's suspect channels, or that none stands out."""
    if not c.get("suspects"):
        return f"<p>{html.escape(suspects_text(c))}</p>"
    return (f"<h3 id='suspects-{html.escape(c['name'])}'>Suspect channels</h3>"
            f"<p>{html.escape(suspects_text(c))}</p>{_table(suspect_rows(c), SUSPECT_HEAD)}")


def _configuration_html(c: dict, figures: list[ReportFigure], several: bool,
                        viewer: str = "") -> str:  # fmt: skip
    """One configuration's section: its test, deviation, modes and figures (the calibrated
    paired modes last: ``viewer``, the 3-D viewer's block, then their renderings)."""
    modes = [[f"{m['test_hz']:.3f}", _f(m["fe_before_hz"], ".3f"), _f(m["fe_after_hz"], ".3f"),
              _f(m["frequency_error_before_pct"], "+.2f"),
              _f(m["frequency_error_after_pct"], "+.2f"), _f(m["mac_before"], ".4f"),
              _f(m["mac_after"], ".4f")] for m in c["modes"]]  # fmt: skip
    anchor = f"test-{html.escape(c['name'])}"
    head = (f"<h2 id='{anchor}'>Configuration {html.escape(c['name'])}</h2>" if several
            else f"<h2 id='{anchor}'>Test</h2>")  # fmt: skip
    return f"""{head}
<p>{html.escape(test_text(c))}</p>
{_misfit_html(c)}
<h3>Paired modes</h3>{_table(modes, ["test Hz", "FE before Hz", "FE after Hz", "error before %",
 "error after %", "MAC before", "MAC after"]) + "<p>Frequency error: (test - FE) / FE.</p>"
 if modes else "<p>No identified test modes (raw FRFs compared).</p>"}
{_model_form_html(c.get("model_form"))}
{''.join(_figure(f) for f in figures if not f.mode)}
{'<h3>Paired modes after calibration</h3>' if viewer or any(f.mode for f in figures)
 else ''}{_viewer_html(viewer)}{''.join(_figure(f) for f in figures if f.mode)}
"""


def _viewer_html(block: str) -> str:
    if not block:
        return ""
    return ("<p>Each pair animated on the calibrated model, coloured by the deflection drawn: "
            "the test shape at the sensors in red (made real and scaled to the FE shape by "
            "the modal scale factor) over the FE shape as the same channels see it in blue. "
            "Choose the pair above the drawing; drag to turn, click a sensor or grid for "
            f"its motion.</p>{block}")


def paired_viewer(case: CaseResult, n: int = 0) -> str:
    """The 3-D viewer (:mod:`femcal.viz.pair_view`) of a configuration's test modes and the
    calibrated model's modes paired with them, as the ``n``-th viewer of its page; ``""``
    without pairs."""
    from ..response.frf import channel_matrix
    from ..viz.pair_view import ShapePair, paired_modes_block
    from ..viz.webview import free_rigid_motions, viewer_mesh
    from .modes import basic_translations

    paired = [m for m in case.modes if m.fe_after is not None]
    if not paired:
        return ""
    modes, model = case.modes_after, case.model
    fe = np.asarray(channel_matrix(model, case.outputs) @ modes.shapes)
    pairs = [ShapePair(m.test_mode, m.test_hz, m.fe_after, float(m.fe_after_hz),
                       float(m.mac_after), case.test_shapes[:, m.test_mode - 1],
                       fe[:, m.fe_after - 1]) for m in paired]  # fmt: skip
    grids = np.flatnonzero(model.is_grid)

    def translations(columns: list[int]) -> np.ndarray:
        some = replace(modes, shapes=modes.shapes[:, columns])
        return np.moveaxis(basic_translations(some, model)[grids], 2, 0)

    return paired_modes_block(viewer_mesh(model), model.cd_frames[grids], translations,
                              modes.frequencies_hz, case.outputs, pairs, case.channel_names,
                              title=f"calibrated model ({case.name})", n=n,
                              free_rigid=free_rigid_motions(modes, model))  # fmt: skip


def _before_after(c: dict) -> list[list[str]]:
    """The verdict table's rows of one configuration: what before, what after."""
    modes = c["modes"]

    def worst(key: str) -> str:
        w = _worst(modes, key)
        return "-" if w is None else f"{w[0]:.2f} % (test mode {w[1]})"

    def lowest(key: str) -> str:
        low = _lowest(modes, key)
        return "-" if low is None else f"{mac_text(low[0])} (test mode {low[1]})"

    def paired(key: str) -> str:
        return f"{sum(m[f'fe_{key}_mode'] is not None for m in modes)} of {len(modes)}"

    m = c["misfit"]
    rows = [["worst frequency error", worst("before"), worst("after")],
            ["lowest MAC", lowest("before"), lowest("after")],
            ["test modes paired", paired("before"), paired("after")]] if modes else []
    rows += [["misfit, root mean square (log10)", f"{m['rms_before']:.3g}",
              f"{m['rms_after']:.3g}"]]  # fmt: skip
    if m["typical_after"] is not None:
        rows.append(["misfit, typical (log10, robust)", f"{m['typical_before']:.3g}",
                     f"{m['typical_after']:.3g}"])  # fmt: skip
    sus = c.get("suspects") or []
    rows.append(["suspect channels", str(sum(x["out_before"] for x in sus)),
                 str(sum(x["out_after"] for x in sus))])
    return rows


@dataclass(frozen=True)
class Verdict:
    """The verdict's parts, plain text, for the page and the PDF alike.

    tables : per configuration (its name, rows of [what, before, after]).
    moved : the parameters that moved most, as one sentence.
    doubts : what to doubt: suspect channels, weakly informed and held parameters, warnings.
    rest : the rest of the trust summary.
    """

    tables: list[tuple[str, list[list[str]]]]
    moved: str
    doubts: list[str]
    rest: list[str]


#: The verdict table's header.
VERDICT_HEAD = ["", "before calibration", "after calibration"]


def _is_warning(line: str) -> bool:
    """A summary line that belongs with the doubts: a warning, or where the model-form
    warning points (``Where: ...``, after a configuration's name where there are several)."""
    return (line.startswith("Warning") or "warning" in line.split(":")[0]
            or re.match(r"^(?:[^:]+: )?Where: ", line) is not None)


#: The verdict names at most this many parameters in a list; the parameters table has all.
VERDICT_NAMES = 5


def _some(names: list[str]) -> str:
    """The first few names, and how many more the parameters table lists."""
    if len(names) <= VERDICT_NAMES + 1:
        return ", ".join(names)
    return (", ".join(names[:VERDICT_NAMES]) + f" and {len(names) - VERDICT_NAMES} more (the "
            "parameters table lists them)")


def verdict_of(report: dict) -> Verdict:
    """:class:`Verdict` of ``report`` (:func:`report_dict`)."""
    confs = report["configurations"]
    free = [p for p in report["parameters"] if not p["held"]]
    moved = sorted(free, key=lambda p: -abs(p["p"]))[:5]
    moved_text = ("Moved most (change from the nominal, ± the posterior standard deviation): "
                  + (", ".join(f"{p['name']} {100 * p['p']:+.2f} % (± "
                               f"{100 * p['posterior_std_p']:.2g} %"
                               f"{', identifiable' if p['identifiable'] else ''})"
                               for p in moved) or "nothing (every parameter held)") + ".")
    doubts = [f"{c['name'] + ': ' if len(confs) > 1 else ''}Suspect channels (misfit over "
              f"{STANDOUT_FACTOR:g} times the median channel's; the suspect-channel table "
              "says more): " + "; ".join(x["brief"] for x in c["suspects"]) + "."
              for c in confs if c.get("suspects")]  # fmt: skip
    weak = [p["name"] for p in free if not p["identifiable"]]
    held = [p["name"] for p in report["parameters"] if p["held"]]
    if weak:
        doubts.append(f"{len(weak)} calibrated parameter{'s' * (len(weak) > 1)} the test "
                      f"informs only weakly (posterior standard deviation over "
                      f"{100 * report['posterior']['identifiable_below']:g} % of the prior's): "
                      f"{_some(weak)}; their values lean on the prior.")  # fmt: skip
    if held:
        doubts.append(f"{len(held)} parameter{'s' * (len(held) > 1)} the test cannot inform, "
                      f"held at the nominal: {_some(held)}.")  # fmt: skip
    trust = report.get("trust", [])
    doubts += [x for x in trust if _is_warning(x)]
    return Verdict([(c["name"], _before_after(c)) for c in confs], moved_text,
                   doubts or ["Nothing stands out."], [x for x in trust if not _is_warning(x)])


def report_texts(report: dict) -> ReportTexts:
    """The report's words and tables for the PDF, as the page has them."""
    from ..viz.report_pdf import ConfigurationTexts, ReportTexts

    v = verdict_of(report)
    ho = report.get("holdout")
    holdout = None
    if ho is not None:
        text, rows = holdout_parts(ho)
        holdout = (text, HOLDOUT_HEAD, rows)
    confs = [ConfigurationTexts(test_text(c), misfit_text(c), suspects_text(c), SUSPECT_HEAD,
                                suspect_rows(c),
                                model_form_tables(c["model_form"]) if c.get("model_form")
                                else []) for c in report["configurations"]]  # fmt: skip
    return ReportTexts(VERDICT_HEAD, v.tables, v.moved, v.doubts, v.rest, holdout, confs,
                       runs_tables(report))


def verdict_html(report: dict) -> str:
    """The block that opens the page (:func:`verdict_of`): per configuration the frequency
    errors, MAC and misfit before and after, then what moved most and what to doubt, then
    the rest of the trust summary."""
    v = verdict_of(report)
    several = len(v.tables) > 1
    tables = "".join((f"<p><b>{html.escape(name)}</b></p>" if several else "")
                     + _table(rows, VERDICT_HEAD) for name, rows in v.tables)  # fmt: skip
    return (f"<section id='verdict' class='verdict'><h2>Verdict</h2>{tables}"
            f"<p>{html.escape(v.moved)}</p><p><b>What to doubt</b></p><ul class='doubt'>"
            + "".join(f"<li>{html.escape(d)}</li>" for d in v.doubts)
            + "</ul><p><b>What holds</b></p><ul class='summary'>"
            + "".join(f"<li>{html.escape(x)}</li>" for x in v.rest)
            + "</ul></section>")  # fmt: skip


#: The runs tables' headers.
CYCLES_HEAD = ["cycle", "step", "full-model deviation at the candidate",
               "actual / predicted fall", "trust radius", "largest change (informed parameters)",
               "search again: best deviation (surrogate)"]  # fmt: skip
STARTS_HEAD = ["start", "objective: first point", "objective: last point",
               "deviation at the last point", "iterations", "seconds", "stop"]


def runs_tables(report: dict) -> list[tuple[str, list[str], list[list[str]]]]:
    """The runs' tables, each (what it shows, header, rows): the cycles, and cycle 1's
    starts."""
    cyc = [[c["cycle"], "multi-start" if c["cycle"] == 1 else
            ("kept" if c["accepted"] else "rejected")
            + (" (search candidate)" if c.get("from_search") else ""),
            _f(c.get("exact_deviation_at_candidate", c.get("exact_deviation_at_center")), ".6g"),
            _f(c.get("rho"), ".2f"), _f(c.get("radius"), ".3g"),
            _f(c.get("moved_informed", c.get("moved")), ".2e"),
            _f(c.get("search_best_deviation"), ".6g") if c.get("searched") else ""]
           for c in report["cycles"]]  # fmt: skip
    # like beside like: the objective at each start's first and last point, then the
    # deviation there
    starts = [[s["start"] + 1, f"{s['history'][0]:.6g}", f"{s['history'][-1]:.6g}",
               f"{s['deviation']:.6g}", s["iterations"], f"{s['seconds']:.1f}", s["message"]]
              for s in report["starts"]]  # fmt: skip
    return [("Each cycle: its step, the full model's deviation at the candidate, the trust "
             "region's ratio and radius.", CYCLES_HEAD, [[str(x) for x in r] for r in cyc]),
            ("Each start of cycle 1 on the surrogate: the objective it minimises where it "
             "started and where it stopped, and the deviation there. The objective is "
             + ("the data's Huber loss (the squared residuals within "
                f"{report['huber_c']:g} robust standard deviations, growing linearly beyond) "
                if report.get("loss") == "huber" else "the deviation ")
             + "plus the prior's term; the deviation is the plain sum of the squared "
             "residuals" + (", which counts the few large ones near antiresonances in full, "
                            "so it can exceed the objective" if report.get("loss") == "huber"
                            else "") + ".", STARTS_HEAD,
             [[str(x) for x in r] for r in starts])]


def write_html(path: Path, report: dict, figures: list[ReportFigure],
               head: dict | None = None, viewers: dict[str, str] | None = None
               ) -> Path:  # fmt: skip
    """The HTML page, one file: the header (``head``, :func:`femcal.io.html.provenance`:
    version, date, command, input files with sizes and digests) and the list of figures, the
    trust summary, then the parameters, each configuration's test, modes and figures, and
    the runs. ``figures`` are numbered in the page's order (the whole calibration's first,
    then each configuration's) and embedded as PNG data URIs; ``viewers`` maps a
    configuration's name to its 3-D viewer of the paired modes (:func:`paired_viewer`)."""
    from ..viz.webview import viewer_assets

    viewers = viewers or {}
    style, script = viewer_assets() if any(viewers.values()) else ("", "")

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
    truth = any(c.get("truth") for c in report["configurations"])
    if truth and any("true" in p for p in report["parameters"]):  # a synthetic test
        for row, p in zip(prm, report["parameters"], strict=True):
            row += [_f(p.get("true"), ".6g"), _f(p.get("error_pct"), "+.2f"),
                    _f(p.get("error_over_std"), ".1f")]  # fmt: skip
        prm_head += ["true", "error %", "|error| / posterior std"]
    why = "".join(f"<li><b>{html.escape(p['name'])}</b>: {html.escape(p['reason'])}</li>"
                  for p in report["parameters"])  # fmt: skip
    (_, cyc_head, cyc), (starts_text, starts_head, starts) = runs_tables(report)
    dev = report["deviation"]
    confs = report["configurations"]
    several = len(confs) > 1
    sections = "".join(_configuration_html(c, [f for f in figures if f.case == c["name"]],
                                           several, viewers.get(c["name"], ""))
                       for c in confs)  # fmt: skip
    contents = "".join(f"<li><a href='#figure-{f.number}'>Figure {f.number}</a>. "
                       f"{html.escape(f.title)}</li>" for f in figures)  # fmt: skip
    nav = "".join(f", <a href='#test-{html.escape(c['name'])}'>"
                  f"{html.escape(c['name']) if several else 'test'}</a>" for c in confs)
    page = f"""<!DOCTYPE html><html><head><meta charset="utf-8"><title>femcal calibration</title>
<meta name="viewport" content="width=device-width, initial-scale=1">
<style>{PAGE_STYLE}
figure.mode{{width:48%;display:inline-block;vertical-align:top;margin:0.5em 1% 0.5em 0}}
</style>{style}</head><body>
<h1>femcal calibration</h1>
{verdict_html(report)}
<p class="nav">On this page: <a href="#parameters">parameters</a>{nav}{
", <a href='#holdout'>held-out validation</a>" if report.get("holdout") else ""},
<a href="#runs">runs</a>, <a href="#provenance">provenance and figures</a>.</p>
<p>Metric {report['metric']}, {'Huber' if report.get('loss') == 'huber' else 'least-squares'}
loss; {len(confs)} configuration{'s' if several else ''}
({html.escape(', '.join(c['name'] for c in confs))}); deviation (the sum of the squared log10
residuals) {dev['before']:.6g} before, after {dev['after']:.6g}{'' if report['settled'] else
'; the parameters had not settled when the cycles ran out'}. Run time
{report['seconds']:.0f} s.</p>
<h2 id='parameters'>Parameters</h2>{_table(prm, prm_head)}
<p>The estimate is the posterior's maximum: the prior is each parameter's standard deviation
(the bounds at {report['prior']['bounds_sigma']:g} standard deviations, or the parameter file's
confidence), the likelihood weighs each test's residuals by their standard deviation and
effective number of independent observations (see each configuration below){
f", under Huber's loss (quadratic within {report['huber_c']:g} robust standard deviations, "
"linear beyond, so antiresonance outliers do not set the parameters)"
if report.get('loss') == 'huber' else ''}. Identifiable:
the posterior standard deviation below {100 * report['posterior']['identifiable_below']:g} % of
the prior's; held: the test cannot narrow the prior by more than
{100 * (1 - report['posterior']['hold_ratio']):g} %.{
" True values from a synthetic test's file." if truth else ""}</p>
<ul>{why}</ul>
{''.join(_figure(f) for f in figures if f.case is None)}
{_holdout_html(report.get("holdout"))}
{_augmented_html(report)}
{sections}
<h2 id='runs'>Runs</h2><p>Cycle 1 runs Levenberg-Marquardt from every start on the nominal model's
surrogate; each later cycle rebuilds the surrogate at the candidate point, where it is the full
model, keeps the step if the full model's cost fell (trust region) and runs LM again inside the
trust radius. When a kept step lowers the cost by less than {
100 * report.get('restart_fall', 0):g} %, or the cycles settle, the multi-start search runs again
on the current surrogate ({report.get('restarts', 0)} times here); a lower minimum elsewhere is
the next candidate.</p>{_table(cyc, cyc_head)}
<p>{html.escape(starts_text)}</p>
{_table(starts, starts_head)}
<h2 id='provenance'>Provenance</h2>
{html_header(head) if head is not None else ''}
{f'<p>Figures:</p><ul class="contents">{contents}</ul>' if contents else ''}
{script}
</body></html>
"""
    return write_atomic(path, lambda tmp: Path(tmp).write_text(page))


def _mode_caption(case: CaseResult, index: int) -> str:
    """The caption of the rendering of the calibrated model's mode ``index`` (0-based): the
    test modes it is paired with."""
    hz = case.modes_after.frequencies_hz[index]
    pairs = [m for m in case.modes if m.fe_after == index + 1]
    paired = "; ".join(f"test mode {m.test_mode} ({m.test_hz:.3f} Hz, frequency error "
                       f"{_f(m.frequency_error_after_pct, '+.2f')} %, MAC "
                       f"{_f(m.mac_after, '.3f')})" for m in pairs)  # fmt: skip
    return (f"FE mode {index + 1} of the calibrated model, {hz:.3f} Hz, paired with {paired}: "
            "the deformed shape coloured by its displacement magnitude (normalised to the "
            "largest, no unit) over the undeformed mesh (grey), in an isometric view.")


def write_report(result: CalibrationResult, out: str | os.PathLike[str], *,
                 progress: Callable[[str], None] | None = None, command: str | None = None,
                 pdf: bool = True) -> Path:  # fmt: skip
    """The pictures (``out/pictures``: parameters, history, and per configuration FRFs, MAC,
    paired shapes and renderings of the calibrated paired modes), ``out/report.html`` (one
    file: every picture embedded, nothing referred to) and, with ``pdf``, ``out/report.pdf``
    (:func:`femcal.viz.report_pdf.write_report_pdf`), both headed by femcal's version, the
    time, ``command`` (the femcal command line this process runs when None and known) and the
    input files with their sizes and SHA-256 digests; returns the page's path."""
    from ..viz import calibration as pictures_of
    from ..viz.render import render_modes

    say = progress or (lambda _m: None)
    out = Path(out)
    pics = out / "pictures"
    pics.mkdir(parents=True, exist_ok=True)
    several = len(result.cases) > 1
    # the charts (Matplotlib) are drawn in a process of their own while the paired modes are
    # rendered (VTK) here: both are one core's work (drawn here in turn on one core)
    renders: dict[str, tuple[list[int], list[Path]]] = {}
    with beside(pictures_of.report_pictures, result, pics) as charts:
        for case in result.cases:
            which = sorted({m.fe_after - 1 for m in case.modes if m.fe_after is not None})
            if which:
                say(f"{case.name}: rendering the calibrated model's paired modes")
                renders[case.name] = (which, render_modes(
                    case.modes_after, case.model,
                    pics / (f"modes_{case.name}" if several else "modes"),
                    title="calibrated", which=which, window=(960, 600)))  # fmt: skip
        drawn = result_of(charts.future, "the report's charts")
    figures: list[ReportFigure] = []

    def add(title: str, path: Path, caption: str, case: str | None, mode: bool = False) -> None:
        figures.append(ReportFigure(len(figures) + 1, title, path, caption, case, mode))

    for f in drawn:
        if f.case is None:
            add(f.title, f.path, f.caption, None)
    for case in result.cases:
        at = f" ({case.name})" if several else ""
        for f in drawn:
            if f.case == case.name:
                add(f.title + at, f.path, f.caption, case.name)
        which, pngs = renders.get(case.name, ([], []))
        for k, png in zip(which, pngs, strict=True):
            add(f"Calibrated mode {k + 1}, "
                f"{case.modes_after.frequencies_hz[k]:.2f} Hz{at}", png,
                _mode_caption(case, k), case.name, mode=True)  # fmt: skip
    report = report_dict(result)
    head = provenance(report_inputs(result), command=command)
    viewers: dict[str, str] = {}
    for case in result.cases:
        viewers[case.name] = paired_viewer(case, n=sum(map(bool, viewers.values())))
    page = write_html(out / "report.html", report, figures, head, viewers)
    written = [page.name]
    if pdf:
        from ..viz.report_pdf import write_report_pdf

        say("writing report.pdf")
        groups: dict[int, str] = {}
        for f in figures:  # the page's heading over each configuration's mode renderings
            if f.mode and not any(g.mode and g.case == f.case for g in figures[:f.number - 1]):
                groups[f.number] = "Paired modes after calibration"
        doc = write_report_pdf(out / "report.pdf", report, head,
                               [(f.number, f.title, f.path, f.caption) for f in figures],
                               headings=groups, texts=report_texts(report))  # fmt: skip
        written.append(f"{doc.path.name} ({len(doc.pages)} pages)")
    say(f"wrote {' and '.join(written)} in {out} with {len(figures)} figures (also in "
        f"{pics})")
    return page
