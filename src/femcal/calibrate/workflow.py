"""The reference study's calibration, end to end (FEMCali's method, Abrahamsson and Kammer):

1. the test FRFs are identified (:func:`femcal.identify.identify`), or an identified model
   is read; channels the identification calls suspect are left out;
2. damping equalisation: every test pole gets the damping zeta0 (the median identified
   damping by default) with its damped frequency kept, and every FE mode gets modal damping
   zeta0, so mass and stiffness parameters are calibrated without pairing modes;
3. frequencies at equal logarithmic steps, a few per half-power bandwidth 2 zeta0 w;
4. the FE model is reduced on its modes at the current point (with static
   eigenvector-derivative vectors of the modes up to ``enrich_hz``, and with ``residual``
   the static responses to the inputs for the residual flexibility), with the exact
   polynomial dependence of K and M on the parameters (or FEMCali's first-order form)
   (:mod:`femcal.calibrate.surrogate`);
5. Levenberg-Marquardt within the bounds on the log-FRF deviation, from Latin hypercube
   starts (the nominal among them) in parallel processes; the best minimum wins;
6. trust-region cycles: the surrogate is rebuilt at the candidate, where it is the full
   model; the step is kept if the full model's cost fell, and LM runs again within the trust
   radius, until the parameters the CRLB calls informed move less than ``settle`` (or the
   radius falls below it, or ``max_cycles`` is reached); when a kept step lowers the full
   model's cost by less than ``restart_fall``, or the cycles settle, the multi-start search
   runs again over the whole box on the current surrogate (at most ``restarts`` times), and
   its best start is the next candidate (the full model decides again): a local minimum the
   cycles have reached is left when a search on the newer surrogate finds a lower one;
7. the calibrated model is solved in full; frequencies, MAC and the deviation before and
   after, the Cramér-Rao bounds at the solution, and the calibrated deck are written.
"""

from __future__ import annotations

import hashlib
import json
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..correlate.shapes import mac, pair_modes, pseudo_orthogonality, serep_mass
from ..deck import read_deck
from ..identify import Settings, equalize_damping, identify
from ..io.atomic import write_atomic
from ..io.identified import read_model, write_model, write_summary
from ..model.build import build_model
from ..response.frf import channel_matrix
from ..testdata.data import FRFData, convert_units
from ..testdata.formats import read_frf
from .config import Config
from .derivatives import group_polynomials
from .fisher import fisher
from .gradient import first_order_correction
from .lm import latin_hypercube
from .metric import deviation, log_frequencies, residuals
from .parameters import Parameter, read_parameters, read_truth, write_calibrated_deck
from .reduction import build_surrogate
from .starts import Problem, run_starts


@dataclass
class Outcome:
    """Everything the report needs (arrays kept for the pictures)."""

    report: dict
    params: list[Parameter]
    p_final: np.ndarray
    freq: np.ndarray
    H_test: np.ndarray
    H_before: np.ndarray
    H_after: np.ndarray
    outputs: tuple
    inputs: tuple
    data: FRFData
    identified: object
    modes_before: object
    modes_after: object
    model: object
    fisher: object
    mac_before: np.ndarray
    mac_after: np.ndarray
    test_hz: np.ndarray
    test_shapes: np.ndarray


#: Changes whenever the surrogate's construction does, so that finished starts of an older
#: version are not resumed.
SURROGATE_VERSION = 7  # 5: CQUAD4 residual bending flexibility, raised-degree fits; 6: CQUAD4 /
# CTRIA3 membranes and CTRIA3 residual bending flexibility, CQUAD8 / CTRIA6 transition shear,
# tapered-beam lumped mass; 7: the TETRA10 5-point stiffness rule, the tapered CBEAM's 3-point
# flexibility rule (a resumed run must not mix element formulations)


def _fingerprint(cfg: Config, extra: str) -> str:
    raw = {k: v for k, v in cfg.raw.items() if k != "test"}
    raw["test"] = {k: v for k, v in cfg.raw.get("test", {}).items() if k != "truth"}
    text = json.dumps(raw, sort_keys=True, default=str) + extra  # (the truth is report only)
    for f in (cfg.deck, cfg.parameters, cfg.test_frf, cfg.test_model):
        if f is not None:
            text += hashlib.sha256(Path(f).read_bytes()).hexdigest()
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _test_side(cfg: Config, out: Path, say: Callable[[str], None]):
    """(data, identified model or None, kept output indices)."""
    data = read_frf(cfg.test_frf) if cfg.test_frf is not None else None
    if data is not None and cfg.model_units and data.units and data.units != cfg.model_units:
        data = convert_units(data, cfg.model_units)
        say(f"test FRFs converted to {cfg.model_units}")
    ident = None
    if cfg.identify is not None:
        s = cfg.identify
        say(f"identifying the test FRFs over {s.band[0]:g}-{s.band[1]:g} Hz")
        ident = identify(data, s.band, splits=s.splits, orders=s.orders,
                         settings=Settings(gamma=s.gamma, beta=s.beta, max_order=s.max_order),
                         progress=say)  # fmt: skip
        write_model(out / "identify" / "model.npz", ident)
        write_summary(out / "identify" / "identify.json", ident)
    elif cfg.test_model is not None:
        ident = read_model(cfg.test_model)
        say(f"identified test model read from {cfg.test_model}")
        if cfg.model_units and ident.units and ident.units != cfg.model_units:
            raise ValueError(f"{cfg.test_model}: the identified model is in {ident.units}, the "
                             f"FE model in {cfg.model_units}")  # fmt: skip
    n_out = len(ident.outputs) if ident is not None else len(data.outputs)
    keep = np.ones(n_out, bool)
    if ident is not None and cfg.exclude_suspect_channels and ident.suspect.any():
        keep = ~ident.suspect
        say("suspect channels left out: "
            + ", ".join(ident.outputs[i].label for i in np.flatnonzero(ident.suspect)))
    return data, ident, keep


def _test_frfs(data: FRFData | None, ident, keep: np.ndarray, zeta0: float,
               freq: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """(frequencies, H_X (n_out, n_in, n_f)): the damping-equalised identified model at
    ``freq``, or, without an identified model, the measured FRFs at the measured frequencies
    nearest to ``freq`` (no interpolation: it would bend the resonance peaks)."""
    if ident is not None:
        return freq, equalize_damping(ident, zeta0).frf(freq).H[keep]
    f = data.frequency_hz
    if freq[0] < f[0] * (1 - 1e-9) or freq[-1] > f[-1] * (1 + 1e-9):
        raise ValueError(f"the calibration band {freq[0]:g}-{freq[-1]:g} Hz lies outside the "
                         f"test data ({f[0]:g}-{f[-1]:g} Hz)")  # fmt: skip
    pos = np.clip(np.searchsorted(f, freq), 1, len(f) - 1)
    idx = np.unique(np.where(freq - f[pos - 1] <= f[pos] - freq, pos - 1, pos))
    return f[idx], data.H[keep][:, :, idx]


def run(cfg: Config, out: str | Path, *, fresh: bool = False, workers: int | None = None,
        starts: int | None = None,
        progress: Callable[[str], None] | None = None) -> Outcome:  # fmt: skip
    """Run the calibration of ``cfg`` into the folder ``out`` (see the module docstring).

    ``fresh`` ignores finished starts of an earlier run; ``workers`` and ``starts``
    override the configuration's.
    """
    say = progress or (lambda _m: None)
    t0 = time.perf_counter()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    n_workers = workers or cfg.workers
    n_starts = starts or cfg.starts
    deck = read_deck(cfg.deck)
    model = build_model(deck)
    params = read_parameters(cfg.parameters, model)
    # a synthetic test's known values, for the report only (read now: a bad file fails fast)
    truth = read_truth(cfg.test_truth, params) if cfg.test_truth is not None else None
    lo = np.array([p.p_lower for p in params])
    hi = np.array([p.p_upper for p in params])
    say(f"{cfg.deck.name}: {model.n_dof} DOF; {len(params)} parameters from "
        f"{cfg.parameters.name}")
    data, ident, keep = _test_side(cfg, out, say)
    source = ident if ident is not None else data
    outputs = tuple(c for c, k in zip(source.outputs, keep, strict=True) if k)
    inputs = tuple(source.inputs)
    quantity = source.quantity
    band = cfg.band
    if ident is not None:
        sel = (ident.frequency_hz >= band[0]) & (ident.frequency_hz <= band[1])
        if not sel.any():
            raise ValueError(f"no identified test mode lies in the calibration band "
                             f"{band[0]:g}-{band[1]:g} Hz")  # fmt: skip
        test_hz, test_shapes = ident.frequency_hz[sel], ident.shapes[keep][:, sel]
        zeta0 = cfg.zeta0 or float(np.median(ident.damping_ratio[sel]))
    else:
        test_hz, test_shapes = np.zeros(0), np.zeros((len(outputs), 0))
        zeta0 = float(cfg.zeta0)
    freq = log_frequencies(band[0], band[1], zeta0, cfg.samples_per_bandwidth)
    freq, H_test = _test_frfs(data, ident, keep, zeta0, freq)
    if (np.abs(H_test) == 0).any():
        raise ValueError("the test FRFs are zero somewhere in the band: the log metric needs "
                         "nonzero values")  # fmt: skip
    say(f"metric: {cfg.metric} over {band[0]:g}-{band[1]:g} Hz, {len(freq)} frequencies "
        f"({cfg.samples_per_bandwidth:g} per half-power bandwidth at zeta0 = {zeta0:.4f}), "
        f"{len(outputs)} outputs x {len(inputs)} inputs")  # fmt: skip
    data_hash = hashlib.sha256(freq.tobytes() + H_test.tobytes()).hexdigest()
    fp = _fingerprint(cfg, f"{n_starts}-{SURROGATE_VERSION}-{cfg.enrich_hz}-"
                      f"{cfg.enrich_vectors}-{cfg.residual}-{cfg.modal_hz}-"
                      f"{cfg.exact_gradient}" + data_hash)  # fmt: skip
    state_path = out / "starts" / "cycles.json"
    rng = np.random.default_rng(cfg.seed)
    starts0 = [np.zeros(len(params))]
    if n_starts > 1:
        starts0 += list(latin_hypercube(n_starts - 1, lo, hi, rng))
    weights = cfg.regularization / ((hi - lo) / 2.0) if cfg.regularization > 0 else None

    say(f"the exact dependence of K and M on the {len(params)} parameters, element group by "
        "element group")
    polys = group_polynomials(model, params, np.zeros(len(params)), constant=True)

    frf_modes: list[int] = []  # the FRFs' mode count, fixed at the nominal model

    def surrogate_at(p: np.ndarray):
        say(f"surrogate at p = [{', '.join(f'{x:+.4f}' for x in p)}]")
        sur, modes = build_surrogate(
            model, params, p, outputs, inputs, n_modes=cfg.reduction_modes, zeta=zeta0,
            quantity=quantity, order=cfg.surrogate, polynomials=polys,
            enrich_hz=cfg.enrich_hz or None, n_enrich=cfg.enrich_vectors,
            residual=cfg.residual, frf_modes=frf_modes[0] if frf_modes else None,
            frf_hz=cfg.modal_hz if not frf_modes and cfg.modal_hz else None,
            exact_gradient=cfg.exact_gradient, progress=say)  # fmt: skip
        if not frf_modes:
            frf_modes.append(sur.n_frf)
            if cfg.modal_hz:
                top = float(sur.basis_hz[-1])
                which = (f"the {sur.n_frf} modes up to {cfg.modal_hz:g} Hz"
                         if cfg.modal_hz < top else
                         f"all {sur.n_frf} reduction modes (up to {top:.1f} Hz: modal_hz = "
                         f"{cfg.modal_hz:g} lies above them)")  # fmt: skip
                say(f"the FRFs sum {which} at the nominal" + (
                    ", the others as residual flexibility" if cfg.residual else ""))
        return sur, modes

    def problem_on(sur, lower: np.ndarray, upper: np.ndarray) -> Problem:
        corr = (first_order_correction(sur, sur.exact, freq, H_test, cfg.metric)
                if sur.exact is not None else None)  # fmt: skip
        return Problem(sur, freq, H_test, cfg.metric, lower, upper, cfg.max_iterations,
                       weights, corr)  # fmt: skip

    def starts_in(name: str, problem: Problem, pts: list[np.ndarray], center: np.ndarray):
        folder = out / "starts" / name
        if fresh and folder.is_dir():
            for f in folder.glob("start_*.json"):
                f.unlink()
        return run_starts(problem, pts, workers=n_workers, folder=folder,
                          fingerprint=fp + f"-{name}-" + ",".join(f"{x:.12g}" for x in center),
                          progress=say)  # fmt: skip

    def save_cycles() -> None:
        text = json.dumps(cycles, indent=1)
        write_atomic(state_path, lambda tmp: Path(tmp).write_text(text))

    # cycle 1: the multi-start search over the whole box on the nominal surrogate
    say("cycle 1: Levenberg-Marquardt from every start on the nominal model's surrogate")
    center = np.zeros(len(params))
    sur, modes_c = surrogate_at(center)
    modes0, sur0 = modes_c, sur
    problem = problem_on(sur, lo, hi)
    cost_c = problem.cost(center)
    results = starts_in("cycle1", problem, starts0, center)
    best = min(results, key=lambda r: r["cost"])
    cand, pred = np.array(best["p"]), best["cost"]
    cycles: list[dict] = [{"cycle": 1, "center": list(map(float, center)),
                           "best_start": best["start"] + 1, "p": list(map(float, cand)),
                           "deviation": best["deviation"], "exact_deviation_at_center":
                           problem.deviation(center), "moved": float(np.abs(cand).max()),
                           "accepted": True, "radius": None, "starts": results}]  # fmt: skip
    save_cycles()
    say(f"cycle 1: best start {best['start'] + 1}, deviation {best['deviation']:.5g} (surrogate)")
    # cycles 2...: trust region; the surrogate rebuilt at the candidate is the full model
    # there, which decides whether the step is kept
    radius = max(float(np.abs(cand - center).max()), cfg.settle)
    settled = False
    restarts_left = cfg.restarts if n_starts > 1 else 0
    searched = False  # the candidate came from a multi-start search over the whole box
    for c in range(2, cfg.max_cycles + 1):
        sur_new, modes_new = surrogate_at(cand)
        prob_new = problem_on(sur_new, lo, hi)
        cost_new = prob_new.cost(cand)
        predicted = cost_c - pred
        rho = (cost_c - cost_new) / predicted if predicted > 0 else 0.0
        accepted = cost_new < cost_c
        step = np.abs(cand - center)
        entry = {"cycle": c, "candidate": list(map(float, cand)), "rho": rho,
                 "accepted": accepted, "radius": radius, "from_search": searched,
                 "exact_deviation_at_candidate": prob_new.deviation(cand)}  # fmt: skip
        stalled, fall = False, 0.0
        if accepted:
            fi_c = fisher(*prob_new.data_jacobian(cand), sigma=cfg.noise_sigma)
            informed = np.isfinite(fi_c.crlb) & (fi_c.crlb <= cfg.identifiable_crlb)
            moved = float(step[informed].max() if informed.any() else step.max())
            fall = (cost_c - cost_new) / cost_c
            center, sur, modes_c, cost_c, problem = cand, sur_new, modes_new, cost_new, prob_new
            radius = min(2 * radius, 1.0) if rho > 0.75 else (radius / 2 if rho < 0.25 else radius)
            say(f"cycle {c}: step kept (full-model cost {cost_new:.5g}, {100 * fall:.3g} % "
                f"lower, ratio to the predicted fall {rho:.2f}); the informed parameters "
                f"moved {moved:.2e}")  # fmt: skip
            settled = moved < cfg.settle
            stalled = fall < cfg.restart_fall
        else:
            if not searched:  # a quarter of the rejected step (of the radius, if it filled it)
                radius = min(radius, float(step.max())) / 4.0
            moved = 0.0  # (a far search candidate says nothing about the local radius)
            say(f"cycle {c}: {'the search candidate' if searched else 'step'} rejected "
                f"(full-model cost {cost_new:.5g} against {cost_c:.5g}); trust radius "
                f"{radius:.3g}")  # fmt: skip
            settled = radius < cfg.settle
        entry["moved_informed"] = moved
        entry["center"] = list(map(float, center))
        last = c == cfg.max_cycles
        local, found = None, []
        if not settled and not last:  # the trust-region step from the centre
            box = replace(problem, lower=np.maximum(lo, center - radius),
                          upper=np.minimum(hi, center + radius))  # fmt: skip
            local = starts_in(f"cycle{c}", box, [center], center)[0]
        res, searched = local, False
        if (settled or stalled) and restarts_left > 0 and not last:
            restarts_left -= 1
            why = "settled" if settled else f"the cost fell by only {100 * fall:.3g} %"
            say(f"cycle {c}: {why}: the multi-start search runs again from {n_starts} new "
                f"starts on this surrogate ({restarts_left} more allowed)")  # fmt: skip
            found = starts_in(f"cycle{c}_search", problem,
                              list(latin_hypercube(n_starts, lo, hi, rng)), center)  # fmt: skip
            best = min(found, key=lambda r: r["cost"])
            ref = ((local["cost"], local["deviation"], np.array(local["p"])) if local
                   else (cost_c, problem.deviation(center), center))  # fmt: skip
            entry["search_best_deviation"] = best["deviation"]
            # another minimum: lower by restart_fall and elsewhere (not the same one again)
            if (best["cost"] < (1 - cfg.restart_fall) * ref[0]
                    and np.abs(np.array(best["p"]) - ref[2]).max() > cfg.settle):
                res, searched, settled = best, True, False
                say(f"cycle {c}: search start {best['start'] + 1} reaches a lower minimum "
                    f"(deviation {best['deviation']:.5g} on the surrogate against "
                    f"{ref[1]:.5g}): it is the next candidate")  # fmt: skip
            else:
                say(f"cycle {c}: the search found no lower minimum elsewhere (its best: "
                    f"deviation {best['deviation']:.5g} on the surrogate, at most "
                    f"{np.abs(np.array(best['p']) - ref[2]).max():.2g} from here in p; "
                    f"here {ref[1]:.5g})")  # fmt: skip
        entry["searched"] = bool(found)
        if res is None:  # settled, or the last cycle
            entry.update(p=list(map(float, center)), deviation=problem.deviation(center),
                         best_start=1)  # fmt: skip
            cycles.append(entry)
            save_cycles()
            break
        cand, pred = np.array(res["p"]), res["cost"]
        entry.update(p=list(map(float, cand)), deviation=res["deviation"],
                     best_start=res["start"] + 1,
                     starts=([local] if local else []) + found)  # fmt: skip
        cycles.append(entry)
        save_cycles()
    p_final = center
    values = np.array([par.value(p) for par, p in zip(params, p_final, strict=True)])
    # the full model at the solution is the last surrogate's centre
    modes_after = modes_c
    write_calibrated_deck(cfg.deck, params, values, out / f"{cfg.deck.stem}_calibrated.bdf")
    Cg = channel_matrix(model, outputs)
    # the full model's FRFs: each surrogate at its centre (the modal sum over the reduction
    # modes, with the residual flexibility if asked)
    H_before = sur0.frf(np.zeros(len(params)), freq)
    H_after = sur.frf(p_final, freq)
    dev_before = deviation(residuals(H_before, H_test, cfg.metric))
    dev_after = deviation(residuals(H_after, H_test, cfg.metric))
    J, r = problem.data_jacobian(p_final)
    fi = fisher(J, r, sigma=cfg.noise_sigma)
    per_band = []
    n_pairs = len(outputs) * len(inputs)
    for b in cfg.crlb_bands:
        rows_f = (freq >= b[0]) & (freq <= b[1])
        rows = np.tile(rows_f, n_pairs * (2 if cfg.metric == "complex-log" else 1))
        fb = fisher(J, r, sigma=fi.sigma, rows=rows)
        per_band.append({"band_hz": list(b), "crlb": list(map(float, fb.crlb))})
    fe_before = np.asarray(Cg @ modes0.shapes)
    fe_after = np.asarray(Cg @ modes_after.shapes)
    mac_b = mac(test_shapes, fe_before)
    mac_a = mac(test_shapes, fe_after)
    pairs_b = {pp.test: pp for pp in pair_modes(test_shapes, test_hz, fe_before,
                                                modes0.frequencies_hz)}  # fmt: skip
    pairs_a = {pp.test: pp for pp in pair_modes(test_shapes, test_hz, fe_after,
                                                modes_after.frequencies_hz)}  # fmt: skip
    # pseudo-orthogonality after calibration: mass reduced to the sensors by SEREP on the FE
    # modes up to 1.5 times the band's top (at most one less than the sensors)
    f_after = modes_after.frequencies_hz
    serep = np.flatnonzero(f_after <= 1.5 * band[1])[: max(len(outputs) - 1, 1)]
    poc = (pseudo_orthogonality(test_shapes, fe_after[:, serep], serep_mass(fe_after[:, serep]))
           if len(test_hz) else np.zeros((0, len(serep))))  # fmt: skip
    mode_rows = []
    for k, f in enumerate(test_hz):
        b, a = pairs_b.get(k), pairs_a.get(k)
        mode_rows.append({
            "test_mode": k + 1, "test_hz": float(f),
            "fe_before_mode": b.fe + 1 if b else None,
            "fe_before_hz": float(modes0.frequencies_hz[b.fe]) if b else None,
            "mac_before": b.mac if b else None,
            "fe_after_mode": a.fe + 1 if a else None,
            "fe_after_hz": float(modes_after.frequencies_hz[a.fe]) if a else None,
            "mac_after": a.mac if a else None,
            "frequency_error_before_pct": b.frequency_difference if b else None,
            "frequency_error_after_pct": a.frequency_difference if a else None,
            "pseudo_orthogonality_after": float(abs(poc[k, list(serep).index(a.fe)]))
            if a and a.fe in serep else None,
        })  # fmt: skip
    param_rows = []
    for i, par in enumerate(params):
        crlb_p = float(fi.crlb[i])
        param_rows.append({
            "name": par.name, "description": par.description, "card": par.card,
            "id": par.id, "field": par.field, "nominal": par.nominal,
            "calibrated": float(values[i]), "lower": par.lower, "upper": par.upper,
            "p": float(p_final[i]), "crlb": crlb_p * abs(par.nominal) if np.isfinite(crlb_p)
            else None, "crlb_p": crlb_p if np.isfinite(crlb_p) else None,
            "identifiable": bool(np.isfinite(crlb_p) and crlb_p <= cfg.identifiable_crlb),
            "at_bound": bool(np.isclose(p_final[i], lo[i], atol=1e-9)
                             or np.isclose(p_final[i], hi[i], atol=1e-9)),
        })  # fmt: skip
        if truth is not None:  # a synthetic test: the error against the known value
            p_true = truth[i] / par.nominal - 1.0
            param_rows[-1].update({
                "true": float(truth[i]), "true_p": float(p_true),
                "error_pct": float(100 * (values[i] / truth[i] - 1.0)),
                "error_over_crlb": float(abs(p_final[i] - p_true) / crlb_p)
                if np.isfinite(crlb_p) and crlb_p > 0 else None,
            })  # fmt: skip
    report = {
        "deck": str(cfg.deck), "parameters_file": str(cfg.parameters),
        "test": str(cfg.test_frf or cfg.test_model),
        "truth": str(cfg.test_truth) if cfg.test_truth is not None else None,
        "band_hz": list(band), "zeta0": zeta0, "metric": cfg.metric,
        "n_frequencies": len(freq), "outputs": [c.label for c in outputs],
        "inputs": [c.label for c in inputs],
        "excluded_channels": [c.label for c, k in zip(source.outputs, keep, strict=True) if not k],
        "parameters": param_rows, "modes": mode_rows,
        "deviation": {"before": dev_before, "after": dev_after,
                      "surrogate_history": [cyc["deviation"] for cyc in cycles]},
        "crlb": {"sigma": fi.sigma, "sigma_given": cfg.noise_sigma is not None,
                 "identifiable_below": cfg.identifiable_crlb, "per_band": per_band,
                 "correlation": [[None if not np.isfinite(v) else float(v) for v in row]
                                 for row in fi.correlation]},
        "cycles": [{k: v for k, v in cyc.items() if k != "starts"} for cyc in cycles],
        "regularization": cfg.regularization,
        "starts": [{k: v for k, v in s.items() if k != "fingerprint"}
                   for s in cycles[0]["starts"]],
        "settled": settled, "restarts": sum(bool(cyc.get("searched")) for cyc in cycles),
        "restart_fall": cfg.restart_fall,
        "reduction_modes": cfg.reduction_modes,
        "surrogate": cfg.surrogate, "enrich_hz": cfg.enrich_hz,
        "enrich_vectors": cfg.enrich_vectors, "residual": cfg.residual,
        "modal_hz": cfg.modal_hz, "frf_modes": frf_modes[0],
        "exact_gradient": cfg.exact_gradient,
        "model_dof": model.n_dof, "seconds": time.perf_counter() - t0,
        "calibrated_deck": f"{cfg.deck.stem}_calibrated.bdf",
    }  # fmt: skip
    text = json.dumps(report, indent=1)
    write_atomic(out / "report.json", lambda tmp: Path(tmp).write_text(text + "\n"))
    say(f"deviation {dev_before:.5g} -> {dev_after:.5g}; wrote {out / 'report.json'}")
    return Outcome(report, params, p_final, freq, H_test, H_before, H_after, outputs, inputs,
                   data, ident, modes0, modes_after, model, fi, mac_b, mac_a, test_hz,
                   test_shapes)  # fmt: skip
